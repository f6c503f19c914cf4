"""One design in the time domain, side by side with the frequency domain (docs/model.md §22).

For each load case of a problem, :func:`verify_case` drives the case's model (its temperature,
payload and valves' operating point, :meth:`hisopt.problem.Problem.model`) over ``R`` seeded
ISO 8608 realisations of the case's road (class, speed, coherence, the wheelbase delay), each
with its mirror (the right track negated: an equally likely road whose pair cancels the random
left-right cross terms), in two models on the same roads:

- ``linear``: the exact lumped state space the frequency domain integrates; its statistics
  against the frequency domain's are the pipeline's own error (record length, band edges);
- ``nonlinear``: the gas law, the valves' laws and tyre lift-off (:class:`Nonlinearities`).

Every road of a case runs in one batched integration per model
(:func:`hisopt.simulation.timedomain.simulate_batch`). The figures
(:mod:`hisopt.simulation.verification_rows`) are formed from the records after a settling
time; ``sigma_aw`` weights the accelerations by the ISO 2631-1 realisable filters in the time
domain (:mod:`hisopt.standards.weighting_filters`), so the frequency domain's is taken by the
filter method too (a problem of the paper's band method is compared so, and told).

Statistics: each realisation (a road and its mirror) gives one value of each figure; the
estimate is their mean and its standard error the spread over ``sqrt(R)``. An RMS figure's
gap to the frequency domain is estimated with the linear run as control variate,
``sqrt(MS_nonlinear / MS_linear) - 1`` on the same roads (the linear run's expectation is the
frequency domain's), with its delta-method standard error; the other figures compare the
nonlinear run with the linear one on the same roads (paired differences). A gap beyond three
standard errors is named: the only nonlinearity acting in the case, or the one whose removal
alone (a rerun on the same roads) takes away most of it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from hisopt.constants import G_MPS2, P_ATM_PA, WHEEL_NAMES
from hisopt.coupled.buildability import pressure_limits
from hisopt.coupled.response import standard_outputs
from hisopt.errors import ConfigError, ModelError
from hisopt.evaluation.build_rules import catalogue_rating
from hisopt.evaluation.evaluate import Evaluator
from hisopt.evaluation.valve_states import valve_states
from hisopt.hydraulics.layout import Accumulator
from hisopt.metrics import COMFORT_OUTPUTS
from hisopt.problem import Problem
from hisopt.simulation.agreement import output_signal, road_realisation
from hisopt.simulation.nonlinear_model import accumulators
from hisopt.simulation.timedomain import Nonlinearities, TimeResponse, simulate_batch
from hisopt.simulation.verification_rows import (
    AGREES,
    BEYOND,
    GAP,
    NONLINEARITIES,
    OUTSIDE,
    ROW_COLUMNS,
    SMALL_GAP,
    CaseLimits,
    FrequencyDomain,
    RoadRuns,
    VerifySettings,
    attribute,
    case_rows,
    check_settings,
    merged,
    rms_and_error,
    stacked,
)


def comfort_mean_square(problem: Problem, outputs: dict[str, Any], response: TimeResponse, keep: NDArray[np.bool_]) -> float:
    """``sigma_aw^2`` of one record: each comfort axis's acceleration weighted in the time
    domain (the filter started at rest with the record), its mean square over ``keep``, summed
    with the axis factors squared (docs/model.md §5.3)."""
    from hisopt.standards.weighting_filters import weighted_signal  # on use: the filters are built on first call

    comfort = problem.spec.comfort
    dt = float(response.t_s[1] - response.t_s[0])
    total = 0.0
    for axis, name in COMFORT_OUTPUTS.items():
        k = getattr(comfort, f"k_{axis}")
        if k == 0.0:
            continue
        weighted = weighted_signal(output_signal(outputs[name], response), dt, outputs[name].weighting)
        total += k * k * float(np.mean(weighted[keep] ** 2))
    return total


@dataclass(frozen=True)
class CaseFacts:
    """What a load case's records are read against: its outputs, the static tyre loads [N],
    each accumulator's gas volume [m^3] at the operating point, and the damper valves'
    crossover flows [m^3/s] (``inf`` for a bleed alone)."""

    outputs: dict[str, Any]
    static_load: NDArray[np.float64]
    v0: NDArray[np.float64]
    crossover: NDArray[np.float64]


def record_figures(problem: Problem, facts: CaseFacts, response: TimeResponse, keep: NDArray[np.bool_]) -> dict[str, Any]:
    """Every figure of one record after the settling time (``keep``): mean squares for the RMS
    figures (per wheel or valve), peaks, shares and extremes (SI)."""
    out: dict[str, Any] = {"sigma_aw": comfort_mean_square(problem, facts.outputs, response, keep)}
    stroke, tyre = response.stroke_m[keep], response.tyre_force_n[keep]
    out["rms_stroke"] = np.mean(stroke**2, axis=0)
    out["rms_tire_load"] = np.mean(tyre**2, axis=0)
    out["peak_stroke"] = float(np.abs(stroke).max())
    out["tyre_off_share"] = float(np.max(np.mean(-tyre >= facts.static_load * (1.0 - 1e-9), axis=0)))
    if response.valve_flow_m3s.shape[1]:
        flows = response.valve_flow_m3s[keep]
        out["rms_valve_flow"] = np.mean(flows**2, axis=0)
        out["peak_valve_flow"] = float(np.abs(flows).max())
        out["blowoff_share"] = float(np.max(np.mean(np.abs(flows) > facts.crossover, axis=0)))
    if response.port_pressure_pa.shape[1]:
        ports = response.port_pressure_pa[keep]
        out["chamber_pressure_min"], out["chamber_pressure_max"] = float(ports.min()), float(ports.max())
        out["peak_strut_force"] = float(np.abs(response.strut_force_n[keep]).max())
    if response.accumulator_pressure_pa.shape[1]:
        acc = response.accumulator_pressure_pa[keep]
        out["accumulator_pressure_min"], out["accumulator_pressure_max"] = acc.min(axis=0), acc.max(axis=0)
        stored = response.accumulator_volume_m3[keep]
        out["gas_volume_min"] = float(np.min(facts.v0 - stored.max(axis=0)))
        out["gas_volume_max"] = float(np.max(facts.v0 - stored.min(axis=0)))
        out["gas_share_max"] = float(np.max(stored.max(axis=0) / facts.v0))
    return out


def realisation_figures(problem: Problem, facts: CaseFacts, pair: list[TimeResponse], settle_s: float) -> dict[str, Any]:
    """One realisation's figures from a road and its mirror: mean squares, peaks and shares
    averaged over the pair; extremes the pair's lowest and highest."""
    keep = pair[0].t_s >= pair[0].t_s[0] + settle_s
    both = [record_figures(problem, facts, r, keep) for r in pair]
    out: dict[str, Any] = {}
    for name in both[0]:
        values = [np.asarray(b[name], dtype=float) for b in both]
        if name.endswith("_min"):
            out[name] = np.minimum(*values)
        elif name.endswith("_max"):
            out[name] = np.maximum(*values)
        else:
            out[name] = 0.5 * (values[0] + values[1])
    return out


# --- one load case -------------------------------------------------------------------------------
def case_facts(model: Any) -> CaseFacts:
    """The :class:`CaseFacts` of a single-design model."""
    car = model.car
    his = model.his
    v0 = accumulators(his).v0 if his is not None else np.zeros(0)
    crossover = []
    if his is not None:
        for k, _, _ in his.network.damper_valves():
            _, kq, p_c, _ = his.values.damper[k]
            crossover.append(math.inf if p_c is None else math.sqrt(float(np.ravel(p_c)[0]) / float(np.ravel(kq)[0])))
    return CaseFacts(standard_outputs(car), car.static_corner_loads(G_MPS2), v0, np.asarray(crossover, dtype=float))


def frequency_domain(case: Problem, x: NDArray[np.float64], model: Any) -> FrequencyDomain:
    """The evaluator's figures of design ``x`` ``(1, n_var)`` on ``case`` (one load case)."""
    from hisopt.coupled.buildability import circuit_pressures, port_values

    network = case.network()
    n_acc, n_ports = len(network.accumulators()), len(network.ports)
    wheels = [f"{q}_{w}" for q in ("stroke", "stroke_rate", "tire_load") for w in WHEEL_NAMES]
    hydraulic = [f"port_pressure_{i}" for i in range(n_ports)] + [f"oil_volume_{j}" for j in range(n_acc)]
    sigma = float(Evaluator(case, names=("sigma_aw",))(x)["sigma_aw"][0])
    rms = Evaluator(case, names=(), rms_outputs=tuple(wheels + hydraulic)).output_rms(model, wheels + hydraulic)[0]
    states = valve_states(case, x)
    his = model.his
    if his is None:
        empty = np.zeros(0)
        return FrequencyDomain(sigma, rms[:4], rms[4:8], rms[8:12], empty, empty, empty, empty, empty)
    static = np.ravel(circuit_pressures(his))
    circuits = [c for c, e in network.elements if isinstance(e, Accumulator)]
    compliance = np.ravel(his.accumulator_compliances())
    return FrequencyDomain(
        sigma,
        rms[:4],
        rms[4:8],
        rms[8:12],
        states.flow_rms[0] if states.labels else np.zeros(0),
        np.ravel(port_values(his, static)) - P_ATM_PA,
        rms[12 : 12 + n_ports],
        static[circuits] - P_ATM_PA,
        rms[12 + n_ports :] / compliance,
    )


SPECTRUM_OUTPUTS = ("acc_z", "acc_roll", "acc_pitch", "stroke_fl", "tire_load_fl")
"""The outputs whose simulated spectra verify.html lays over the frequency domain's PSDs."""


def road_grid(case: Problem, settings: VerifySettings) -> NDArray[np.float64]:
    """[s] The records' sample times: five samples per period of the band's top (the cubic
    road and the weighting filters hold their shape there), settling time included."""
    dt = 1.0 / (5.0 * case.spec.band.f_max_hz)
    return np.arange(int(round((settings.settle_s + settings.duration_s) / dt)), dtype=float) * dt


def road_pairs(case: Problem, t: NDArray[np.float64], settings: VerifySettings, case_index: int, first: int, count: int) -> NDArray[np.float64]:
    """[m] Realisations ``first .. first + count - 1`` of ``case``'s road, each followed by its
    mirror (the right track negated), ``(2 count, n_t, 4)``."""
    mirror = np.array([1.0, -1.0, 1.0, -1.0])
    roads = []
    for i in range(first, first + count):
        road = road_realisation(case, t, settings.seed, 100_000 * case_index + i)
        roads += [road, road * mirror]
    return np.stack(roads)


def run_roads(
    case: Problem, model: Any, facts: CaseFacts, t: NDArray[np.float64], roads: NDArray[np.float64], switches: Nonlinearities | None, settings: VerifySettings
) -> RoadRuns:
    """Simulate ``roads`` (pairs) in one batch: the linear model (``switches`` None) or the
    nonlinear one with ``switches``; :class:`ModelError` if it leaves its validity."""
    from scipy.signal import welch

    mode = "linear" if switches is None else "nonlinear"
    responses = simulate_batch(model, t, roads, mode, interpolation="cubic", method="RK45", rtol=settings.rtol, nonlinearities=switches)  # type: ignore[arg-type]
    figures = [realisation_figures(case, facts, responses[i : i + 2], settings.settle_s) for i in range(0, len(responses), 2)]
    keep = t >= t[0] + settings.settle_s
    dt = float(t[1] - t[0])
    segment = min(int(round(4.0 / dt)), int(keep.sum()))
    spectra: dict[str, NDArray[np.float64]] = {}
    f = np.zeros(0)
    for name in SPECTRUM_OUTPUTS:
        records = np.stack([output_signal(facts.outputs[name], r)[keep] for r in responses])
        f, power = welch(records, fs=1.0 / dt, nperseg=segment, axis=-1)
        spectra[name] = power.mean(axis=0)
    return RoadRuns(figures, responses[0], f, spectra)


def case_limits(case: Problem, model: Any, facts: CaseFacts, settings: VerifySettings) -> CaseLimits | None:
    """The :class:`CaseLimits` of a model with HIS (None without)."""
    if model.his is None:
        return None
    bounds = pressure_limits(model.his, case.spec.build_limits, catalogue_rating(case))
    return CaseLimits(
        float(bounds.port_floor) - P_ATM_PA,
        float(bounds.port_ceiling),
        np.ravel(bounds.accumulator_floor) - P_ATM_PA,
        np.ravel(bounds.accumulator_ceiling),
        (1.0 - settings.gas_volume_share) * facts.v0,
    )


# --- the verification of a design ---------------------------------------------------------------
@dataclass(frozen=True)
class CaseTraces:
    """What verify.html draws of one load case: the worst second of the first road in both
    models (``signals``: name -> ``(linear, nonlinear)`` records, SI, ``units``), and the
    spectra of every record (``spectra``: name -> ``(frequency domain, linear, nonlinear)``
    one-sided PSDs at ``f_hz``)."""

    case: str
    t_s: NDArray[np.float64]
    signals: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]
    units: dict[str, str]
    f_hz: NDArray[np.float64]
    spectra: dict[str, tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]]


@dataclass(frozen=True)
class CaseVerification:
    """One load case's rows (:data:`ROW_COLUMNS`), traces, realisations used and what the
    nonlinear run says of the model's validity (plain sentences)."""

    rows: list[dict[str, Any]]
    traces: CaseTraces
    realisations: int
    notes: tuple[str, ...]


def worst_second(record: TimeResponse, facts: CaseFacts, settle_s: float) -> slice:
    """The one-second window after settling with the largest mean square of the CG's vertical
    acceleration."""
    dt = float(record.t_s[1] - record.t_s[0])
    width = max(int(round(1.0 / dt)), 1)
    start = int(np.searchsorted(record.t_s, record.t_s[0] + settle_s))
    a = output_signal(facts.outputs["acc_z"], record)[start:] ** 2
    if a.size <= width:
        return slice(start, start + a.size)
    power = np.convolve(a, np.ones(width), mode="valid")
    first = start + int(np.argmax(power))
    return slice(first, first + width)


TRACE_SIGNALS = ("acc_z", "roll", "stroke_fl", "stroke_fr", "stroke_rl", "stroke_rr", "tire_load_fl", "tire_load_fr", "tire_load_rl", "tire_load_rr")


def case_traces(
    case: str, model: Any, fd_psd: dict[str, NDArray[np.float64]], facts: CaseFacts, lin: RoadRuns, nl: RoadRuns | None, settle_s: float
) -> CaseTraces:
    """The :class:`CaseTraces` of one load case."""
    chosen = nl.first if nl is not None else lin.first
    window = worst_second(chosen, facts, settle_s)
    signals: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}
    units: dict[str, str] = {}
    for name in TRACE_SIGNALS:
        out = facts.outputs[name]
        pair = [output_signal(out, r.first)[window] if r is not None else np.full(window.stop - window.start, np.nan) for r in (lin, nl)]
        signals[name], units[name] = (pair[0], pair[1]), out.unit
    for label, attr, unit in (("p_port", "port_pressure_pa", "Pa"), ("p_acc", "accumulator_pressure_pa", "Pa"), ("valve_flow", "valve_flow_m3s", "m^3/s")):
        for i in range(getattr(lin.first, attr).shape[1]):
            pair = [getattr(r.first, attr)[window, i] if r is not None else np.full(window.stop - window.start, np.nan) for r in (lin, nl)]
            signals[f"{label}_{i}"], units[f"{label}_{i}"] = (pair[0], pair[1]), unit
    spectra = {name: (fd_psd[name], lin.spectra[name], nl.spectra[name] if nl is not None else np.full(lin.f_hz.size, np.nan)) for name in SPECTRUM_OUTPUTS}
    return CaseTraces(case, lin.first.t_s[window], signals, units, lin.f_hz, spectra)


def frequency_domain_psd(case: Problem, model: Any, f_hz: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
    """The frequency domain's one-sided PSDs of :data:`SPECTRUM_OUTPUTS` at ``f_hz`` (0 outside the band)."""
    from hisopt.evaluation.channels import DirectOutputs

    ev = Evaluator(case, names=("sigma_aw",))
    chosen = {name: ev.all_outputs[name] for name in SPECTRUM_OUTPUTS}
    band = case.spec.band
    inside = (f_hz >= band.f_min_hz) & (f_hz <= band.f_max_hz)
    f = f_hz[inside][None, :]
    psd = ev.spectra(f, DirectOutputs(model, chosen)(2 * np.pi * f))[0]
    out = {}
    for i, name in enumerate(SPECTRUM_OUTPUTS):
        full = np.zeros(f_hz.size)
        full[inside] = psd[:, i]
        out[name] = full
    return out


def active_nonlinearities(model: Any, nl: RoadRuns) -> list[str]:
    """The nonlinearities (:data:`NONLINEARITIES`) that act in a load case: the gas law with an
    accumulator, the valves' laws with a damper valve or an orifice with a quadratic part, tyre
    lift-off when a tyre left the road in the nonlinear run. Only these can cause a gap."""
    from hisopt.simulation.timedomain import has_nonlinear_valve

    acts = {
        "gas_law": model.his is not None and bool(model.his.network.accumulators()),
        "valve_law": has_nonlinear_valve(model),
        "tyre_liftoff": bool(np.any(stacked(nl, "tyre_off_share") > 0.0)),
    }
    return [name for name in NONLINEARITIES if acts[name]]


def verify_case(case: Problem, x: NDArray[np.float64], name: str, index: int, settings: VerifySettings) -> CaseVerification:
    """Verify design ``x`` ``(1, n_var)`` on one load case ``case`` (module docstring)."""
    notes: list[str] = []
    if case.spec.comfort.method != "filter":
        notes.append(f"{name}: sigma_aw in both domains by the filter method (the problem's [comfort] method is {case.spec.comfort.method!r})")
        spec = case.spec.model_copy(update={"comfort": case.spec.comfort.model_copy(update={"method": "filter"})})
        case = type(case)(spec, case.path)
    model = case.model(x)
    facts = case_facts(model)
    fd = frequency_domain(case, x, model)
    limits = case_limits(case, model, facts, settings)
    t = road_grid(case, settings)
    everything = Nonlinearities(gas_law=True, valve_law=True, tyre_liftoff=True)

    def batch(first: int, count: int) -> tuple[RoadRuns, RoadRuns | None]:
        roads = road_pairs(case, t, settings, index, first, count)
        lin = run_roads(case, model, facts, t, roads, None, settings)
        try:
            return lin, run_roads(case, model, facts, t, roads, everything, settings)
        except ModelError as exc:
            notes.append(f"{name}: the nonlinear model leaves its validity on this road: {exc}")
            return lin, None

    count = settings.realisations or settings.first_realisations
    lin, nl = batch(0, count)
    if settings.realisations is None and count < settings.max_realisations:
        _, error = rms_and_error(stacked(nl if nl is not None else lin, "sigma_aw"))
        relative = error / max(math.sqrt(float(np.mean(stacked(lin, "sigma_aw")))), 1e-300)
        needed = min(settings.max_realisations, math.ceil(count * (relative / settings.target_se) ** 2))
        if needed > count:
            more_lin, more_nl = batch(count, needed - count)
            lin = merged(lin, more_lin)
            nl = merged(nl, more_nl) if nl is not None and more_nl is not None else None
            count = needed
    rows = case_rows(name, fd, facts.static_load, lin, nl, limits, settings)
    if nl is not None and any(r["verdict"] in (GAP, SMALL_GAP) for r in rows):
        active = active_nonlinearities(model, nl)
        if len(active) == 1:  # the only nonlinearity at work: no rerun needed to name it
            attribute(rows, {}, active[0])
        elif active:
            roads = road_pairs(case, t, settings, index, 0, count)
            without = {}
            for switch in active:
                runs = run_roads(case, model, facts, t, roads, replace(everything, **{switch: False}), settings)
                without[switch] = case_rows(name, fd, facts.static_load, lin, runs, limits, settings)
            attribute(rows, without)
    for row in rows:
        if row["verdict"] == OUTSIDE:
            notes.append(f"{name}: {row['figure']} is {row['nonlinear']:.3g} (limit {row['limit']:.3g}): outside the model's validity")
    traces = case_traces(name, model, frequency_domain_psd(case, model, lin.f_hz), facts, lin, nl, settings.settle_s)
    return CaseVerification(rows, traces, count, tuple(notes))


@dataclass(frozen=True)
class Verification:
    """One design verified in the time domain over every load case of its problem.

    Attributes
    ----------
    problem : str
        [-] the problem's name
    design : str
        [-] which design (``"front.csv row 12"``, ``"baseline"``)
    values : dict[str, float]
        [SI] its design variables
    settings : VerifySettings
        [-] the settings used
    cases : tuple[CaseVerification, ...]
        [-] each load case's rows, traces and realisations
    manoeuvres : pd.DataFrame
        [-] the manoeuvres' figures (:mod:`hisopt.simulation.manoeuvres`), one row per load
        case, manoeuvre and figure
    """

    problem: str
    design: str
    values: dict[str, float]
    settings: VerifySettings
    cases: tuple[CaseVerification, ...]
    manoeuvres: pd.DataFrame

    def frame(self) -> pd.DataFrame:
        """Every load case's rows (:data:`ROW_COLUMNS`), SI, each row's unit in ``unit``."""
        frame = pd.DataFrame([row for case in self.cases for row in case.rows], columns=list(ROW_COLUMNS))
        return frame

    @property
    def notes(self) -> tuple[str, ...]:
        """What the nonlinear runs say of the model's validity, plain sentences."""
        return tuple(note for case in self.cases for note in case.notes)

    @property
    def verdict(self) -> str:
        """``"agrees"`` when every compared figure agrees and every extreme is within its
        limit; otherwise what fails first: ``"outside validity"``, ``"beyond limit"``, ``"gap"``."""
        verdicts = set(self.frame()["verdict"])
        for bad in (OUTSIDE, BEYOND, GAP):
            if bad in verdicts or (bad == OUTSIDE and self.notes):
                return bad
        return AGREES


def load_cases(problem: Problem) -> list[tuple[str, Problem]]:
    """Each load case of ``problem`` as its single-case problem (the problem itself, named
    by its road, without ``[[scenarios]]``)."""
    if problem.spec.scenarios:
        return [(name, problem.scenario_space(name)) for name in problem.scenario_names]  # type: ignore[misc]
    return [("road", problem)]


def verify_design(problem: Problem, design: Any, label: str = "baseline", settings: VerifySettings | None = None, manoeuvres: bool = True) -> Verification:
    """Verify one design of ``problem`` in the time domain over every load case (module
    docstring); ``manoeuvres``: also the step steer, sine with dwell and bump of each case."""
    settings = settings or VerifySettings()
    check_settings(settings, problem.spec.band.f_min_hz)
    x = problem.design_matrix(design)
    if len(x) != 1:
        raise ConfigError(f"expected one design, got {len(x)}", key="design")
    cases = tuple(verify_case(case, x, name, i, settings) for i, (name, case) in enumerate(load_cases(problem)))
    frames = []
    if manoeuvres:
        from hisopt.simulation.manoeuvres import manoeuvre_table

        for name, case in load_cases(problem):
            frames.append(manoeuvre_table(case, x).assign(case=name))
    table = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
    values = dict(zip(problem.variable_names, map(float, x[0]), strict=True))
    return Verification(problem.name, label, values, settings, cases, table)


__all__ = [
    "ROW_COLUMNS",
    "CaseTraces",
    "CaseVerification",
    "Verification",
    "VerifySettings",
    "check_settings",
    "load_cases",
    "verify_case",
    "verify_design",
]
