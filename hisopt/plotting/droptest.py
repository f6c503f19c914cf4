"""Figures of drop-test response spectra (paper Fig. 13), from the data handed to them.

A test's spectrum is a mapping with ``case`` (``"front_axle"``, ``"left_side"`` or
``"all_wheels"``), ``p0_pa`` [Pa], ``source`` (``"simulated"`` or ``"measured"``), ``mode``
(the model mode the test's signal is), ``f_hz`` [Hz] and ``magnitude`` [unit s] (amplitude
spectrum of the test's body coordinate, see :meth:`hisopt.simulation.droptest.DropTest.spectrum`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from hisopt.plotting.theme import template

if TYPE_CHECKING:
    import plotly.graph_objects as go

F_MAX_HZ = 10.0
"""[Hz] Highest frequency drawn: the body modes lie below, the 20 Hz low-pass above."""

CASE_ORDER = ("left_side", "front_axle", "all_wheels")
"""Panel order of :func:`drop_spectra_figure`: roll, pitch, bounce as in paper Fig. 13."""

ACCELERATION_UNITS = {"bounce": "m/s", "roll": "rad/s", "pitch": "rad/s"}
"""Unit of the amplitude spectrum of each body coordinate's acceleration."""


def drop_spectrum_figure(test: Mapping[str, Any], fig: go.Figure | None = None, row: int | None = None) -> go.Figure:
    """One test's response spectrum up to :data:`F_MAX_HZ`, one trace (dashed if measured).

    Parameters
    ----------
    test
        the test's spectrum (module docstring)
    fig
        figure to add the trace to; ``None`` makes a new one
    row
        subplot row of ``fig`` (column 1); ``None`` for a figure without subplots
    """
    import plotly.graph_objects as go

    fig = go.Figure(layout={"template": template()}) if fig is None else fig
    f, mag = test["f_hz"], test["magnitude"]
    keep = f <= F_MAX_HZ
    dash = "dash" if test["source"] == "measured" else "solid"
    fig.add_scatter(
        x=f[keep],
        y=mag[keep],
        name=f"p0 = {test['p0_pa'] / 1e6:g} MPa ({test['source']})",
        line={"dash": dash},
        legendgroup=test["case"],
        legendgrouptitle_text=f"{test['case']} drop ({test['mode']})",
        **({"row": row, "col": 1} if row is not None else {}),
    )
    return fig


def drop_spectra_figure(tests: Sequence[Mapping[str, Any]], case_modes: Mapping[str, str]) -> go.Figure:
    """Response spectra of drop tests, one panel per case present (paper Fig. 13).

    Parameters
    ----------
    tests
        each test's spectrum (module docstring)
    case_modes
        the body mode (``bounce``, ``roll``, ``pitch``) each case is meant to excite
    """
    from plotly.subplots import make_subplots

    present = [c for c in CASE_ORDER if any(t["case"] == c for t in tests)]
    titles = [f"{case_modes[c]} response ({c.replace('_', ' ')} drop)" for c in present]
    fig = make_subplots(rows=max(len(present), 1), cols=1, subplot_titles=titles, vertical_spacing=0.08)
    for row, case in enumerate(present, start=1):
        for test in (t for t in tests if t["case"] == case):
            drop_spectrum_figure(test, fig, row=row)
        mode = case_modes[case]
        fig.update_yaxes(title_text=f"|{mode} acc.| [{ACCELERATION_UNITS[mode]}]", row=row, col=1)
    fig.update_xaxes(title_text="frequency [Hz]", row=len(present), col=1)
    fig.update_layout(
        template=template(),
        title="Drop-test response spectra (20 Hz low-pass, free decay)",
        height=320 * max(len(present), 1) + 120,
        legend={"groupclick": "toggleitem"},
    )
    return fig
