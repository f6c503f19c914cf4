"""The figures of a time-domain verification and their verdicts (docs/model.md §22).

Each figure of a load case is one row (:data:`ROW_COLUMNS`): the frequency domain's value (an
exact expectation for the RMS figures; an estimate for peaks and shares; the static value
plus or minus three road sigmas for pressures), the linear and the nonlinear simulations'
estimates with their standard errors, the gap between them and a verdict
(:mod:`hisopt.simulation.verification` runs the simulations).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr

from hisopt.constants import WHEEL_NAMES
from hisopt.errors import ConfigError
from hisopt.simulation.timedomain import TimeResponse

NONLINEARITIES = ("gas_law", "valve_law", "tyre_liftoff")
"""The nonlinearities a gap is attributed to, by their :class:`Nonlinearities` switch."""

CAUSE_LABELS = {"gas_law": "gas law", "valve_law": "valve law", "tyre_liftoff": "tyre lift-off", "combined": "several nonlinearities together"}

AGREES, SMALL_GAP, GAP, WITHIN, BEYOND, OUTSIDE, INFO = "agrees", "small gap", "gap", "within limits", "beyond limit", "outside validity", "info"
"""The verdicts a figure can get."""

EULER_GAMMA = 0.5772156649015329


@dataclass(frozen=True)
class VerifySettings:
    """How :func:`verify_design` samples and judges (SI).

    Attributes
    ----------
    realisations : int | None
        [-] road realisations per load case (each with its mirror); None: chosen so that
        ``sigma_aw``'s standard error is at most ``target_se`` (from ``first_realisations`` up
        to ``max_realisations``)
    duration_s : float
        [s] record kept per simulation
    settle_s : float
        [s] simulated before the record (the car's and the weighting filters' transients)
    seed : int
        [-] realisation ``i`` of load case ``c`` (from 0) uses the generator seeded
        ``(seed, 100000 c + i)`` (:func:`hisopt.simulation.agreement.road_realisation`)
    target_se, worst_se : float
        [-] the relative standard error of ``sigma_aw`` to reach, and the largest accepted
    first_realisations, max_realisations : int
        [-] the automatic choice's first batch and cap
    tyre_off_share : float
        [-] a tyre off the ground for longer than this share of the time leaves the model's validity
    blowoff_share : float
        [-] a damper valve open on its blow-off for longer than this share of the time does too
    gas_volume_share : float
        [-] an accumulator whose oil takes more than this share of its gas volume does too
    rtol : float
        [-] the integrator's relative tolerance
    """

    realisations: int | None = None
    duration_s: float = 20.0
    settle_s: float = 5.0
    seed: int = 41
    target_se: float = 0.02
    worst_se: float = 0.10
    first_realisations: int = 4
    max_realisations: int = 24
    tyre_off_share: float = 0.05
    blowoff_share: float = 0.5
    gas_volume_share: float = 0.95
    rtol: float = 1e-4


def check_settings(settings: VerifySettings, f_min_hz: float, keys: dict[str, str] | None = None) -> None:
    """Refuse settings that cannot give a standard error (one line naming the option)."""
    keys = keys or {}
    r = settings.realisations
    if r is not None and (not isinstance(r, int) or r < 2):
        raise ConfigError(f"expected at least 2 realisations (a standard error needs two), got {r!r}", key=keys.get("realisations", "realisations"))
    shortest = 10.0 / f_min_hz
    if not settings.duration_s >= shortest:
        raise ConfigError(
            f"expected a record of at least {shortest:g} s (ten periods of the band's lowest frequency, {f_min_hz:g} Hz), got {settings.duration_s:g} s",
            key=keys.get("duration", "duration_s"),
        )
    if not settings.settle_s >= 0.0:
        raise ConfigError(f"expected a settling time >= 0 s, got {settings.settle_s!r}", key=keys.get("settle", "settle_s"))


# --- statistics --------------------------------------------------------------------------------
def mean_and_error(samples: NDArray[np.float64]) -> tuple[float, float]:
    """The mean of ``samples`` ``(R,)`` and its standard error (spread over ``sqrt(R)``)."""
    return float(np.mean(samples)), float(np.std(samples, ddof=1) / math.sqrt(samples.size))


def rms_and_error(mean_squares: NDArray[np.float64]) -> tuple[float, float]:
    """The RMS of realisations' mean squares ``(R,)`` and its standard error (delta method:
    half the mean square's relative error)."""
    mean, error = mean_and_error(mean_squares)
    rms = math.sqrt(max(mean, 0.0))
    return rms, (0.5 * error / mean * rms if mean > 0 else 0.0)


def ratio_gap(nonlinear: NDArray[np.float64], linear: NDArray[np.float64]) -> tuple[float, float]:
    """``sqrt(mean MS_nonlinear / mean MS_linear) - 1`` on the same roads and its standard error
    (the spread of ``MS_nl - r MS_lin`` over ``sqrt(R)``, delta method)."""
    ratio = float(nonlinear.mean() / linear.mean())
    error = float(np.std(nonlinear - ratio * linear, ddof=1) / math.sqrt(nonlinear.size) / linear.mean())
    return math.sqrt(ratio) - 1.0, error / (2.0 * math.sqrt(ratio))


def davenport_peak(sigma: float, sigma_rate: float, duration_s: float) -> float:
    """Expected largest ``|x|`` of a stationary Gaussian ``x`` over ``duration_s`` (Davenport
    1964): ``sigma (sqrt(2 ln N) + gamma / sqrt(2 ln N))``, ``N = 2 nu_0 T`` the expected
    crossings of either level, ``nu_0 = sigma_rate / (2 pi sigma)``."""
    n = 2.0 * sigma_rate / (2.0 * math.pi * sigma) * duration_s
    if not (n > math.e and math.isfinite(n)):
        return float("nan")
    root = math.sqrt(2.0 * math.log(n))
    return sigma * (root + EULER_GAMMA / root)


@dataclass(frozen=True)
class FrequencyDomain:
    """A load case's frequency-domain figures of one design (SI): ``sigma_aw``, each wheel's RMS
    stroke, stroke rate and tyre load ``(4,)``, each damper valve's RMS flow, each chamber's
    static pressure [Pa gauge] and RMS swing, each accumulator's static pressure [Pa gauge] and
    RMS swing."""

    sigma_aw: float
    stroke: NDArray[np.float64]
    stroke_rate: NDArray[np.float64]
    tire_load: NDArray[np.float64]
    valve_flow: NDArray[np.float64]
    port_static: NDArray[np.float64]
    port_swing: NDArray[np.float64]
    accumulator_static: NDArray[np.float64]
    accumulator_swing: NDArray[np.float64]


@dataclass(frozen=True)
class RoadRuns:
    """One model's realisations in one load case: each realisation's figures (a road and its
    mirror), the first road's record, and the Welch spectra of every record."""

    figures: list[dict[str, Any]]
    first: TimeResponse
    f_hz: NDArray[np.float64]
    spectra: dict[str, NDArray[np.float64]]


def merged(a: RoadRuns, b: RoadRuns) -> RoadRuns:
    """Two batches of the same case and model as one (the spectra weighted by their records)."""
    na, nb = len(a.figures), len(b.figures)
    spectra = {k: (na * a.spectra[k] + nb * b.spectra[k]) / (na + nb) for k in a.spectra}
    return replace(a, figures=a.figures + b.figures, spectra=spectra)


def stacked(runs: RoadRuns, name: str) -> NDArray[np.float64]:
    """Figure ``name`` of every realisation, ``(R,)`` or ``(R, k)``."""
    return np.stack([np.asarray(f[name], dtype=float) for f in runs.figures])


# --- the rows ------------------------------------------------------------------------------------
ROW_COLUMNS = ("case", "figure", "unit", "frequency_domain", "linear", "linear_se", "nonlinear", "nonlinear_se", "gap", "gap_se", "limit", "verdict", "cause")
"""verify.csv's columns, one row per load case (or manoeuvre) and figure; values SI, each row's
unit in ``unit``; ``gap`` relative (nonlinear over linear or over the frequency domain, minus 1)."""


def _row(case: str, figure: str, unit: str, **values: Any) -> dict[str, Any]:
    row: dict[str, Any] = dict.fromkeys(ROW_COLUMNS, math.nan)
    row.update(case=case, figure=figure, unit=unit, verdict=INFO, cause="")
    row.update(values)
    return row


MATERIAL_GAP = 0.01
"""[-] A gap beyond three standard errors but below this share is a ``"small gap"``: real, and
named, but too small to change a design decision."""


def _judged(gap: float, error: float) -> str:
    if abs(gap) <= 3.0 * error or abs(gap) < 1e-9:
        return AGREES
    return SMALL_GAP if abs(gap) < MATERIAL_GAP else GAP


def rms_rows(case: str, fd: FrequencyDomain, lin: RoadRuns, nl: RoadRuns | None) -> list[dict[str, Any]]:
    """The RMS figures: ``sigma_aw``, the worst wheel's stroke and tyre load, the worst damper
    valve's flow (worst by the frequency domain), compared through the control variate."""
    picks: list[tuple[str, str, str, float, int | None]] = [("sigma_aw", "sigma_aw", "m/s^2", fd.sigma_aw, None)]
    w = int(np.argmax(fd.stroke))
    picks.append((f"rms_stroke_{WHEEL_NAMES[w]}", "rms_stroke", "m", float(fd.stroke[w]), w))
    w = int(np.argmax(fd.tire_load))
    picks.append((f"rms_tire_load_{WHEEL_NAMES[w]}", "rms_tire_load", "N", float(fd.tire_load[w]), w))
    if fd.valve_flow.size:
        j = int(np.argmax(fd.valve_flow))
        picks.append((f"rms_valve_flow_{j}", "rms_valve_flow", "m^3/s", float(fd.valve_flow[j]), j))
    rows = []
    for figure, key, unit, value, column in picks:
        ms_lin = stacked(lin, key) if column is None else stacked(lin, key)[:, column]
        rms_lin, se_lin = rms_and_error(ms_lin)
        row = _row(case, figure, unit, frequency_domain=value, linear=rms_lin, linear_se=se_lin)
        if nl is not None:
            ms_nl = stacked(nl, key) if column is None else stacked(nl, key)[:, column]
            rms_nl, se_nl = rms_and_error(ms_nl)
            gap, gap_se = ratio_gap(ms_nl, ms_lin)
            row.update(nonlinear=rms_nl, nonlinear_se=se_nl, gap=gap, gap_se=gap_se, verdict=_judged(gap, gap_se))
        rows.append(row)
    return rows


def paired_row(
    case: str, figure: str, unit: str, lin: RoadRuns, nl: RoadRuns | None, estimate: float = math.nan, limit: float = math.nan, validity: bool = False
) -> dict[str, Any]:
    """A peak or share: the realisations' mean in each model, the nonlinear run against the
    linear on the same roads (paired differences); beyond ``limit`` (a validity bound when
    ``validity``) said so."""
    a = stacked(lin, figure)
    value_lin, se_lin = mean_and_error(a)
    row = _row(case, figure, unit, frequency_domain=estimate, linear=value_lin, linear_se=se_lin, limit=limit)
    if nl is None:
        return row
    b = stacked(nl, figure)
    value_nl, se_nl = mean_and_error(b)
    diff, diff_se = mean_and_error(b - a)
    scale = abs(value_lin) if value_lin != 0.0 else 1.0
    verdict = _judged(diff / scale, diff_se / scale)
    if validity and value_nl > limit:
        verdict = OUTSIDE
    row.update(nonlinear=value_nl, nonlinear_se=se_nl, gap=diff / scale if value_lin != 0.0 else math.nan, gap_se=diff_se / scale, verdict=verdict)
    return row


def extreme_row(
    case: str,
    figure: str,
    unit: str,
    lin: RoadRuns,
    nl: RoadRuns | None,
    estimate: float,
    limit: float,
    side: str,
    column: int | None = None,
    validity: bool = False,
) -> dict[str, Any]:
    """A pressure's or gas volume's extreme over every record of the case (the lowest for a
    ``"floor"``, the highest for a ``"ceiling"``) against its limit (a bound of the model's
    validity when ``validity``); the frequency domain's ``estimate`` is the static value plus
    or minus three road sigmas."""
    pick = np.min if side == "floor" else np.max

    def worst(runs: RoadRuns) -> float:
        values = stacked(runs, figure)
        return float(pick(values if column is None else values[:, column]))

    row = _row(case, figure if column is None else f"{figure}_{column}", unit, frequency_domain=estimate, linear=worst(lin), limit=limit)
    if nl is not None:
        value = worst(nl)
        holds = value >= limit if side == "floor" else value <= limit
        row.update(nonlinear=value, verdict=WITHIN if holds or not math.isfinite(limit) else OUTSIDE if validity else BEYOND)
    return row


@dataclass(frozen=True)
class CaseLimits:
    """[Pa gauge] What the chambers' and accumulators' pressures are held to (the
    buildability rules', docs/model.md §21), and [m^3] each accumulator's smallest allowed gas
    volume (the model's validity)."""

    chamber_floor: float
    chamber_ceiling: float
    accumulator_floor: NDArray[np.float64]
    accumulator_ceiling: NDArray[np.float64]
    gas_volume_floor: NDArray[np.float64]


def case_rows(
    case: str, fd: FrequencyDomain, static_load: NDArray[np.float64], lin: RoadRuns, nl: RoadRuns | None, limits: CaseLimits | None, settings: VerifySettings
) -> list[dict[str, Any]]:
    """Every figure of one load case (:data:`ROW_COLUMNS`); ``static_load`` [N] each tyre's."""
    rows = rms_rows(case, fd, lin, nl)
    peaks = [davenport_peak(float(s), float(r), settings.duration_s) for s, r in zip(fd.stroke, fd.stroke_rate, strict=True)]
    rows.append(paired_row(case, "peak_stroke", "m", lin, nl, estimate=max(peaks)))
    lift = float(np.max(ndtr(-static_load / fd.tire_load)))  # Gaussian share of time beyond the static load
    rows.append(paired_row(case, "tyre_off_share", "-", lin, nl, estimate=lift, limit=settings.tyre_off_share, validity=True))
    if fd.valve_flow.size:
        rows.append(paired_row(case, "peak_valve_flow", "m^3/s", lin, nl))
        rows.append(paired_row(case, "blowoff_share", "-", lin, nl, limit=settings.blowoff_share, validity=True))
    if limits is None:
        return rows
    three = 3.0
    if fd.port_static.size:
        rows.append(
            extreme_row(case, "chamber_pressure_min", "Pa", lin, nl, float(np.min(fd.port_static - three * fd.port_swing)), limits.chamber_floor, "floor")
        )
        rows.append(
            extreme_row(case, "chamber_pressure_max", "Pa", lin, nl, float(np.max(fd.port_static + three * fd.port_swing)), limits.chamber_ceiling, "ceiling")
        )
        rows.append(paired_row(case, "peak_strut_force", "N", lin, nl))
    for j in range(fd.accumulator_static.size):
        low, high = fd.accumulator_static[j] - three * fd.accumulator_swing[j], fd.accumulator_static[j] + three * fd.accumulator_swing[j]
        rows.append(extreme_row(case, "accumulator_pressure_min", "Pa", lin, nl, float(low), float(limits.accumulator_floor[j]), "floor", j))
        rows.append(extreme_row(case, "accumulator_pressure_max", "Pa", lin, nl, float(high), float(limits.accumulator_ceiling[j]), "ceiling", j))
    if fd.accumulator_static.size:
        rows.append(extreme_row(case, "gas_volume_min", "m^3", lin, nl, math.nan, float(np.min(limits.gas_volume_floor)), "floor", validity=True))
        rows.append(extreme_row(case, "gas_volume_max", "m^3", lin, nl, math.nan, math.inf, "ceiling"))
    return rows


def attribute(rows: list[dict[str, Any]], without: dict[str, list[dict[str, Any]]], only: str | None = None) -> None:
    """Name each gap's cause in place: ``only`` when a single nonlinearity acts; otherwise the
    nonlinearity whose removal (rows ``without[name]``, the same roads with that one off) takes
    away at least half of the gap, else ``"combined"``."""
    for i, row in enumerate(rows):
        if row["verdict"] not in (GAP, SMALL_GAP):
            continue
        if only is not None:
            row["cause"] = CAUSE_LABELS[only]
            continue
        gap = abs(float(row["gap"]))
        remaining = {name: abs(float(other[i]["gap"])) for name, other in without.items()}
        best = min(remaining, key=lambda n: remaining[n])
        row["cause"] = CAUSE_LABELS[best] if remaining[best] <= 0.5 * gap else CAUSE_LABELS["combined"]
