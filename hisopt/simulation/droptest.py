"""Full-vehicle drop tests and modal identification (paper Section VI, Figs. 11-13, Table 3).

Three tests each excite one body mode mainly: a **front-axle drop** (pitch), a **left-side
drop** (roll) and an **all-wheel drop** (bounce). A drop is simulated as the road support
under the chosen wheels falling away by a step of ``-height`` (the wheels rolling off blocks
of that height), the car starting at rest in its static equilibrium on the blocks.

Processing, for simulated and measured records alike (paper Section VI), with the kit of
:mod:`hisopt.simulation.identification`:

1. accelerations at eight sensor points: the body above each wheel (``T_z [z_s, phi,
   theta]''``, paper Eq. 6) and the four wheels, low-passed at 20 Hz (4th-order Butterworth,
   applied forward and backward, so with no phase shift);
2. the four body corners projected on body coordinates with the pseudo-inverse of ``T_z``
   and weighted by ``sqrt(m_s), sqrt(I_x), sqrt(I_y)`` (so squared amplitudes are kinetic
   energies, as in :func:`hisopt.coupled.modal.modal_table`);
3. the free decay, from the largest response of the test's body coordinate over
   ``window_s``, fitted by the Eigensystem Realization Algorithm (ERA, Juang and Pappa 1985)
   at several model orders. In each fit the **dominant mode** is the identified body-range
   mode with the largest contribution to the test's coordinate (pitch, roll or bounce); the
   reported frequency and damping are the medians over the orders (a stabilisation check),
   and its motion shape (complex amplitudes of body bounce, roll, pitch and the four wheels)
   comes from a least-squares fit on that order's poles;
4. the identified mode is **paired** with the model mode it is (:func:`pair_mode`): among
   the modes within :data:`PAIRING_WINDOW` of its frequency, the one whose mass-weighted
   shape it matches (modal assurance criterion at least :data:`MAC_MIN`, and no other
   candidate does). The case does not decide the mode: on some layouts a front-axle drop
   excites the bounce mode most (``layout_axle_roll``). A signal that matches no single mode
   is reported as ``mixed: a+b`` with no model error.

A free decay oscillates at the *damped* natural frequency ``Im(s) / 2 pi``, so the model
column of Table 3 is :func:`hisopt.modal_analysis`'s ``damped_frequency_hz`` of the paired
mode; the body modes are damped by 10-30 %, which puts the undamped frequency 1-4 % higher.

References
----------
Paper Section VI, Figs. 11-13 and Table 3. J.-N. Juang and R. S. Pappa, "An eigensystem
realization algorithm for modal parameter identification and model reduction", J. Guidance,
Control, and Dynamics 8(5), 620-627, 1985.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from hisopt.arguments import not_empty, number, of_type, one_of
from hisopt.constants import WHEEL_NAMES
from hisopt.coupled.modal import MODE_NAMES, mac, mechanical_mode_shapes, modal_analysis, modal_table, motion_coordinates
from hisopt.coupled.model import CoupledModel
from hisopt.errors import ConfigError
from hisopt.road.profiles import step_profile
from hisopt.simulation.identification import (
    BODY_COORDINATES,
    LOWPASS_HZ,
    BodyMode,
    IdentifiedMode,
    amplitude_spectrum,
    body_motion,
    identify_mode,
    lowpass,
)
from hisopt.simulation.timedomain import SimulationMode, TimeResponse, simulate
from hisopt.units import attach_units, display_for

if TYPE_CHECKING:
    from hisopt.plotting import Figure
    from hisopt.problem import Problem

DropCase = Literal["front_axle", "left_side", "all_wheels"]
"""The paper's three drop tests (Fig. 11)."""


@dataclass(frozen=True)
class DropCaseSpec:
    """Wheels that drop, the body mode the test excites and its body coordinate index."""

    wheels: tuple[str, ...]
    mode: BodyMode
    coordinate: int


DROP_CASES: dict[str, DropCaseSpec] = {  # mode: what the test is meant to excite (its coordinate)
    "front_axle": DropCaseSpec(("fl", "fr"), "pitch", 2),
    "left_side": DropCaseSpec(("fl", "rl"), "roll", 1),
    "all_wheels": DropCaseSpec(WHEEL_NAMES, "bounce", 0),
}
"""Paper Section VI: front axle -> pitch, left side -> roll, all wheels -> bounce."""

BODY_SENSORS = tuple(f"body_{w}" for w in WHEEL_NAMES)
WHEEL_SENSORS = tuple(f"wheel_{w}" for w in WHEEL_NAMES)
SENSOR_NAMES = BODY_SENSORS + WHEEL_SENSORS
"""The eight accelerometers [m/s^2]: body above each wheel, then each wheel (z up)."""

TABLE_COLUMNS = ("case", "p0", "mode", "mac", "frequency_time_hz", "frequency_model_hz", "error_pct", "damping")
"""Columns of Table 3 as written by ``hisopt droptest``."""

PAIRING_WINDOW = 0.3
"""[-] A model mode is a candidate for a drop test's signal when its damped frequency is
within 30 % of the identified one: wide enough for the model errors a drop test is meant to
show (the paper's are a few %), narrow enough to leave out modes of another kind (wheel
modes lie a decade higher). Among the candidates the shape decides (:func:`pair_mode`)."""

MAC_MIN = 0.8
"""[-] Smallest modal assurance criterion for pairing a signal with a mode. The shapes are
mass-weighted, so for a signal mixing orthogonal modes the MAC with one of them is the
share of the signal's kinetic energy in that mode's shape: 0.8 means at least 80 % of the
motion is the paired mode. Exactly one candidate must reach it; otherwise the signal is
reported as mixed. A noise-free simulated drop gives ``1 - MAC < 1e-6``."""

DEFAULT_HEIGHT_M = 0.05
"""[m] Drop height: a common block (kerb-like ramp) height for vehicle drop tests. It gives
corner accelerations of a few m/s^2, far above accelerometer noise. The dropped wheels leave
the road for a moment and the accumulators swing by up to ~16 % of their gas volume in the
first cycle, but the free decay the identification uses is milder: the nonlinear model (gas
law, tyre lift-off) gives the same frequencies within 0.1 % (``tests/test_droptest.py``)."""


SAMPLE_RATE_HZ = 200.0
"""[Hz] Sampling rate of simulated drop records."""


# --- drop tests ----------------------------------------------------------------------------


def drop_profile(t_s: ArrayLike, case: DropCase, height_m: float = DEFAULT_HEIGHT_M, t_drop_s: float = 0.5) -> NDArray[np.float64]:
    """Road under the four wheels of a drop test: a step of ``-height_m`` under the case's wheels.

    Parameters
    ----------
    t_s
        [s] Increasing times, shape ``(n_t,)``.
    case
        ``"front_axle"``, ``"left_side"`` or ``"all_wheels"``.
    height_m
        [m] Drop height ``> 0``.
    t_drop_s
        [s] Time of the drop.

    Returns
    -------
    ndarray, shape ``(n_t, 4)``
        [m] Road displacement at FL, FR, RL, RR.
    """
    spec = _case(case)
    if not height_m > 0.0:
        raise ConfigError(f"expected a drop height > 0 [m], got {height_m!r}", key="height")
    return step_profile(t_s, -height_m, t_drop_s, spec.wheels)  # type: ignore[arg-type]


def simulate_drop(
    model: CoupledModel,
    case: DropCase,
    height_m: float = DEFAULT_HEIGHT_M,
    duration_s: float = 6.0,
    t_drop_s: float = 0.5,
    sample_rate_hz: float = SAMPLE_RATE_HZ,
    mode: SimulationMode = "linear",
) -> TimeResponse:
    """Time response of one drop test (see the module docstring).

    Parameters
    ----------
    model
        Single-design lumped model.
    case
        Drop test.
    height_m
        [m] Drop height.
    duration_s
        [s] Record length, the drop at ``t_drop_s``.
    t_drop_s
        [s] Time of the drop (a quiet lead-in, as in a measured record).
    sample_rate_hz
        [Hz] Sampling rate of the record.
    mode
        ``"linear"``, or ``"nonlinear"``: gas law in the accumulators and tyres that lift off.

    Returns
    -------
    TimeResponse
    """
    of_type(model, CoupledModel, "model", "a CoupledModel (a problem's model(design))")
    _case(case)
    number(height_m, "height_m", positive=True, unit="m")
    duration_s = number(duration_s, "duration_s", positive=True, unit="s")
    sample_rate_hz = number(sample_rate_hz, "sample_rate_hz", positive=True, unit="Hz")
    number(t_drop_s, "t_drop_s", low=0.0, high=duration_s, unit="s")
    t = np.arange(int(round(duration_s * sample_rate_hz)) + 1) / sample_rate_hz
    road = drop_profile(t, case, height_m, t_drop_s)
    if mode == "nonlinear":
        return simulate(model, t, road, "nonlinear", tyre_liftoff=True)
    return simulate(model, t, road, mode)


def sensor_frame(t_s: ArrayLike, corner_acc: ArrayLike, wheel_acc: ArrayLike | None = None) -> pd.DataFrame:
    """Accelerometer record in the measured-file layout: ``time`` plus :data:`SENSOR_NAMES`.

    Parameters
    ----------
    t_s
        [s] Sample times, shape ``(n_t,)``.
    corner_acc
        [m/s^2] Body above FL, FR, RL, RR, shape ``(n_t, 4)``.
    wheel_acc
        [m/s^2] Wheels FL, FR, RL, RR, shape ``(n_t, 4)``; omitted columns are left out.
    """
    cols: dict[str, Any] = {"time": np.asarray(t_s, dtype=float)}
    cols |= dict(zip(BODY_SENSORS, np.asarray(corner_acc, dtype=float).T, strict=True))
    if wheel_acc is not None:
        cols |= dict(zip(WHEEL_SENSORS, np.asarray(wheel_acc, dtype=float).T, strict=True))
    return pd.DataFrame(cols)


def response_sensors(response: TimeResponse) -> pd.DataFrame:
    """The eight sensor signals of a simulated drop (unfiltered), measured-file layout."""
    of_type(response, TimeResponse, "response", "a TimeResponse (hisopt.simulate_drop, hisopt.simulate)")
    return sensor_frame(response.t_s, response.corner_acceleration, response.acceleration[:, 3:])


@dataclass(frozen=True)
class Pairing:
    """Which model mode a drop test's signal is (:func:`pair_mode`).

    ``mode``: a name of :data:`hisopt.coupled.modal.MODE_NAMES`; ``"mixed: a+b"`` when the
    signal's shape matches no single candidate (the two modes of highest MAC, highest
    first); ``"none"`` when no model mode lies within :data:`PAIRING_WINDOW` of the signal's
    frequency. ``mac`` [-]: MAC with the paired mode, else the best candidate's (NaN:
    none). ``frequency_model_hz`` [Hz]: damped frequency of the paired mode (NaN unless
    paired). ``macs``: MAC with every mechanical mode of the model.
    """

    mode: str
    mac: float
    frequency_model_hz: float
    macs: dict[str, float] = field(repr=False)

    @property
    def paired(self) -> bool:
        """Whether the signal is one mode (so a frequency error is meaningful)."""
        return self.mode in MODE_NAMES


def pair_mode(model: CoupledModel, identified: IdentifiedMode) -> Pairing:
    """Pair an identified drop-test mode with the model mode it is, by frequency and shape.

    The candidates are the model's mechanical modes whose damped frequency lies within
    :data:`PAIRING_WINDOW` of the identified frequency. The identified complex shape (body
    bounce, roll and pitch and, if recorded, the four wheels) and each mode's shape are
    mass-weighted (:func:`hisopt.coupled.modal.motion_coordinates`) and compared by the modal
    assurance criterion (:func:`hisopt.coupled.modal.mac`) over the recorded coordinates. The
    signal is paired with a candidate of ``MAC >= MAC_MIN`` if it is the only such one;
    else it is mixed.

    Parameters
    ----------
    model
        Single-design model at the test's precharge.
    identified
        Output of :func:`hisopt.simulation.identification.identify_mode`.
    """
    table = modal_table(model).set_index("mode")
    _, shapes = mechanical_mode_shapes(model)
    names = [n for j, n in enumerate(MODE_NAMES) if n in table.index and np.all(np.isfinite(shapes[:, j]))]
    columns = [MODE_NAMES.index(n) for n in names]
    shape = np.asarray(identified.shape, dtype=complex)
    rows = [0, 1, 2] + ([3, 4, 5, 6] if np.all(np.isfinite(shape[3:])) else [])  # recorded motions
    u = motion_coordinates(np.nan_to_num(shape)[:, None], np.diag(model.mass))[rows]
    macs = mac(u, shapes[rows][:, columns])[0]
    f_model = table.loc[names, "damped_frequency_hz"].to_numpy(dtype=float)
    near = np.abs(f_model / identified.frequency_hz - 1.0) <= PAIRING_WINDOW
    by_mac = {n: float(m) for n, m in zip(names, macs, strict=True)}
    if not near.any():
        return Pairing("none", float("nan"), float("nan"), by_mac)
    candidates = np.flatnonzero(near)[np.argsort(-macs[near], kind="stable")]
    best = candidates[0]
    if macs[best] >= MAC_MIN and (len(candidates) == 1 or macs[candidates[1]] < MAC_MIN):
        return Pairing(names[best], float(macs[best]), float(f_model[best]), by_mac)
    top = np.argsort(-macs, kind="stable")[:2]
    return Pairing("mixed: " + "+".join(names[i] for i in top), float(macs[best]), float("nan"), by_mac)


@dataclass(frozen=True)
class DropTest:
    """One processed drop test: filtered sensors, body accelerations and the identified mode.

    ``signals``: filtered accelerations (``time`` + sensors); ``body`` ``(n_t, 3)``;
    ``pairing``: the model mode the identified one is, by frequency and shape (:func:`pair_mode`).
    """

    case: DropCase
    p0_pa: float
    source: Literal["simulated", "measured"]
    signals: pd.DataFrame
    body: NDArray[np.float64] = field(repr=False)
    identified: IdentifiedMode
    pairing: Pairing
    window_s: float

    @property
    def mode(self) -> str:
        """The model mode the signal is (``"mixed: a+b"`` or ``"none"`` if no single one)."""
        return self.pairing.mode

    @property
    def model_frequency_hz(self) -> float:
        """[Hz] Damped frequency of the paired model mode (NaN unless paired)."""
        return self.pairing.frequency_model_hz

    def row(self) -> dict[str, Any]:
        """One row of Table 3 (:data:`TABLE_COLUMNS`); no error against a mode it is not."""
        f_t, f_m = self.identified.frequency_hz, self.model_frequency_hz
        return {
            "case": self.case,
            "p0": self.p0_pa,
            "mode": self.mode,
            "mac": self.pairing.mac,
            "frequency_time_hz": f_t,
            "frequency_model_hz": f_m,
            "error_pct": 100.0 * (f_t / f_m - 1.0),
            "damping": self.identified.damping_ratio,
        }

    def spectrum(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """[Hz], [unit s] Amplitude spectrum of the test's body coordinate over the decay."""
        t = self.signals["time"].to_numpy()
        start = int(np.searchsorted(t, self.identified.t_start_s))
        stop = int(np.searchsorted(t, self.identified.t_start_s + self.window_s))
        coord = DROP_CASES[self.case].coordinate
        return amplitude_spectrum(t[start:stop], self.body[start:stop, coord])

    def to_frame(self) -> pd.DataFrame:
        """Filtered sensors plus the body accelerations ``a_z_s, a_phi, a_theta``."""
        body = pd.DataFrame(self.body, columns=[f"a_{c}" for c in BODY_COORDINATES])
        return pd.concat([self.signals.reset_index(drop=True), body], axis=1)

    def _spectrum_data(self) -> dict[str, Any]:
        """What a figure of the spectrum needs (:mod:`hisopt.plotting.droptest`)."""
        f, mag = self.spectrum()
        return {"case": self.case, "p0_pa": self.p0_pa, "source": self.source, "mode": self.mode, "f_hz": f, "magnitude": mag}

    def plot_spectrum(self, fig: Figure | None = None, row: int | None = None) -> Figure:
        """Response spectrum of the test's body coordinate (paper Fig. 13), one trace (:func:`hisopt.plotting.droptest.drop_spectrum_figure`)."""
        from hisopt.plotting.droptest import drop_spectrum_figure

        return drop_spectrum_figure(self._spectrum_data(), fig, row)


def _case(case: str) -> DropCaseSpec:
    if case not in DROP_CASES:
        raise ConfigError(f"unknown drop test {case!r}; expected one of {', '.join(DROP_CASES)}", key="case")
    return DROP_CASES[case]


def _with_p0(problem: Problem, p0_pa: float) -> Problem:
    if not p0_pa >= 0.0:
        raise ConfigError(f"expected a gauge precharge p0 >= 0 [Pa], got {p0_pa!r}", key="p0")
    return problem.with_values(p0=float(p0_pa))


def model_frequency(problem: Problem, case: DropCase, p0_pa: float) -> float:
    """[Hz] Damped frequency of the mode the case is meant to excite (:data:`DROP_CASES`)
    from :func:`hisopt.modal_analysis` at ``p0``; Table 3 pairs by shape instead
    (:func:`pair_mode`), since on some layouts a test excites another mode most."""
    modes = modal_analysis(_with_p0(problem, p0_pa)).set_index("mode")
    return float(modes.loc[_case(case).mode, "damped_frequency_hz"])


def process_record(
    problem: Problem,
    case: DropCase,
    p0_pa: float,
    record: pd.DataFrame,
    source: Literal["simulated", "measured"],
    window_s: float = 4.0,
) -> DropTest:
    """Filter, project and identify a drop-test record (``time`` + sensor columns, SI).

    Parameters
    ----------
    problem
        Vehicle and HIS (the model frequency is computed at ``p0_pa``).
    case
        Which drop test the record is.
    p0_pa
        [Pa] Gauge accumulator precharge of the test.
    record
        ``time`` [s] and at least the four ``body_*`` columns [m/s^2].
    source
        ``"simulated"`` or ``"measured"``.
    window_s
        [s] Length of the analysed free decay.
    """
    spec = _case(case)
    t = record["time"].to_numpy(dtype=float)
    fs = 1.0 / float(np.median(np.diff(t)))
    sensors = [c for c in SENSOR_NAMES if c in record.columns]
    raw = record[sensors].to_numpy(dtype=float)
    # Accelerometers may carry gravity or a bias: the motion has died out by the end of a
    # drop record, so its last second is the offset (ERA alone would not mind; spectra do).
    raw = raw - np.median(raw[t >= t[-1] - 1.0], axis=0)
    filtered = lowpass(raw, fs)
    signals = pd.DataFrame(filtered, columns=sensors)
    signals.insert(0, "time", t)
    vehicle = problem.vehicle
    body = body_motion(signals[list(BODY_SENSORS)].to_numpy(), vehicle)
    wheels = signals[list(WHEEL_SENSORS)].to_numpy() if set(WHEEL_SENSORS) <= set(sensors) else None
    identified = identify_mode(t, body, vehicle, spec.mode, window_s, wheel_acc=wheels)
    pairing = pair_mode(_with_p0(problem, p0_pa).model(), identified)
    return DropTest(case, float(p0_pa), source, signals, body, identified, pairing, window_s)


def run_drop_test(
    problem: Problem,
    case: DropCase,
    p0_pa: float,
    height_m: float = DEFAULT_HEIGHT_M,
    mode: SimulationMode = "linear",
) -> DropTest:
    """Simulate and process one drop test at precharge ``p0_pa`` (other values: baseline).

    Parameters
    ----------
    problem
        Vehicle and HIS; the design is the baseline with ``p0`` replaced.
    case
        Drop test.
    p0_pa
        [Pa] Gauge accumulator precharge.
    height_m
        [m] Drop height.
    mode
        Simulation fidelity (see :func:`simulate_drop`).
    """
    model = _with_p0(problem, p0_pa).model()
    response = simulate_drop(model, case, height_m, mode=mode)
    return process_record(problem, case, p0_pa, response_sensors(response), "simulated")


def check_drop_arguments(p0_pa: Sequence[float], height_m: float, mode: str, names: Mapping[str, str] | None = None) -> list[float]:
    """The precharges [Pa] of a set of drop tests, after refusing in one line a bad list of
    precharges (empty, not finite or below 0), drop height (not finite or not > 0) or mode;
    ``names`` the arguments as the caller knows them (``hisopt droptest``: ``--p0``,
    ``--height``, ``--mode``; the library: ``p0``, ``height``, ``mode``)."""
    from hisopt.specification.validation import magnitude_problem

    key = {"p0": "p0", "height": "height", "mode": "mode"} | dict(names or {})
    if isinstance(p0_pa, (str, bytes)) or np.ndim(p0_pa) != 1:
        raise ConfigError(f"expected a list of gauge precharges [Pa], e.g. [1e6, 2e6], got {p0_pa!r}", key=key["p0"])
    not_empty(p0_pa, key["p0"], "precharge")
    values = [number(v, key["p0"], low=0.0, unit="Pa") for v in p0_pa]
    number(height_m, key["height"], positive=True, unit="m")
    wrong = magnitude_problem(float(height_m))
    if wrong:
        raise ConfigError(f"{wrong}, got {height_m!r} m", key=key["height"])
    one_of(mode, ("linear", "nonlinear"), key["mode"])
    return values


def run_drop_tests(
    problem: Problem,
    p0_pa: Sequence[float],
    height_m: float = DEFAULT_HEIGHT_M,
    cases: Sequence[DropCase] = ("front_axle", "left_side", "all_wheels"),
    mode: SimulationMode = "linear",
) -> list[DropTest]:
    """All drop tests for each precharge (paper Table 3 uses 1, 2 and 3 MPa)."""
    p0_pa = check_drop_arguments(p0_pa, height_m, mode)
    not_empty(cases, "cases", "drop test case")
    return [run_drop_test(problem, case, p0, height_m, mode) for p0 in p0_pa for case in cases]


def drop_table(tests: Sequence[DropTest]) -> pd.DataFrame:
    """Table 3: one row per test, columns :data:`TABLE_COLUMNS` (units in ``attrs["units"]``).

    A measured test replaces the simulated one of the same case and ``p0`` (its
    ``frequency_time_hz`` is the measured frequency); other measured tests are appended.
    """
    _check_tests(tests)
    rows: dict[tuple[str, float], dict[str, Any]] = {}
    for test in sorted(tests, key=lambda d: d.source == "measured"):
        rows[(test.case, test.p0_pa)] = test.row()
    frame = pd.DataFrame(list(rows.values()), columns=list(TABLE_COLUMNS))
    return attach_units(frame, extra={"p0": "Pa", "mac": "-"})


def _check_tests(tests: Sequence[DropTest]) -> None:
    """Refuse anything but a non-empty sequence of drop tests (``tests``)."""
    of_type(tests, Sequence, "tests", "a list of drop tests (hisopt.run_drop_tests, hisopt.measured_drop_test)")
    not_empty(tests, "tests", "drop test")
    for test in tests:
        of_type(test, DropTest, "tests", "a list of drop tests (hisopt.run_drop_tests, hisopt.measured_drop_test)")


def unpaired_notes(tests: Sequence[DropTest]) -> list[str]:
    """One line for each row of :func:`drop_table` whose signal is no single mode (mixed or
    none), saying why it has no model error."""
    sources = {(t.case, t.p0_pa): t.source for t in sorted(tests, key=lambda d: d.source == "measured")}
    notes = []
    for row in drop_table(tests).itertuples():
        if math.isfinite(row.frequency_model_hz):
            continue
        near = f"{row.frequency_time_hz:.3f} Hz"
        why = (
            f"no model mode within {PAIRING_WINDOW:.0%} of {near}"
            if row.mode == "none"
            else f"{row.mode}: the signal's shape matches no single mode near {near} (best MAC {row.mac:.2f}, pairing needs {MAC_MIN:g})"
        )
        p0 = display_for("Pa", np.array([row.p0]))(row.p0)
        notes.append(f"{row.case} at {p0} ({sources[(row.case, row.p0)]}): {why}; no model error reported")
    return notes


# --- measured records ----------------------------------------------------------------------


def read_measured(path: str | Path) -> pd.DataFrame:
    """Read a measured drop-test CSV (format in ``docs/droptest.md``).

    Columns: ``time`` [s], uniformly sampled and increasing; ``body_fl, body_fr, body_rl,
    body_rr`` [m/s^2] (vertical, z up; a constant offset such as gravity is harmless);
    optional ``wheel_fl, wheel_fr, wheel_rl, wheel_rr`` [m/s^2]. Other columns are ignored.
    """
    path = Path(path)
    if not path.is_file():
        raise ConfigError("file not found; expected a CSV with columns time, body_fl, body_fr, body_rl, body_rr", file=str(path))
    try:
        data = pd.read_csv(path, comment="#")
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise ConfigError(f"not a readable CSV ({exc.__class__.__name__}); expected columns time, body_fl, ...", file=str(path)) from exc
    data.columns = [str(c).strip() for c in data.columns]
    missing = [c for c in ("time",) + BODY_SENSORS if c not in data.columns]
    if missing:
        raise ConfigError(
            f"missing column(s) {', '.join(missing)}; expected time [s] and body_fl, body_fr, body_rl, body_rr [m/s^2]",
            file=str(path),
        )
    columns = ["time"] + [c for c in SENSOR_NAMES if c in data.columns]
    values = data[columns].apply(pd.to_numeric, errors="coerce")
    bad = [c for c in columns if not np.all(np.isfinite(values[c].to_numpy(dtype=float)))]
    if bad:
        raise ConfigError(f"column {bad[0]} has empty or non-numeric values; expected numbers in SI units", file=str(path))
    t = values["time"].to_numpy(dtype=float)
    dt = np.diff(t)
    if t.size < 100 or not np.all(dt > 0) or np.ptp(dt) > 0.01 * np.median(dt):
        raise ConfigError("expected an increasing, uniformly sampled time column [s] with >= 100 samples", file=str(path))
    return values


def measured_drop_test(problem: Problem, path: str | Path, case: DropCase, p0_pa: float, window_s: float = 4.0) -> DropTest:
    """Identify the dominant mode of a measured drop-test record (same processing as simulated).

    Parameters
    ----------
    problem
        Vehicle geometry and masses (projection, weighting) and the model for comparison.
    path
        Measured CSV (:func:`read_measured`).
    case
        Which drop test the file records.
    p0_pa
        [Pa] Gauge accumulator precharge during the test.
    window_s
        [s] Length of the analysed free decay.
    """
    _case(case)
    record = read_measured(path)
    fs = 1.0 / float(np.median(np.diff(record["time"].to_numpy())))
    if not fs > 2.0 * LOWPASS_HZ:
        raise ConfigError(
            f"sampling rate {fs:g} Hz is too low; expected > {2 * LOWPASS_HZ:g} Hz for the 20 Hz low-pass",
            file=str(path),
        )
    duration = float(record["time"].iloc[-1] - record["time"].iloc[0])
    if duration < 1.0:
        raise ConfigError(f"record lasts {duration:g} s; expected a free decay of >= 1 s", file=str(path))
    return process_record(problem, case, p0_pa, record, "measured", window_s)


def spectra_figure(tests: Sequence[DropTest]) -> Figure:
    """Response spectra of the drop tests, one panel per body mode (paper Fig. 13; :func:`hisopt.plotting.droptest.drop_spectra_figure`)."""
    from hisopt.plotting.droptest import drop_spectra_figure

    _check_tests(tests)
    return drop_spectra_figure([t._spectrum_data() for t in tests], {case: spec.mode for case, spec in DROP_CASES.items()})


__all__ = [
    "BODY_SENSORS",
    "DEFAULT_HEIGHT_M",
    "DROP_CASES",
    "DropCase",
    "DropTest",
    "MAC_MIN",
    "PAIRING_WINDOW",
    "Pairing",
    "SENSOR_NAMES",
    "TABLE_COLUMNS",
    "drop_profile",
    "drop_table",
    "measured_drop_test",
    "model_frequency",
    "pair_mode",
    "process_record",
    "read_measured",
    "response_sensors",
    "run_drop_test",
    "run_drop_tests",
    "simulate_drop",
    "spectra_figure",
    "unpaired_notes",
]
