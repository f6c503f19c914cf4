"""Response spectra of one design with and without HIS (paper Fig. 4)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.arguments import one_of, problem_argument
from hisopt.errors import ConfigError
from hisopt.evaluation.channels import DirectOutputs
from hisopt.evaluation.evaluate import Evaluator
from hisopt.units import psd_unit, variable_units, with_units

if TYPE_CHECKING:
    from hisopt.plotting import Figure
    from hisopt.problem import Problem

FIG4_OUTPUTS = ("acc_z", "acc_roll", "acc_pitch", "tire_load_fl")
"""Paper Fig. 4: CG vertical, roll and pitch accelerations and the FL tyre force."""

OUTPUT_LABELS = {
    "acc_z": "CG vertical acceleration",
    "acc_x": "longitudinal acceleration at the occupant",
    "acc_y": "lateral acceleration at the occupant",
    "acc_roll": "roll acceleration",
    "acc_pitch": "pitch acceleration",
    "roll": "roll angle",
    "pitch": "pitch angle",
    "stroke_fl": "FL suspension stroke",
    "tire_load_fl": "FL dynamic tyre load",
}
"""What each output of :func:`hisopt.coupled.response.standard_outputs` is, for figure titles."""


@dataclass(frozen=True)
class ResponseSpectra:
    """PSDs on a frequency grid: column ``<output>_his`` and ``<output>_ref`` per output.

    ``frame`` has ``f_hz`` [Hz] and the PSDs [(output unit)^2/Hz] (``frame.attrs["units"]``);
    ``units`` is each output's own unit.
    """

    frame: pd.DataFrame
    outputs: tuple[str, ...]
    units: dict[str, str]
    design: dict[str, float]
    design_units: dict[str, str] = field(default_factory=dict)

    def plot(self, fig: Figure | None = None) -> Figure:
        """Log-log PSDs with and without HIS, one panel per output (:func:`hisopt.plotting.spectra.response_spectra_figure`)."""
        from hisopt.plotting.spectra import response_spectra_figure

        return response_spectra_figure(self.frame, self.outputs, self.units, self.design, self.design_units, OUTPUT_LABELS, fig)


def frequency_grid(models: list[Any], f_lo_hz: float, f_hi_hz: float, n: int = 1500, per_mode: int = 60) -> np.ndarray:
    """[Hz] log grid plus points clustered (tan spacing) around every mode of ``models``."""
    parts = [np.geomspace(f_lo_hz, f_hi_hz, n)]
    theta = np.linspace(-1.5, 1.5, per_mode)
    for model in models:
        a = model.state_space().a
        lam = np.linalg.eigvals(a.reshape((-1,) + a.shape[-2:])[0])
        for pole in lam[lam.imag > 0]:
            parts.append(pole.imag / (2 * np.pi) - pole.real / (2 * np.pi) * np.tan(theta))
    f = np.concatenate(parts)
    return np.unique(f[(f >= f_lo_hz) & (f <= f_hi_hz)])


def response_spectra(problem: Problem, design: Any = None, outputs: tuple[str, ...] = FIG4_OUTPUTS) -> ResponseSpectra:
    """Road-induced PSDs of ``outputs`` for ``design`` (baseline if None) and the car without HIS."""
    problem_argument(problem)
    x = problem.design_matrix(problem.baseline if design is None else design)
    if len(x) != 1:
        raise ConfigError(f"expected one design, got {len(x)}", key="design")
    ev = Evaluator(problem)
    if isinstance(outputs, str):
        outputs = (outputs,)
    for name in outputs:
        one_of(name, list(ev.all_outputs), "outputs")
    chosen = {name: ev.all_outputs[name] for name in outputs}
    models = {"his": problem.model(x), "ref": problem.model(his=False)}
    band = problem.spec.band
    f = frequency_grid(list(models.values()), band.f_min_hz, band.f_max_hz)[None, :]
    frame = pd.DataFrame({"f_hz": f[0]})
    for suffix, model in models.items():
        psd = ev.spectra(f, DirectOutputs(model, chosen)(2 * np.pi * f))
        for i, name in enumerate(outputs):
            frame[f"{name}_{suffix}"] = psd[0, :, i]
    units = {name: chosen[name].unit for name in outputs}
    columns = {f"{name}_{suffix}": psd_unit(units[name]) for name in outputs for suffix in models}
    with_units(frame, {"f_hz": "Hz"} | columns)
    design = dict(zip(problem.variable_names, x[0], strict=True))
    return ResponseSpectra(frame, tuple(outputs), units, design, variable_units(problem))
