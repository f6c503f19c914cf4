"""Parameter sweeps and feasible regions (paper Section IV, Figs. 5-8, and Section V, Figs. 9-10).

**Sweep** (:func:`sweep`): one design variable across its bounds, the others at the baseline
design. For the roll, pitch and bounce modes: the modal frequency and damping ratio and the
peak of the mode's response PSD (its frequency and value); for the FL tyre force: the peak of
its PSD. Each mode is followed continuously along the sweep (:func:`hisopt.coupled.modal.track_modes`:
modes of neighbouring designs paired by their shapes), named as at the grid point nearest the
baseline design, so a curve never jumps to another mode. Where two modes exchange character
(the default car's bounce and pitch modes veer near p0 = 0.65 MPa and dA = 6e-4 m^2) a curve
keeps its name and its ``<mode>_motion_share`` falls below 1/2; :func:`hisopt.modal_analysis`
of a single design names modes by their character. The responses are the paper's Fig. 4
indicators (:data:`SWEEP_RESPONSES`): roll and pitch angular accelerations, CG vertical
acceleration, FL dynamic tyre load. A mode's peak is the continuous maximum of its response
PSD within an octave of the modal frequency (so that, e.g., the wheel-hop hump of the roll
acceleration near 11 Hz does not stand in for the roll mode); the tyre force's peak is its
maximum over the whole band, wherever it is. Maxima are found as the evaluator finds its
own: from the pole-aware nodes and peak samples (:meth:`hisopt.evaluation.evaluate.Evaluator.nodes`),
refined off them (:func:`hisopt.evaluation.peaks.refine_maximum`).

**Regions** (:func:`regions`): a 2-D grid over two variables' bounds, the others at the
baseline, of the four indicators of docs/model.md §6 (paper Section V) and of the problem's
constraint quantities. The feasible region is where every constraint of the problem holds;
a problem without constraints gets the baseline design's four indicator values as reference
thresholds (the region then holds the designs no worse than the baseline in any indicator),
and the figure says so.

Both return result objects with ``to_frame()`` (SI units, Hz for frequencies) and ``plot()``
(a figure drawn by :mod:`hisopt.plotting.sweeps`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import pandas as pd

from hisopt.errors import ConfigError

if TYPE_CHECKING:
    from hisopt.evaluation.parallel import Backend
    from hisopt.plotting import Figure
    from hisopt.problem import Problem

SweepKey = Literal["roll", "pitch", "bounce", "tire"]

SWEEP_MODES: tuple[str, ...] = ("roll", "pitch", "bounce")
"""Modes whose modal frequency a sweep reports (names of :data:`hisopt.coupled.modal.MODE_NAMES`)."""

SWEEP_RESPONSES: dict[str, str] = {"roll": "acc_roll", "pitch": "acc_pitch", "bounce": "acc_z", "tire": "tire_load_fl"}
"""Response whose PSD peak characterises each mode (paper Fig. 4 (b), (c), (a), (d))."""

INDICATORS: tuple[str, ...] = ("sigma_aw", "max_roll_psd", "max_stroke_psd", "max_tire_load_psd")
"""The paper's four indicators (docs/model.md §6; paper Section V, Figs. 9-10)."""

_LABELS = {"roll": "roll mode", "pitch": "pitch mode", "bounce": "bounce mode", "tire": "FL tyre force"}


def _check_variable(problem: Problem, name: str, option: str) -> None:
    if name not in problem.variable_names:
        raise ConfigError(f"expected a design variable of {problem.name} ({', '.join(problem.variable_names)}), got {name!r}", key=option)


SWEEP_MAX_POINTS = 1000
"""Most points of a sweep: a line resolving 0.1 % of the range. All points are one batch
holding about 0.9 MB each, so 1000 points take about 10 s and 0.9 GB on a 2-core machine;
larger requests are refused up front rather than streamed, since no figure or CSV reader
gains from them."""

REGIONS_MAX_POINTS = 300
"""Most grid values per variable of a regions map: 300^2 = 90,000 designs, about 25 s and
0.4 GB on a 2-core machine; finer than any contour figure shows."""


def _check_points(points: int, least: int = 2, most: int | None = None, what: str = "grid points") -> None:
    if not isinstance(points, int) or isinstance(points, bool) or points < least:
        raise ConfigError(f"expected an integer of at least {least} {what}, got {points!r}", key="--points")
    if most is not None and points > most:
        raise ConfigError(f"expected at most {most} {what}, got {points}; {_LIMIT_REASON[what]}", key="--points")


_LIMIT_REASON = {
    "sweep points": f"{SWEEP_MAX_POINTS} resolve 0.1 % of the range and take about 10 s and 0.9 GB (see hisopt.studies.sweeps.SWEEP_MAX_POINTS)",
    "grid values per variable": (
        f"{REGIONS_MAX_POINTS}^2 = {REGIONS_MAX_POINTS**2:,} designs take about 25 s and 0.4 GB; narrow the [variables] "
        "bounds for a finer map (see hisopt.studies.sweeps.REGIONS_MAX_POINTS)"
    ),
}


# --- PSD peaks -------------------------------------------------------------------------------
def response_peaks(
    problem: Problem,
    designs: Any,
    outputs: tuple[str, ...],
    centers_hz: Mapping[str, np.ndarray] | None = None,
    window: float = 2.0,
    steps: int = 8,
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """[Hz], [unit^2/Hz] Frequency and value of the maximum of each output's PSD.

    Parameters
    ----------
    problem : Problem
        the problem (vehicle, HIS, road, band)
    designs : Any
        designs, as :meth:`hisopt.problem.Problem.design_matrix` accepts, ``n`` rows
    outputs : tuple[str, ...]
        names of :func:`hisopt.coupled.response.standard_outputs`
    centers_hz : Mapping[str, np.ndarray] | None, optional
        [Hz] per output, a frequency per design, shape ``(n,)``: the maximum is then
        sought within ``[center / window, center * window]`` (a mode's own peak, not another
        mode's); outputs without a centre use the whole band
    window : float, optional
        [-] frequency ratio of the search window each side of a centre
    steps : int, optional
        new samples of each maximum (:func:`hisopt.evaluation.peaks.refine_maximum`)

    Returns
    -------
    dict[str, tuple[np.ndarray, np.ndarray]]
        name -> ``(f_peak_hz (n,), psd_peak (n,))``
    """
    from hisopt.evaluation.channels import DirectOutputs
    from hisopt.evaluation.evaluate import Evaluator, poles
    from hisopt.evaluation.peaks import refine_maximum

    ev = Evaluator(problem)
    unknown = [o for o in outputs if o not in ev.all_outputs]
    if unknown:
        raise ConfigError(f"unknown response {unknown[0]!r}; expected one of {', '.join(ev.all_outputs)}")
    x = problem.design_matrix(designs)
    model = problem.model(x)
    lam = poles(model)
    f, _ = ev.nodes(lam)
    frf = DirectOutputs(model, {name: ev.all_outputs[name] for name in outputs})
    psd = ev.spectra(f, frf(2 * np.pi * f))
    out = {}
    for j, name in enumerate(outputs):
        y = psd[..., j]
        lo_hz, hi_hz = np.full((len(x), 1), -np.inf), np.full((len(x), 1), np.inf)
        if centers_hz is not None and name in centers_hz:
            c = np.asarray(centers_hz[name], dtype=float)[:, None]
            lo_hz, hi_hz = c / window, c * window
            y = np.where((f >= lo_hz) & (f <= hi_hz), y, -np.inf)

        def values_at(pts: np.ndarray, j: int = j, lo_hz: np.ndarray = lo_hz, hi_hz: np.ndarray = hi_hz) -> np.ndarray:
            inside = (pts >= lo_hz) & (pts <= hi_hz)
            return np.where(inside, ev.spectra(pts, frf(2 * np.pi * pts, j))[..., 0], -np.inf)

        f_best, best = refine_maximum(values_at, f, y, steps)
        out[name] = (f_best, best)
    return out


# --- sweeps ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class SweepResult:
    """A one-variable sweep (paper Figs. 5-8).

    Attributes
    ----------
    problem_name : str
        the problem's name
    variable : str
        the swept design variable
    unit : str
        its unit (SI)
    frame : pd.DataFrame
        one row per value: the variable, then ``<mode>_frequency_hz``,
        ``<mode>_damping_ratio``, ``<mode>_motion_share`` (share of the mode's kinetic energy
        in the motion its name says, :func:`hisopt.coupled.modal.modal_table`), ``<mode>_peak_hz`` and
        ``<mode>_peak_psd`` for roll, pitch and bounce (each mode followed continuously,
        named as at the grid point nearest the baseline), ``tire_peak_hz`` and
        ``tire_peak_psd`` for the FL tyre force
    responses : dict[str, str]
        response of each key (:data:`SWEEP_RESPONSES`)
    units : dict[str, str]
        PSD unit of each key
    baseline : dict[str, float]
        the fixed values of the other variables
    baseline_units : dict[str, str]
        their units
    """

    problem_name: str
    variable: str
    unit: str
    frame: pd.DataFrame
    responses: dict[str, str]
    units: dict[str, str]
    baseline: dict[str, float] = field(default_factory=dict)
    baseline_units: dict[str, str] = field(default_factory=dict)

    def to_frame(self) -> pd.DataFrame:
        """The sweep as a table (a copy of :attr:`frame`; units in ``attrs["units"]``)."""
        from hisopt.units import attach_units

        peaks = {f"{key}_peak_psd": unit for key, unit in self.units.items()}
        return attach_units(self.frame.copy(), extra={self.variable: self.unit} | peaks)

    def plot(self, fig: Figure | None = None) -> Figure:
        """Frequency (left axis) and peak PSD (right axis, log) against the variable, per mode (:func:`hisopt.plotting.sweeps.sweep_figure`)."""
        from hisopt.plotting.sweeps import sweep_figure

        return sweep_figure(
            self.problem_name, self.variable, self.unit, self.frame, self.responses, self.units, self.baseline, self.baseline_units, _LABELS, fig
        )


def _sweep_modes(problem: Problem, x: np.ndarray, anchor: int, keys: list[str]) -> pd.DataFrame:
    """Frequency, damping ratio and motion share of each mode of ``keys`` along the sweep.

    Each mode is followed continuously from design to design (:func:`hisopt.coupled.modal.track_modes`),
    named as at design ``anchor``.
    """
    from hisopt.coupled.modal import track_modes

    tracked = track_modes(problem, x, anchor=anchor)
    frame = pd.DataFrame(index=range(len(x)))
    for key in keys:
        rows = tracked[tracked["mode"] == key].set_index("design")
        for col in ("frequency_hz", "damping_ratio", "motion_share"):
            frame[f"{key}_{col}"] = rows[col].to_numpy()
    return frame


def _sweep_peaks(item: tuple[np.ndarray, dict[str, np.ndarray]], problem: Problem, chosen: dict[str, str]) -> pd.DataFrame:
    """Response peaks of the designs ``item[0]``, each mode's sought near ``item[1][key]`` [Hz]."""
    x, centers = item
    frame = pd.DataFrame(index=range(len(x)))
    for key, name in chosen.items():
        near = {name: centers[key]} if key in centers else None
        frame[f"{key}_peak_hz"], frame[f"{key}_peak_psd"] = response_peaks(problem, x, (name,), near)[name]
    return frame


def sweep(
    problem: Problem,
    vary: str,
    points: int = 41,
    responses: Mapping[str, str] | None = None,
    backend: Backend | None = None,
) -> SweepResult:
    """Sweep ``vary`` across its bounds, the other variables at the baseline (paper Figs. 5-8).

    Parameters
    ----------
    problem : Problem
        the problem (its variables' bounds, baseline design, vehicle, road, band)
    vary : str
        a design variable of the problem
    points : int, optional
        [-] values, evenly spaced between the bounds (both included)
    responses : Mapping[str, str] | None, optional
        response per key (``roll``, ``pitch``, ``bounce``, ``tire``); default
        :data:`SWEEP_RESPONSES`; e.g. ``{"roll": "roll"}`` for the roll angle; a key that
        is a mode name (:data:`hisopt.coupled.modal.MODE_NAMES`) gets that mode's modal columns
    backend : Backend | None, optional
        where to compute (default in-process; a Dask backend splits the points into
        chunks of :data:`hisopt.evaluation.parallel.DEFAULT_CHUNK`)

    Raises
    ------
    ConfigError
        ``vary`` is not a design variable, ``points < 2`` or a response is unknown.
    """
    from hisopt.coupled.modal import MODE_NAMES
    from hisopt.evaluation.parallel import Backend, chunks

    _check_variable(problem, vary, "--vary")
    _check_points(points, most=SWEEP_MAX_POINTS, what="sweep points")
    chosen = dict(SWEEP_RESPONSES) | dict(responses or {})
    j = problem.variable_names.index(vary)
    values = grid_values(problem, j, points)
    points = len(values)
    x = np.repeat(problem.baseline[None, :], points, axis=0)
    x[:, j] = values
    backend = backend or Backend()
    anchor = int(np.argmin(np.abs(values - problem.baseline[j])))
    keys = [key for key in chosen if key in MODE_NAMES]
    modal = _sweep_modes(problem, x, anchor, keys)  # sequential and cheap: in this process
    centers = {key: modal[f"{key}_frequency_hz"].to_numpy() for key in keys}
    size = len(x) if not backend.is_distributed else max(1, -(-len(x) // (4 * backend.n_workers)))
    items = [(x[c], {k: v[c] for k, v in centers.items()}) for c in chunks(len(x), size)]
    peaks = pd.concat(backend.map(_sweep_peaks, items, problem, chosen), ignore_index=True)
    columns = {vary: values}
    for key in chosen:
        names = [f"{key}_{col}" for col in ("frequency_hz", "damping_ratio", "motion_share") if key in keys]
        columns |= {n: modal[n].to_numpy() for n in names}
        columns |= {n: peaks[n].to_numpy() for n in (f"{key}_peak_hz", f"{key}_peak_psd")}
    frame = pd.DataFrame(columns)
    from hisopt.coupled.response import standard_outputs
    from hisopt.units import psd_unit, variable_units

    all_outputs = standard_outputs(problem.vehicle)
    units = {key: psd_unit(all_outputs[name].unit) for key, name in chosen.items()}
    baseline = {n: float(v) for n, v in zip(problem.variable_names, problem.baseline, strict=True) if n != vary}
    var_units = variable_units(problem)
    return SweepResult(problem.name, vary, var_units[vary], frame, chosen, units, baseline, var_units)


# --- feasible regions -------------------------------------------------------------------------
@dataclass(frozen=True)
class RegionsResult:
    """Indicators on a 2-D design grid with thresholds (paper Figs. 9-10).

    Attributes
    ----------
    problem_name : str
        the problem's name
    pair : tuple[str, str]
        the two varied design variables (x axis, y axis)
    units : tuple[str, str]
        their units
    grid_x, grid_y : np.ndarray
        [variable units] grid values, shapes ``(n_x,)``, ``(n_y,)``
    values : dict[str, np.ndarray]
        [physical units] each indicator and constraint quantity, shape ``(n_y, n_x)``
    valid : np.ndarray
        the model could be evaluated, shape ``(n_y, n_x)``
    thresholds : dict[str, float]
        [physical units] upper limit per quantity (value <= limit is acceptable)
    threshold_source : Literal['constraints', 'baseline']
        ``"constraints"`` (the problem's) or ``"baseline"`` (the baseline
        design's indicator values, for a problem without constraints)
    baseline : dict[str, float]
        the fixed values of the other variables
    baseline_units : dict[str, str]
        their units
    """

    problem_name: str
    pair: tuple[str, str]
    units: tuple[str, str]
    grid_x: np.ndarray
    grid_y: np.ndarray
    values: dict[str, np.ndarray]
    valid: np.ndarray
    thresholds: dict[str, float]
    threshold_source: Literal["constraints", "baseline"]
    baseline: dict[str, float] = field(default_factory=dict)
    baseline_units: dict[str, str] = field(default_factory=dict)

    @property
    def feasible(self) -> np.ndarray:
        """Grid points meeting every threshold (and valid), shape ``(n_y, n_x)``."""
        ok = self.valid.copy()
        for name, limit in self.thresholds.items():
            ok &= self.values[name] <= limit
        return ok

    def to_frame(self) -> pd.DataFrame:
        """One row per grid point: both variables, every quantity, ``valid``, ``feasible``.

        Units in ``attrs["units"]``.
        """
        from hisopt.units import attach_units

        xx, yy = np.meshgrid(self.grid_x, self.grid_y)
        frame = pd.DataFrame({self.pair[0]: xx.ravel(), self.pair[1]: yy.ravel()})
        for name, v in self.values.items():
            frame[name] = v.ravel()
        frame["valid"] = self.valid.ravel()
        frame["feasible"] = self.feasible.ravel()
        return attach_units(frame, extra=dict(zip(self.pair, self.units, strict=True)))

    def plot(self, fig: Figure | None = None) -> Figure:
        """Contours of log10 of each indicator; thresholds dashed, the infeasible set shaded (:func:`hisopt.plotting.sweeps.regions_figure`)."""
        from hisopt.plotting.sweeps import regions_figure

        return regions_figure(
            self.problem_name,
            self.pair,
            self.units,
            self.grid_x,
            self.grid_y,
            self.values,
            self.valid,
            self.feasible,
            self.thresholds,
            self.threshold_source,
            INDICATORS,
            self.baseline,
            self.baseline_units,
            fig,
        )


def indicator_problem(problem: Problem) -> Problem:
    """The problem with the four indicators as objectives (constraints kept)."""
    from hisopt.problem import Problem, problem_from_dict

    if tuple(problem.objective_names) == INDICATORS:
        return problem
    data = problem.spec.model_dump(by_alias=True)
    data["objectives"] = list(INDICATORS)
    derived = problem_from_dict(data, str(problem.path or "<problem>"), warn_implausible=False)  # checked when read
    return Problem(derived.spec, problem.path, None)


def regions(problem: Problem, pair: tuple[str, str], points: int = 41, backend: Backend | None = None) -> RegionsResult:
    """The four indicators on a ``points x points`` grid over ``pair`` (paper Figs. 9-10).

    Parameters
    ----------
    problem : Problem
        the problem (bounds, baseline design, constraints)
    pair : tuple[str, str]
        two different design variables: x axis, y axis
    points : int, optional
        [-] grid values per variable, evenly spaced between its bounds
    backend : Backend | None, optional
        where to evaluate the grid (default in-process; Dask for large grids)

    Raises
    ------
    ConfigError
        A name is not a design variable, the two are equal, or ``points < 2``.
    """
    if len(pair) != 2:
        raise ConfigError(f"expected two design variables separated by a comma, got {','.join(pair)!r}", key="--pair")
    a, b = pair
    for name in pair:
        _check_variable(problem, name, "--pair")
    if a == b:
        raise ConfigError(f"expected two different design variables, got {a!r} twice", key="--pair")
    _check_points(points, most=REGIONS_MAX_POINTS, what="grid values per variable")
    ia, ib = problem.variable_names.index(a), problem.variable_names.index(b)
    grid_x, grid_y = grid_values(problem, ia, points), grid_values(problem, ib, points)
    xx, yy = np.meshgrid(grid_x, grid_y)
    x = np.repeat(problem.baseline[None, :], xx.size, axis=0)
    x[:, ia], x[:, ib] = xx.ravel(), yy.ravel()
    from hisopt.evaluation.robust_evaluator import evaluate_designs

    derived = indicator_problem(problem)
    ev = derived.evaluator()
    q = evaluate_designs(derived, x, backend)
    shape = (points, points)
    values = {name: np.asarray(q[name]).reshape(shape) for name in ev.names}
    if problem.spec.constraints:
        thresholds = {c.name: float(c.limit) for c in problem.spec.constraints}
        source: Literal["constraints", "baseline"] = "constraints"
    else:
        base = ev(problem.baseline[None, :])
        thresholds = {name: float(base[name][0]) for name in INDICATORS}
        source = "baseline"
    from hisopt.units import variable_units

    var_units = variable_units(problem)
    units = (var_units[a], var_units[b])
    baseline = {n: float(v) for n, v in zip(problem.variable_names, problem.baseline, strict=True) if n not in pair}
    return RegionsResult(
        problem.name,
        (a, b),
        units,
        grid_x,
        grid_y,
        values,
        np.asarray(q["valid"]).reshape(shape),
        thresholds,
        source,
        baseline,
        var_units,
    )


def grid_values(problem: Problem, j: int, points: int) -> np.ndarray:
    """[SI] ``points`` values of design variable ``j`` from its lower to its upper bound, or
    of a choice variable its listed values (all of them, or ``points`` spread evenly along
    the list when it is longer: docs/model.md §17)."""
    choices = problem.choices.get(j)
    if choices is None:
        return np.linspace(problem.lower[j], problem.upper[j], points)
    picks = np.unique(np.round(np.linspace(0, len(choices) - 1, min(points, len(choices)))).astype(int))
    return choices[picks]
