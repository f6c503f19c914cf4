"""Screening HIS layouts: the stiffness and damping each adds to the four stroke patterns.

``hisopt layouts [PROBLEM]`` and :func:`mode_stiffness` list the catalogue (and a problem's
custom layout) with, at the problem's baseline values, what each layout adds to the car's
suspension in the four stroke patterns (docs/model.md §12.4)::

    bounce  u = ( 1,  1,  1,  1)        pitch  u = ( 1,  1, -1, -1)
    roll    u = ( 1, -1,  1, -1)        warp   u = ( 1, -1, -1,  1)

(strokes of FL, FR, RL, RR, extension positive; roll: the left side extends, pitch: the
front extends). "Per unit modal stroke" means per metre of the pattern's amplitude ``x`` in
``delta = x u``: each strut moves ``x``. The static stiffness of a pattern is
``u^T K_his u`` [N/m] (``K_his = lim_{s->0} D(s)``; the work-conjugate force per metre of
``x``), its low-frequency damping ``u^T C_lf u`` [N s/m] with
``C_lf = lim_{s->0} (D(s) - K_his) / s`` (:func:`hisopt.hydraulics.network.low_frequency_damping`).
``stiffness_coupling`` is the largest ``|U^T K U|_ij / sqrt(|U^T K U|_ii |U^T K U|_jj)`` between two
patterns (0: the patterns stay uncoupled statically).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from hisopt.arguments import problem_argument
from hisopt.hydraulics.catalogue import CUSTOM, catalogue, his_layout, his_parameter_values
from hisopt.hydraulics.coupling import HydraulicSystem
from hisopt.hydraulics.network import compile_network
from hisopt.units import NO_UNIT, with_units

if TYPE_CHECKING:
    from hisopt.hydraulics.roll_plane import RollPlaneHIS
    from hisopt.specification.design_space import DesignSpace

STROKE_PATTERNS: dict[str, tuple[float, float, float, float]] = {
    "bounce": (1.0, 1.0, 1.0, 1.0),
    "roll": (1.0, -1.0, 1.0, -1.0),
    "pitch": (1.0, 1.0, -1.0, -1.0),
    "warp": (1.0, -1.0, -1.0, 1.0),
}
"""Unit stroke patterns (FL, FR, RL, RR; extension positive), see the module docstring."""


def pattern_matrix() -> np.ndarray:
    """[-] ``U``: the stroke patterns as rows, shape ``(4, 4)`` (bounce, roll, pitch, warp)."""
    return np.array(list(STROKE_PATTERNS.values()))


def layout_his(his: RollPlaneHIS, name: str) -> RollPlaneHIS:
    """``his`` with catalogue layout ``name`` (the problem's own table for its own layout);
    ``[his.parameters]`` entries the other layout does not read are dropped."""
    if name == his.layout:
        return his
    defaults = catalogue()[name].parameters
    params = {k: v for k, v in his.parameters.items() if k in defaults}
    return his.model_copy(update={"layout": name, "circuits": None, "parameters": params})


def layout_system(his: RollPlaneHIS) -> HydraulicSystem:
    """The HIS of a ``[his]`` table at its own values (lumped pipes), one design."""
    return HydraulicSystem(compile_network(his_layout(his), "lumped"), his_parameter_values(his))


def pattern_properties(system: HydraulicSystem) -> dict[str, float]:
    """Static stiffness [N/m], low-frequency damping [N s/m] per unit stroke pattern and the
    largest static coupling between patterns [-] of a one-design HIS (module docstring)."""
    k = np.asarray(system.static_stiffness(), dtype=float).reshape(1, 4, 4)
    c = np.asarray(system.low_frequency_damping(), dtype=float).reshape(1, 4, 4)
    return {name: float(values[0]) for name, values in pattern_table(k, c).items()}


def pattern_table(k_his: np.ndarray, c_lf: np.ndarray) -> dict[str, np.ndarray]:
    """The screening columns of a batch: ``k_his`` [N/m] and ``c_lf`` [N s/m] of shape
    ``(B, 4, 4)`` (stroke stiffness and low-frequency damping) -> ``k_bounce`` .. ``c_warp``
    and ``stiffness_coupling``, each of shape ``(B,)`` (module docstring)."""
    u = pattern_matrix()
    k = u @ k_his @ u.T
    c = u @ c_lf @ u.T
    diag = np.abs(np.diagonal(k, axis1=-2, axis2=-1))
    scale = np.sqrt(diag[:, :, None] * diag[:, None, :])
    ratio = np.divide(np.abs(k), scale, out=np.zeros_like(k), where=scale > 0)
    ratio[ratio < 1e-12] = 0.0  # round-off of patterns that are exactly uncoupled
    upper = np.triu_indices(4, 1)
    out = {f"k_{name}": k[:, i, i] for i, name in enumerate(STROKE_PATTERNS)}
    out |= {f"c_{name}": c[:, i, i] for i, name in enumerate(STROKE_PATTERNS)}
    out["stiffness_coupling"] = np.max(ratio[:, upper[0], upper[1]], axis=-1)
    return out


def mode_stiffness(problem: DesignSpace | None = None) -> pd.DataFrame:
    """The catalogue's screening table at a problem's baseline values (module docstring).

    One row per catalogue layout, plus the problem's own layout when it is custom; columns
    ``layout``, ``k_bounce``, ``k_roll``, ``k_pitch``, ``k_warp`` [N/m], ``c_bounce``, ...
    [N s/m], ``stiffness_coupling`` [-] and ``summary``; units in ``attrs["units"]``.

    Parameters
    ----------
    problem : DesignSpace | None, optional
        the problem whose ``[his]`` values (the baseline design) are used; None: the
        default problem's (docs/model.md §3.6)
    """
    from hisopt.hydraulics.roll_plane import RollPlaneHIS

    if problem is not None:
        problem_argument(problem)
    his = problem.spec.his if problem is not None else RollPlaneHIS()
    rows = []
    names = list(catalogue()) + ([CUSTOM] if his.layout == CUSTOM else [])
    for name in names:
        summary = catalogue()[name].summary if name in catalogue() else "the problem's custom layout ([[his.circuits]])"
        rows.append({"layout": name, **pattern_properties(layout_system(layout_his(his, name))), "summary": summary})
    frame = pd.DataFrame(rows)
    units = {"layout": NO_UNIT, "summary": NO_UNIT, "stiffness_coupling": NO_UNIT}
    units |= {c: "N/m" for c in frame.columns if c.startswith("k_")} | {c: "N s/m" for c in frame.columns if c.startswith("c_")}
    return with_units(frame, units)
