"""Manoeuvres in the time domain, linear against nonlinear (docs/model.md §22.4).

Three inputs, each a small pure description and simulated on one design's model by
:func:`hisopt.simulation.timedomain.simulate` in both modes: ``"linear"`` (the exact lumped
state space the frequency-domain figures come from) and ``"nonlinear"`` with every
nonlinearity on (gas law, valve laws, tyre lift-off):

- :class:`StepSteer`: an ideal lateral-acceleration step of ``[handling] step_g`` at ``t = 0``,
  the roll moment ``m_s a_y h_0s`` on the roll DOF, the input of ``roll_step_peak``
  (:mod:`hisopt.evaluation.transient`, docs/model.md §6.6);
- :class:`SineWithDwell`: the FMVSS No. 126 / UN Regulation No. 140 steering input (a 0.7 Hz
  sine with a 500 ms dwell at its second peak) applied as the lateral acceleration itself, at
  the step's amplitude;
- :class:`HalfSineBump`: a half-sine bump ``h sin(pi s / L)`` under the left wheels, driven
  over at the case's road speed (:func:`hisopt.road.profiles.half_sine_profile`).

Each manoeuvre's figures (:data:`FIGURES`) are peaks over the record: the roll and the roll
rate refined between samples (:func:`refined_peak`: a cubic Hermite interpolant of the signal
and its exact derivative), pressures, forces and strokes at the samples. The body's gravity
moment follows ``[handling] gravity_moment`` in all three, as the transient quantities take it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.constants import G_MPS2
from hisopt.errors import ConfigError, ModelError
from hisopt.road.profiles import Wheel, half_sine_profile
from hisopt.simulation.timedomain import SimulationMode, TimeResponse, simulate

if TYPE_CHECKING:
    from hisopt.coupled.model import CoupledModel
    from hisopt.specification.design_space import DesignSpace

ROLL = 1
"""Index of the roll angle among the DOFs (``hisopt.constants.DOF_NAMES``)."""

RTOL = {"linear": 1e-9, "nonlinear": 1e-6}
"""[-] Relative tolerance of the integration by mode: the linear step steer's peaks reproduce the
transient quantities to 1e-6 (docs/model.md §22.4); the nonlinear figures are read against the
linear ones at the 1e-3 level, and 1e-6 costs half of 1e-9 on a model with hoses and valves."""

REFINEMENT = 1e-7
"""[-] Budget of the linear runs' peak refinement between samples, a share of the peak
(:func:`linear_step_s`)."""

FINEST_STEP_S = 1e-4
"""[s] The linear runs' samples are never finer (a 1.6 kHz ripple is resolved to the budget)."""

FIGURES = {
    "peak_roll": "rad",
    "roll_overshoot": "-",
    "roll_ratio_1s": "-",
    "peak_roll_rate": "rad/s",
    "min_chamber_pressure": "Pa",
    "max_chamber_pressure": "Pa",
    "min_accumulator_pressure": "Pa",
    "max_accumulator_pressure": "Pa",
    "peak_strut_force": "N",
    "peak_stroke": "m",
}
"""[SI] Every figure a manoeuvre may report, with its unit (pressures gauge)."""

TRANSIENT_OF = {"peak_roll": "roll_step_peak", "roll_overshoot": "roll_step_overshoot", "peak_roll_rate": "roll_rate_peak"}
"""The transient quantity (:data:`hisopt.evaluation.transient.STEP_NAMES`) each step-steer figure reproduces."""

COLUMNS = ("manoeuvre", "figure", "unit", "transient", "linear", "nonlinear", "note")
"""Columns of :func:`manoeuvre_table`."""


# --- the inputs ------------------------------------------------------------------------------
@dataclass(frozen=True)
class StepSteer:
    """An ideal step of lateral acceleration ``accel_g`` [g] at ``t = 0`` (``roll_step_peak``'s
    input, docs/model.md §6.6), recorded for ``duration_s`` [s] every ``dt_s`` [s].

    3 s covers the peak (the roll mode's first half period, 0.2 s on the paper's car) and lets
    the roll settle to about 1e-3 of its overshoot there; 2 ms samples keep the peaks'
    refinement error under 1e-8 on that car (:func:`refined_peak`; linear runs sample finer
    where the modes need it, :func:`linear_step_s`)."""

    accel_g: float
    duration_s: float = 3.0
    dt_s: float = 0.002
    name: str = "step_steer"

    def __post_init__(self) -> None:
        _check({"accel_g": (self.accel_g, False), "duration_s": (self.duration_s, True), "dt_s": (self.dt_s, True)})

    def lateral_acceleration(self, t_s: Any) -> np.ndarray:
        """[m/s^2] ``a_y`` at times ``t_s`` [s] (``accel_g g`` from ``t = 0``)."""
        return np.where(np.asarray(t_s, dtype=float) >= 0.0, self.accel_g * G_MPS2, 0.0)


@dataclass(frozen=True)
class SineWithDwell:
    """The sine with dwell of FMVSS No. 126 (49 CFR 571.126, S7.7) and UN Regulation No. 140
    (Annex 3), in lateral acceleration of amplitude ``accel_g`` [g].

    The regulations steer the hand wheel ``A sin(2 pi f t)`` at ``f = 0.7 Hz`` up to its
    second peak (``t = 3 / (4 f)``, 1.071 s), hold it there for ``dwell_s = 0.5`` s, then
    finish the sine to zero (at ``1 / f + dwell``, 1.929 s), and judge the yaw rate 1.0 s
    after that. Here the shape drives the lateral acceleration directly (no tyre or yaw
    model: the roll's input, as the step steer's), and the record runs ``after_s = 1.0`` s
    past the end, where ``roll_ratio_1s`` reads ``|phi|`` against its peak (the regulation's
    yaw-rate ratio, in roll)."""

    accel_g: float
    frequency_hz: float = 0.7
    dwell_s: float = 0.5
    after_s: float = 1.0
    dt_s: float = 0.002
    name: str = "sine_with_dwell"

    def __post_init__(self) -> None:
        _check({"accel_g": (self.accel_g, False), "frequency_hz": (self.frequency_hz, True), "dt_s": (self.dt_s, True)})
        if not (self.dwell_s >= 0.0 and self.after_s >= 1.0):
            raise ConfigError(f"expected dwell_s >= 0 [s] and after_s >= 1 [s] (roll_ratio_1s reads 1 s past the end), got {self.dwell_s!r}, {self.after_s!r}")

    @property
    def end_s(self) -> float:
        """[s] End of the steering input, ``1 / f + dwell``."""
        return 1.0 / self.frequency_hz + self.dwell_s

    @property
    def duration_s(self) -> float:
        """[s] Length of the record."""
        return self.end_s + self.after_s

    def lateral_acceleration(self, t_s: Any) -> np.ndarray:
        """[m/s^2] ``a_y`` at times ``t_s`` [s]: the sine, the dwell at ``-a``, the sine's end."""
        t = np.asarray(t_s, dtype=float)
        dwell_at = 0.75 / self.frequency_hz
        phase = np.where(t < dwell_at, t, np.where(t < dwell_at + self.dwell_s, dwell_at, t - self.dwell_s))
        shape = np.where((t >= 0.0) & (t <= self.end_s), np.sin(2.0 * np.pi * self.frequency_hz * phase), 0.0)
        return self.accel_g * G_MPS2 * shape


@dataclass(frozen=True)
class HalfSineBump:
    """A half-sine bump ``height_m sin(pi s / length_m)`` under ``wheels`` (the left), front then rear
    after the wheelbase, driven over at ``speed_mps`` [m/s] (the case's road speed).

    50 mm by 1 m is a chosen test, not a standard's: a speed bump's height on a road hump's
    scale, large enough to move the strokes by tens of millimetres (the gas law and the valves
    leave their linear range) and, one side only, to roll the body. The record runs ``settle_s``
    past the rear wheel leaving the bump; samples every ``dt_s`` or 1/20 of the bump's passage,
    whichever is finer."""

    speed_mps: float
    height_m: float = 0.05
    length_m: float = 1.0
    settle_s: float = 1.5
    dt_s: float = 0.002
    wheels: tuple[Wheel, ...] = ("fl", "rl")
    name: str = "half_sine_bump"

    def __post_init__(self) -> None:
        _check({"speed_mps": (self.speed_mps, True), "height_m": (self.height_m, False), "length_m": (self.length_m, True), "dt_s": (self.dt_s, True)})
        if not self.settle_s >= 0.0:
            raise ConfigError(f"expected settle_s >= 0 [s], got {self.settle_s!r}")

    def duration_s(self, wheelbase_m: float) -> float:
        """[s] Length of the record on a car of ``wheelbase_m`` [m]."""
        return (self.length_m + wheelbase_m) / self.speed_mps + self.settle_s

    def step_s(self) -> float:
        """[s] Sample spacing."""
        return min(self.dt_s, self.length_m / self.speed_mps / 20.0)


def _check(values: dict[str, tuple[float, bool]]) -> None:
    """Each ``name: (value, positive)``: finite, and > 0 when ``positive`` (else nonzero)."""
    for name, (value, positive) in values.items():
        if not (np.isfinite(value) and (value > 0.0 if positive else value != 0.0)):
            raise ConfigError(f"expected {name} finite and {'> 0' if positive else 'nonzero'}, got {value!r}")


Manoeuvre = StepSteer | SineWithDwell | HalfSineBump
"""One of the three manoeuvres."""


def manoeuvres_of(space: DesignSpace) -> tuple[StepSteer, SineWithDwell, HalfSineBump]:
    """The three manoeuvres of a single-case problem: the step and the sine with dwell at its
    ``[handling] step_g``, the bump at its road speed."""
    step_g = float(space.spec.handling.step_g)
    return StepSteer(step_g), SineWithDwell(step_g), HalfSineBump(float(space.spec.road.speed))


# --- simulating ------------------------------------------------------------------------------
def roll_moment(model: CoupledModel, accel: Callable[[Any], np.ndarray]) -> Callable[[Any], np.ndarray]:
    """The generalised force ``(7,)`` at a time, ``(n, 7)`` at ``n`` times, of the lateral
    acceleration ``accel(t)`` [m/s^2]: the roll moment ``m_s h_0s a_y`` on the roll DOF
    (:func:`hisopt.evaluation.transient.moment_per_acceleration`)."""
    from hisopt.evaluation.transient import moment_per_acceleration  # on use: the evaluation layer's convention

    per = moment_per_acceleration(model.car)

    def force(t: Any) -> np.ndarray:
        a_y = accel(t)
        out = np.zeros(np.shape(a_y) + (7,))
        out[..., ROLL] = per * a_y
        return out

    return force


def linear_step_s(model: CoupledModel, gravity_moment: bool, cap_s: float) -> float:
    """[s] Sample spacing of a linear run: ``cap_s`` divided by the smallest whole number that
    keeps the peak refinement's bound (:func:`refined_peak`) within :data:`REFINEMENT`.

    The bound sums ``(h |lambda_k|)^4 / 384`` over the roll's modes under a roll moment
    (:func:`hisopt.evaluation.transient.modal_form`), weighted by each mode's share of the roll
    (``|r_k / lambda_k|``) and of the roll rate (``|r_k|``): a hose's kilohertz mode that
    carries 1e-3 of the roll rate needs samples a tenth of a millisecond apart, the paper's car
    2 ms. Never below :data:`FINEST_STEP_S`; ``cap_s`` when the modes are not trusted."""
    from hisopt.evaluation.transient import gravity_softened, modal_form, roll_moment_input, stable, static_roll_gain

    a = np.asarray(model.state_space().a, dtype=float)
    a = a.reshape((-1,) + a.shape[-2:])[:1]
    b = roll_moment_input(model.car, a.shape[-1])[None]
    with np.errstate(all="ignore"):
        form, trusted = modal_form(gravity_softened(a, b) if gravity_moment else a, b, static_roll_gain(model, gravity_moment)[:1])
    lam, res = form.lam[0], form.res[0]
    if not (trusted[0] and stable(form.lam)[0]):
        return cap_s
    weight = max(float(np.sum(np.abs(w) * np.abs(lam) ** 4) / np.sum(np.abs(w))) for w in (res / lam, res))
    h = (384.0 * REFINEMENT / weight) ** 0.25
    return cap_s / int(np.ceil(cap_s / max(h, FINEST_STEP_S)))


def simulate_manoeuvre(
    model: CoupledModel, manoeuvre: Manoeuvre, mode: SimulationMode, gravity_moment: bool, rtol: float | None = None, dt_s: float | None = None
) -> TimeResponse:
    """One manoeuvre on one design's lumped ``model``: ``"linear"``, or ``"nonlinear"`` with the
    gas law, the valve laws and tyre lift-off; ``gravity_moment`` as ``[handling]`` says.

    Samples every ``dt_s`` [s]; default the manoeuvre's spacing, in linear mode divided to keep
    the peaks' refinement within :data:`REFINEMENT` (:func:`linear_step_s`). ``rtol`` default
    :data:`RTOL` of the mode. Raises :class:`~hisopt.errors.ModelError` when the nonlinear run
    leaves the model (an accumulator bottoming out) or the integrator fails."""
    nonlinear = mode == "nonlinear"
    wheelbase = model.car.l_f + model.car.l_r
    spacing = manoeuvre.step_s() if isinstance(manoeuvre, HalfSineBump) else manoeuvre.dt_s
    if dt_s is None:
        dt_s = spacing if nonlinear else linear_step_s(model, gravity_moment, spacing)
    duration = manoeuvre.duration_s(wheelbase) if isinstance(manoeuvre, HalfSineBump) else manoeuvre.duration_s
    t = dt_s * np.arange(int(np.floor(duration / dt_s + 1e-9)) + 1)
    if isinstance(manoeuvre, HalfSineBump):
        road = half_sine_profile(t, manoeuvre.height_m, manoeuvre.length_m, manoeuvre.speed_mps, wheelbase, manoeuvre.wheels)
        force = None
    else:
        road = np.zeros((t.size, 4))
        force = roll_moment(model, manoeuvre.lateral_acceleration)
    tol = RTOL[mode] if rtol is None else rtol
    return simulate(model, t, road, mode, tyre_liftoff=nonlinear, rtol=tol, body_force=force, gravity_moment=gravity_moment, gas_law=True, valve_law=True)


# --- figures ---------------------------------------------------------------------------------
def refined_peak(t_s: np.ndarray, y: np.ndarray, dy: np.ndarray, candidates: int = 3) -> float:
    """Largest ``|y|`` over the record, refined between samples.

    Around each of the ``candidates`` largest local maxima of the samples ``|y|``, the cubic
    Hermite interpolant of ``y`` and its exact derivative ``dy`` on the two neighbouring
    intervals is maximised in closed form. Its error is at most ``h^4 max|y''''| / 384`` (``h``
    the sample spacing): ``(h omega)^4 / 384`` of a mode of ``omega`` [rad/s].

    Parameters
    ----------
    t_s : np.ndarray
        [s] increasing sample times ``(n,)``
    y, dy : np.ndarray
        the signal and its time derivative at ``t_s`` ``(n,)``
    candidates : int, optional
        [-] local maxima followed
    """
    size = np.abs(y)
    inner = np.flatnonzero((size[1:-1] >= size[:-2]) & (size[1:-1] >= size[2:])) + 1
    tops = np.concatenate([inner, [0, len(y) - 1]])
    tops = tops[np.argsort(-size[tops], kind="stable")[:candidates]]
    best = float(size.max())
    for i in tops:
        for j in (i - 1, i):
            if 0 <= j < len(y) - 1:
                best = max(best, _hermite_max(t_s[j + 1] - t_s[j], y[j], y[j + 1], dy[j], dy[j + 1]))
    return best


def _hermite_max(h: float, y0: float, y1: float, m0: float, m1: float) -> float:
    """Largest ``|p|`` inside ``[0, 1]`` of the cubic Hermite ``p(s)`` with values ``y0, y1``
    and slopes ``m0, m1`` (per unit time) over an interval of ``h`` [s]."""
    c1, c2, c3 = h * m0, 3.0 * (y1 - y0) - h * (2.0 * m0 + m1), 2.0 * (y0 - y1) + h * (m0 + m1)
    roots = np.roots([3.0 * c3, 2.0 * c2, c1]) if (c3 != 0.0 or c2 != 0.0) else np.array([])
    s = np.real(roots[np.isreal(roots)])
    s = s[(s > 0.0) & (s < 1.0)]
    return float(np.max(np.abs(y0 + s * (c1 + s * (c2 + s * c3))), initial=0.0))


def _extremes(values: np.ndarray) -> tuple[float, float]:
    """``(min, max)`` of ``values``, NaN for an empty record (a car without HIS)."""
    return (float(values.min()), float(values.max())) if values.size else (np.nan, np.nan)


def hydraulic_figures(response: TimeResponse) -> dict[str, float]:
    """Chamber and accumulator pressure ranges [Pa gauge] and the largest strut force [N]
    (static included) over the samples."""
    p_min, p_max = _extremes(response.port_pressure_pa)
    a_min, a_max = _extremes(response.accumulator_pressure_pa)
    force = np.abs(response.strut_force_n)
    return {
        "min_chamber_pressure": p_min,
        "max_chamber_pressure": p_max,
        "min_accumulator_pressure": a_min,
        "max_accumulator_pressure": a_max,
        "peak_strut_force": float(force.max()) if force.size else np.nan,
    }


def roll_figures(response: TimeResponse) -> dict[str, float]:
    """Peak ``|phi|`` [rad] and peak ``|dphi/dt|`` [rad/s] refined between samples
    (:func:`refined_peak`)."""
    t = response.t_s
    return {
        "peak_roll": refined_peak(t, response.displacement[:, ROLL], response.velocity[:, ROLL]),
        "peak_roll_rate": refined_peak(t, response.velocity[:, ROLL], response.acceleration[:, ROLL]),
    }


def step_figures(response: TimeResponse, steady_rad: float) -> dict[str, float]:
    """A step steer's figures: the peak is the supremum of ``|phi|`` over ``t >= 0``, the
    larger of the refined record peak and the steady roll ``steady_rad`` [rad] (a creeping
    response reaches it only at infinity), the overshoot ``peak / |steady| - 1``, as
    :func:`hisopt.evaluation.transient.step_response_peaks` defines them."""
    figures = roll_figures(response)
    steady = abs(steady_rad)
    figures["peak_roll"] = max(figures["peak_roll"], steady)
    figures["roll_overshoot"] = figures["peak_roll"] / steady - 1.0
    return figures | hydraulic_figures(response)


def sine_figures(response: TimeResponse, manoeuvre: SineWithDwell) -> dict[str, float]:
    """The sine with dwell's figures: peak roll and roll rate, ``roll_ratio_1s`` (``|phi|`` 1.0 s
    after the input ends over the peak roll, read between samples by the cubic Hermite of
    ``phi`` and its rate), pressures and strut forces. No overshoot: the input has no steady
    level for one to refer to."""
    figures = roll_figures(response)
    t = response.t_s
    at = manoeuvre.end_s + 1.0
    j = min(int(np.searchsorted(t, at, side="right")) - 1, len(t) - 2)
    h = t[j + 1] - t[j]
    s = (at - t[j]) / h
    phi, rate = response.displacement[:, ROLL], response.velocity[:, ROLL]
    value = (2 * s**3 - 3 * s**2 + 1) * phi[j] + (s**3 - 2 * s**2 + s) * h * rate[j] + (-2 * s**3 + 3 * s**2) * phi[j + 1] + (s**3 - s**2) * h * rate[j + 1]
    figures["roll_ratio_1s"] = abs(value) / figures["peak_roll"]
    return figures | hydraulic_figures(response)


def bump_figures(response: TimeResponse) -> dict[str, float]:
    """The bump's figures: peak roll and roll rate, pressures, strut forces and the largest
    ``|stroke|`` [m] of the four struts over the samples."""
    return roll_figures(response) | hydraulic_figures(response) | {"peak_stroke": float(np.abs(response.stroke_m).max())}


# --- one design, one load case -----------------------------------------------------------------
def steady_roll(model: CoupledModel, accel_g: float, gravity_moment: bool) -> float:
    """[rad] The linear model's steady roll under ``accel_g`` [g] of lateral acceleration
    (``roll_gradient``'s law, :func:`hisopt.evaluation.transient.static_roll_gain`)."""
    from hisopt.evaluation.transient import static_roll_gain  # on use: the evaluation layer's convention

    return float(static_roll_gain(model, gravity_moment)[0]) * accel_g * G_MPS2


def manoeuvre_figures(
    model: CoupledModel, manoeuvre: Manoeuvre, gravity_moment: bool, rtol: Mapping[str, float] = RTOL
) -> tuple[dict[str, float], dict[str, float], str]:
    """The figures of one manoeuvre on one design, linear and nonlinear, and a note (the
    nonlinear run's :class:`~hisopt.errors.ModelError`, else empty: its figures are then NaN).
    ``rtol``: the relative tolerance of each mode (:data:`RTOL`).

    The nonlinear step steer's steady roll is its record's last value corrected by the linear
    run's unsettled part there, ``phi_nl(T) + (phi_static - phi_lin(T))``."""
    runs: dict[str, TimeResponse] = {}
    note = ""
    runs["linear"] = simulate_manoeuvre(model, manoeuvre, "linear", gravity_moment, rtol["linear"])
    try:
        runs["nonlinear"] = simulate_manoeuvre(model, manoeuvre, "nonlinear", gravity_moment, rtol["nonlinear"])
    except ModelError as err:
        note = f"nonlinear run stopped: {err}"
    out: list[dict[str, float]] = []
    for mode in ("linear", "nonlinear"):
        response = runs.get(mode)
        if response is None:
            out.append({})
        elif isinstance(manoeuvre, StepSteer):
            static = steady_roll(model, manoeuvre.accel_g, gravity_moment)
            unsettled = static - runs["linear"].displacement[-1, ROLL]
            steady = static if mode == "linear" else response.displacement[-1, ROLL] + unsettled
            out.append(step_figures(response, steady))
        elif isinstance(manoeuvre, SineWithDwell):
            out.append(sine_figures(response, manoeuvre))
        else:
            out.append(bump_figures(response))
    return out[0], out[1], note


def _transient_values(model: CoupledModel, step: StepSteer, gravity_moment: bool) -> dict[str, float]:
    """The step steer's transient quantities of ``model`` (one design)."""
    from hisopt.evaluation.transient import STEP_NAMES, transient_quantities  # on use: the evaluation layer

    values = transient_quantities(model, model.car, STEP_NAMES, step.accel_g, gravity_moment)
    return {figure: float(values[name][0]) for figure, name in TRANSIENT_OF.items()}


def manoeuvre_table(space: DesignSpace, design: Any = None, manoeuvres: Sequence[Manoeuvre] | None = None) -> pd.DataFrame:
    """The manoeuvres of one design on a single-case problem, linear against nonlinear.

    Parameters
    ----------
    space : DesignSpace
        a single-case problem (a scenario problem's :meth:`scenario_space`)
    design : Any, optional
        one design in a form :meth:`DesignSpace.design_matrix` takes (default the baseline)
    manoeuvres : Sequence[Manoeuvre] | None, optional
        default :func:`manoeuvres_of` the problem

    Returns
    -------
    pd.DataFrame
        one row per manoeuvre and figure, :data:`COLUMNS`: ``unit`` SI (pressures gauge),
        ``transient`` the transient quantity the figure reproduces (step steer's peak roll,
        overshoot and peak roll rate; NaN elsewhere), ``note`` why a nonlinear run stopped
    """
    if space.scenario_names:
        raise ConfigError("manoeuvre_table takes a single-case problem; use problem_manoeuvres for one with [[scenarios]]")
    x = space.design_matrix(space.baseline if design is None else design)
    if len(x) != 1:
        raise ConfigError(f"manoeuvre_table takes one design, got {len(x)}")
    model = space.model(x)
    gravity = bool(space.spec.handling.gravity_moment)
    rows = []
    for manoeuvre in manoeuvres_of(space) if manoeuvres is None else manoeuvres:
        linear, nonlinear, note = manoeuvre_figures(model, manoeuvre, gravity)
        transient = _transient_values(model, manoeuvre, gravity) if isinstance(manoeuvre, StepSteer) else {}
        for figure, unit in FIGURES.items():
            if figure in linear:
                rows.append((manoeuvre.name, figure, unit, transient.get(figure, np.nan), linear[figure], nonlinear.get(figure, np.nan), note))
    return pd.DataFrame(rows, columns=list(COLUMNS))


def problem_manoeuvres(space: DesignSpace, design: Any = None) -> pd.DataFrame:
    """:func:`manoeuvre_table` over every load case of a problem (its ``[[scenarios]]``, or the
    problem itself), with a first column ``case`` (``""`` for a single-case problem)."""
    names = space.scenario_names or ("",)
    frames = []
    for name in names:
        table = manoeuvre_table(space.scenario_space(name) if name else space, design)
        frames.append(table.assign(case=name)[["case", *COLUMNS]])
    return pd.concat(frames, ignore_index=True)


__all__ = [
    "COLUMNS",
    "FIGURES",
    "HalfSineBump",
    "Manoeuvre",
    "SineWithDwell",
    "StepSteer",
    "bump_figures",
    "hydraulic_figures",
    "linear_step_s",
    "manoeuvre_figures",
    "manoeuvre_table",
    "manoeuvres_of",
    "problem_manoeuvres",
    "refined_peak",
    "roll_figures",
    "roll_moment",
    "simulate_manoeuvre",
    "sine_figures",
    "steady_roll",
    "step_figures",
]
