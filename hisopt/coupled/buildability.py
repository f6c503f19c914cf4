"""Buildability: the rules that stop a real HIS from working, each a usage (docs/model.md §21).

Every rule compares a demand with a limit and reports a **usage**, at most 1 where the rule
holds, and a **margin** ``1 - usage``, the distance from the limit in units of the limit:

- a *ceiling* (a pressure rating, a share of the corner's load, an area ratio, a buckling
  load, a hose's velocity or Reynolds number, a wheel-hop frequency): ``usage = value / limit``;
- a *floor* (a lowest pressure, a wall thickness, a damping ratio): ``usage = 2 - value / limit``
  (linear and finite everywhere, so an optimiser sees how far a design is from its floor
  even where the linear estimate of a pressure goes below zero).

The pressures at a load case's static point come from the model's operating point (the charged
HIS's circuit pressures at the case's temperature and payload, or the paper's idealisation's
precharge plus the payload's rise); the road's swing of every chamber and accumulator
pressure and of every strut's stroke rate from the evaluator's integrals (:class:`RoadSwing`:
``sigmas`` standard deviations of it count); the quasi-static swing of steady cornering at
``cornering_g`` from the static stiffness that gives the roll gradient. A rule a design's
layout has no part for (no hose) has usage 0.

All in SI, absolute pressures unless a name says gauge.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from hisopt.constants import G_MPS2, P_ATM_PA
from hisopt.coupled.model import CoupledModel, gravity_stiffness
from hisopt.hydraulics import backend as bk
from hisopt.hydraulics import laws
from hisopt.hydraulics.coupling import HydraulicSystem
from hisopt.hydraulics.layout import Accumulator, Pipe
from hisopt.hydraulics.network import circuit_entry, resolve, total_compliance
from hisopt.vehicle import VehicleParams, stroke_matrix
from hisopt.vehicle.batch import VehicleBatch
from hisopt.vehicle.parameters import sprung_corner_loads


@dataclass(frozen=True)
class BuildLimits:
    """The rules' settings and limits, SI (``[build]`` of a problem file, docs/model.md §21.2
    for each default's source)."""

    sigmas: float = 3.0
    """[-] Standard deviations of the road's swing a pressure keeps from its limits: a
    Gaussian road stays within three 99.73 % of the time."""
    gravity_moment: bool = True
    """[-] Count the body's gravity moment in the cornering roll (``[handling] gravity_moment``)."""
    cornering_g: float = 0.8
    """[g] Steady lateral acceleration of the quasi-static swing: a passenger car's limit on
    dry asphalt (tyre friction about 0.8-0.9)."""
    air_release_pressure: float = P_ATM_PA
    """[Pa abs] Lowest pressure in a chamber: oil exposed to air is saturated with it at
    atmospheric pressure and releases it below (Henry's law)."""
    precharge_margin: float = 1.1
    """[-] An accumulator's lowest working pressure over its precharge, absolute: the makers'
    minimum, so the separator never seats (HST, HARDWARE.md)."""
    cylinder_pressure: float = 16e6
    """[Pa gauge] Rated pressure of the cylinders: ISO 6020/2's nominal 160 bar."""
    strut_load_share: float = 0.9
    """[-] Largest share of its corner's sprung load the fluid may carry at rest: the spring
    keeps a tenth in compression."""
    area_ratio_max: float = 2.0
    """[-] Largest bore-over-annulus area ratio: ISO 6020/2's ranges offer 1.25, 1.4 and 2."""
    annulus_wall: float = 3.5e-3
    """[m] Thinnest annulus wall ``(bore - rod) / 2``: ISO 6020/2's thinnest pair, a 25 mm
    bore with an 18 mm rod."""
    rod_length: float = 0.3
    """[m] The rod's free length between its pins, for Euler buckling."""
    rod_modulus: float = 210e9
    """[Pa] Young's modulus of the rod (steel)."""
    buckling_safety: float = 3.5
    """[-] Safety factor on Euler's buckling load (the cylinder makers' catalogues)."""
    hose_velocity: float = 6.0
    """[m/s] Largest peak flow velocity in a hose: the top of the pressure-line range of the
    hose makers' selection charts (7-20 ft/s)."""
    reynolds_laminar: float = 2300.0
    """[-] Largest Reynolds number the pipes' laminar (Hagen-Poiseuille) law holds at."""
    wheel_hop_hz: float = 30.0
    """[Hz] Highest wheel-hop frequency: above it the hydraulics lock the wheel to the body."""
    wheel_damping: float = 0.1
    """[-] Lowest damping ratio of a wheel-hop mode."""


Side = Literal["ceiling", "floor"]


@dataclass(frozen=True)
class Rule:
    """One rule: its quantity's name, what it checks, the unit of its value and limit, and
    whether the limit is a ceiling or a floor."""

    name: str
    label: str
    unit: str
    side: Side
    needs_road: bool = False


RULES: dict[str, Rule] = {
    r.name: r
    for r in (
        Rule("pressure_floor_usage", "lowest pressure (abs) over its floor", "Pa", "floor", True),
        Rule("pressure_ceiling_usage", "highest pressure (gauge) over its rating", "Pa", "ceiling", True),
        Rule("strut_load_usage", "static fluid force's share of the corner load", "-", "ceiling"),
        Rule("area_ratio_usage", "cylinder area ratio bore / annulus", "-", "ceiling"),
        Rule("annulus_wall_usage", "annulus wall (bore - rod) / 2", "m", "floor"),
        Rule("rod_buckling_usage", "peak rod force over Euler's load / safety", "N", "ceiling", True),
        Rule("hose_velocity_usage", "peak hose flow velocity", "m/s", "ceiling", True),
        Rule("hose_reynolds_usage", "peak hose Reynolds number (laminar law)", "-", "ceiling", True),
        Rule("wheel_hop_usage", "highest wheel-hop frequency", "Hz", "ceiling"),
        Rule("wheel_damping_usage", "lowest wheel-hop damping ratio", "-", "floor"),
    )
}
"""Every rule, in the order the design sheet lists them."""

STATIC_RULES = ("strut_load_usage", "area_ratio_usage", "annulus_wall_usage")
"""The rules that need no road and no modes: numpy and CasADi alike (:func:`static_rule_elements`)."""

BUILD_USAGE = "build_usage"
"""The largest usage of all the rules: at most 1 for a buildable design."""


@dataclass(frozen=True)
class RuleValue:
    """A rule's value and limit at its binding element, and its usage, each ``(n,)``."""

    value: np.ndarray
    limit: np.ndarray
    usage: np.ndarray

    @property
    def margin(self) -> np.ndarray:
        """[-] ``1 - usage``: the distance from the limit in units of the limit."""
        return 1.0 - self.usage


def usage(value: Any, limit: Any, side: Side) -> Any:
    """The usage of ``value`` against ``limit`` (module docstring)."""
    return value / limit if side == "ceiling" else 2.0 - value / limit


def binding(value: np.ndarray, limit: np.ndarray, side: Side) -> RuleValue:
    """The element (last axis) with the largest usage, per design: a NaN element is skipped
    unless all are NaN; no element at all gives usage 0 (nothing to check)."""
    value, limit = np.broadcast_arrays(np.asarray(value, dtype=float), np.asarray(limit, dtype=float))
    if value.shape[-1] == 0:
        zero = np.zeros(value.shape[:-1])
        return RuleValue(zero, np.full(value.shape[:-1], np.nan), zero)
    with np.errstate(divide="ignore", invalid="ignore"):
        u = usage(value, limit, side)
    u = np.where(np.isnan(value) | np.isnan(limit), np.nan, u)
    pick = np.nanargmax(np.where(np.isnan(u), -np.inf, u), axis=-1)[..., None]
    take = lambda a: np.take_along_axis(a, pick, axis=-1)[..., 0]  # noqa: E731
    return RuleValue(take(value), take(limit), take(u))


# --- the static point ------------------------------------------------------------------------
def circuit_pressures(his: HydraulicSystem) -> np.ndarray:
    """[Pa abs] :func:`circuit_pressure_list` of a numpy batch, ``B + (n_circuits,)``."""
    return np.stack([np.broadcast_to(np.asarray(p, dtype=float), his.batch_shape) for p in circuit_pressure_list(his)], axis=-1)


def port_values(his: HydraulicSystem, per_circuit: np.ndarray) -> np.ndarray:
    """A per-circuit value ``B + (n_circuits,)`` at each port ``B + (n_ports,)``."""
    return np.asarray(per_circuit)[..., his.network.port_circuit]


def cornering_swing(model: CoupledModel, lateral_g: float, gravity_moment: bool) -> np.ndarray:
    """[Pa] Each circuit's quasi-static pressure change in a steady turn at ``lateral_g``,
    ``B + (n_circuits,)`` (its magnitude counts: the car turns both ways). The roll moment
    ``m_s a_y h_0s`` on the static stiffness (the roll gradient's load, with the body's
    gravity moment when ``gravity_moment``: :func:`~hisopt.coupled.model.gravity_stiffness`) strokes the struts by
    ``delta = G X``; at rest each circuit is one compliance ``C_c`` filled through
    ``a_c = sum of its ports' rows of N``, so ``dp_c = a_c . delta / C_c``."""
    his = model.his
    assert his is not None
    v = model.vehicle
    moment = np.asarray(v.m_s, dtype=float) * lateral_g * G_MPS2 * np.asarray(v.h_0s, dtype=float)
    k = gravity_stiffness(model.stiffness(), v, gravity_moment)
    load = np.zeros(np.broadcast_shapes(np.shape(moment), k.shape[:-2]) + (7, 1))
    load[..., 1, 0] = moment
    x = np.linalg.solve(k, load)[..., 0]
    delta = np.einsum("...ij,...j->...i", stroke_matrix(v), x)
    n = np.asarray(his.incidence, dtype=float)
    out = []
    for c in range(his.network.n_circuits):
        a_c = n[..., his.network.port_circuit == c, :].sum(axis=-2)
        out.append(np.einsum("...w,...w->...", a_c, delta) / np.asarray(total_compliance(his.network, his.values, c), dtype=float))
    return np.abs(np.stack(np.broadcast_arrays(*out), axis=-1))


# --- the road --------------------------------------------------------------------------------
@dataclass(frozen=True)
class RoadSwing:
    """[Pa], [m^3], [m/s] RMS road swing of each port's (chamber's) pressure, each
    accumulator's oil volume and each strut's stroke rate, ``(n, n_ports)``, ``(n, n_acc)``
    and ``(n, 4)``, from the evaluator's integrals."""

    port_pressure: np.ndarray
    oil_volume: np.ndarray
    stroke_rate: np.ndarray


@dataclass(frozen=True)
class Extremes:
    """[Pa abs] The lowest and highest pressure each port and accumulator sees: static, minus
    or plus ``k`` standard deviations of the road and the cornering swing."""

    port_low: np.ndarray
    port_high: np.ndarray
    accumulator_low: np.ndarray
    accumulator_high: np.ndarray


def pressure_extremes(model: CoupledModel, limits: BuildLimits, swing: RoadSwing) -> Extremes:
    """The pressures' :class:`Extremes` of a batch of models on the road ``swing`` was
    measured on (module docstring)."""
    his = model.his
    assert his is not None
    static = circuit_pressures(his)
    corner = cornering_swing(model, limits.cornering_g, limits.gravity_moment)
    port_static, port_corner = port_values(his, static), port_values(his, corner)
    port_road = limits.sigmas * swing.port_pressure
    circuits = [c for _, (c, e) in enumerate(his.network.elements) if isinstance(e, Accumulator)]
    acc_road = limits.sigmas * swing.oil_volume / his.accumulator_compliances()
    acc_static, acc_corner = static[..., circuits], corner[..., circuits]
    return Extremes(
        port_static - port_road - port_corner,
        port_static + port_road + port_corner,
        acc_static - acc_road - acc_corner,
        acc_static + acc_road + acc_corner,
    )


def precharges_at_temperature(his: HydraulicSystem) -> np.ndarray:
    """[Pa abs] Each accumulator's precharge at the case's temperature, ``B + (n_acc,)``."""
    tau = his.params.get("gas_temperature_ratio", 1.0)
    out = [laws.gas_pressure_at_temperature(laws.absolute_pressure(resolve(e.precharge, his.params)), tau) for _, e, _ in his.network.accumulators()]
    if not out:
        return np.zeros(his.batch_shape + (0,))
    return np.stack(np.broadcast_arrays(*(np.broadcast_to(np.asarray(p, dtype=float), his.batch_shape) for p in out)), axis=-1)


AccumulatorRating = Callable[[HydraulicSystem], np.ndarray]
"""[Pa gauge] The highest working pressure each accumulator is rated for, ``B + (n_acc,)``."""


def pressure_rules(model: CoupledModel, limits: BuildLimits, swing: RoadSwing, rating: AccumulatorRating, ext: Extremes | None = None) -> dict[str, RuleValue]:
    """``pressure_floor_usage`` and ``pressure_ceiling_usage``: every chamber's and
    accumulator's lowest pressure against its floor (air release; an accumulator's also
    ``precharge_margin`` times its precharge at the temperature) and highest against its
    rating (the cylinders' ``cylinder_pressure``; an accumulator's from ``rating``)."""
    his = model.his
    assert his is not None
    ext = pressure_extremes(model, limits, swing) if ext is None else ext
    bounds = pressure_limits(his, limits, rating)
    low = np.concatenate([ext.port_low, ext.accumulator_low], axis=-1)
    floor = np.concatenate([np.broadcast_to(bounds.port_floor, ext.port_low.shape), bounds.accumulator_floor], axis=-1)
    high = np.concatenate([ext.port_high, ext.accumulator_high], axis=-1) - P_ATM_PA
    ceiling = np.concatenate([np.broadcast_to(bounds.port_ceiling, ext.port_high.shape), bounds.accumulator_ceiling], axis=-1)
    return {"pressure_floor_usage": binding(low, floor, "floor"), "pressure_ceiling_usage": binding(high, ceiling, "ceiling")}


@dataclass(frozen=True)
class PressureLimits:
    """What the pressure rules hold each chamber (port) and accumulator to: floors [Pa abs]
    and ceilings [Pa gauge], ``B + (n_ports,)`` (or one value for all) and ``B + (n_acc,)``."""

    port_floor: Any
    port_ceiling: Any
    accumulator_floor: np.ndarray
    accumulator_ceiling: np.ndarray


def pressure_limits(his: HydraulicSystem, limits: BuildLimits, rating: AccumulatorRating) -> PressureLimits:
    """The :class:`PressureLimits` of a batch: air release for every chamber and accumulator,
    an accumulator's also ``precharge_margin`` times its precharge at the temperature; the
    cylinders' ``cylinder_pressure`` and each accumulator's ``rating``."""
    precharge = precharges_at_temperature(his)
    acc_floor = np.maximum(limits.air_release_pressure, limits.precharge_margin * precharge)
    return PressureLimits(limits.air_release_pressure, limits.cylinder_pressure, acc_floor, rating(his))


# --- the cylinders and the struts' static balance (numpy batches and CasADi alike) -----------
def _entry(matrix: Any, i: int, j: int) -> Any:
    """Entry ``(i, j)`` of a numpy batch ``B + (m, n)`` or a CasADi matrix."""
    return matrix[i, j] if bk.is_casadi(matrix) else np.asarray(matrix)[..., i, j]


def _wheel(per_wheel: Any, w: int) -> Any:
    """Wheel ``w``'s entry of a numpy ``B + (4,)`` array or a list of four expressions."""
    return per_wheel[w] if isinstance(per_wheel, list) else np.asarray(per_wheel)[..., w]


def circuit_pressure_list(his: HydraulicSystem) -> list[Any]:
    """[Pa abs] Static pressure of each circuit at the operating point ``his`` is linearised
    at, one value per circuit (numpy ``B`` or CasADi): a charged HIS's, or an accumulator's
    (its precharge, at the temperature, plus a payload's rise); a circuit of oil alone sits at
    atmospheric pressure."""
    net = his.network
    if his.static_pressure is not None:
        return [circuit_entry(his.static_pressure, c) for c in range(net.n_circuits)]
    out: list[Any] = [P_ATM_PA] * net.n_circuits
    for k, (c, e) in reversed(list(enumerate(net.elements))):  # the circuit's first accumulator
        if isinstance(e, Accumulator):
            out[c] = his.values.gas[k][1]
    return out


def strut_shares(his: HydraulicSystem, vehicle: VehicleParams | VehicleBatch) -> list[Any]:
    """[-] The fluid's static force on each strut, extension positive, ``f = -N^T (p - p_atm)``
    (the atmosphere pushes on the rod's end: gauge pressures, docs/model.md §3.2), over its
    corner's sprung load (:func:`sprung_corner_loads`), per wheel."""
    pressure = circuit_pressure_list(his)
    loads = sprung_corner_loads(vehicle, G_MPS2)
    n = his.incidence
    out = []
    for w in range(4):
        force: Any = 0.0
        for port, c in enumerate(his.network.port_circuit):
            force = force - _entry(n, port, w) * (pressure[int(c)] - P_ATM_PA)
        out.append(force / loads[..., w])
    return out


def cylinder_sizes(his: HydraulicSystem) -> tuple[list[Any], list[Any], list[Any]]:
    """[m], [m], [-] Bore and rod diameters and the area ratio ``A_b / A_t`` of each wheel's
    cylinder (:func:`hisopt.hydraulics.laws.bore_and_rod`), one value per wheel."""
    top, bottom = his.areas
    bores, rods, ratios = [], [], []
    for w in range(4):
        a_t, a_b = _wheel(top, w), _wheel(bottom, w)
        bore, rod = laws.bore_and_rod(a_b - a_t, a_t / a_b)
        bores.append(bore)
        rods.append(rod)
        ratios.append(a_b / a_t)
    return bores, rods, ratios


def static_rule_elements(model: CoupledModel, limits: BuildLimits) -> dict[str, tuple[list[Any], Any]]:
    """The rules that need no road, per element (wheel), with their limit: ``strut_load_usage``,
    ``area_ratio_usage`` and ``annulus_wall_usage``, numpy batches and CasADi alike."""
    his = model.his
    assert his is not None
    bores, rods, ratios = cylinder_sizes(his)
    return {
        "strut_load_usage": (strut_shares(his, model.vehicle), limits.strut_load_share),
        "area_ratio_usage": (ratios, limits.area_ratio_max),
        "annulus_wall_usage": ([0.5 * (b - r) for b, r in zip(bores, rods, strict=True)], limits.annulus_wall),
    }


def symbolic_usage(name: str, elements: list[Any], limit: float) -> Any:
    """The usage of rule ``name`` as one expression: the largest of its elements' (CasADi)."""
    worst: Any = None
    for value in elements:
        u = usage(value, limit, RULES[name].side)
        worst = u if worst is None else bk.fmax(worst, u)
    return worst


def static_rules(model: CoupledModel, limits: BuildLimits) -> dict[str, RuleValue]:
    """:func:`static_rule_elements` of a numpy batch, each at its binding wheel."""
    n = model.his.batch_shape if model.his is not None else ()
    out = {}
    for name, (elements, limit) in static_rule_elements(model, limits).items():
        value = np.stack([np.broadcast_to(np.asarray(v, dtype=float), n) for v in elements], axis=-1)
        out[name] = binding(value, np.full(value.shape, limit), RULES[name].side)
    return out


def cylinder_geometry(his: HydraulicSystem) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """[m], [m], [-] :func:`cylinder_sizes` of a numpy batch, ``B + (4,)`` each."""
    return tuple(np.stack([np.broadcast_to(np.asarray(v, dtype=float), his.batch_shape) for v in part], axis=-1) for part in cylinder_sizes(his))  # type: ignore[return-value]


def euler_load(rod: Any, limits: BuildLimits) -> Any:
    """[N] Euler's buckling load of a rod pinned at both ends, ``pi^2 E I / L^2`` with
    ``I = pi d^4 / 64``."""
    return math.pi**2 * limits.rod_modulus * (math.pi * rod**4 / 64.0) / limits.rod_length**2


def buckling_rule(model: CoupledModel, limits: BuildLimits, swing: RoadSwing, ext: Extremes | None = None) -> RuleValue:
    """``rod_buckling_usage``: each rod's peak compressive force, its bottom chamber at its
    highest pressure and its top at its lowest (not below vacuum), against Euler's load over
    ``buckling_safety``."""
    his = model.his
    assert his is not None
    ext = pressure_extremes(model, limits, swing) if ext is None else ext
    n = np.asarray(his.incidence, dtype=float)
    pushing = np.where(n < 0, ext.port_high[..., :, None], np.maximum(ext.port_low, 0.0)[..., :, None])  # bottom (n < 0) high, top low
    force = -np.einsum("...pw,...pw->...w", n, pushing - P_ATM_PA)
    _, rod, _ = cylinder_geometry(his)
    return binding(np.maximum(force, 0.0), euler_load(rod, limits) / limits.buckling_safety, "ceiling")


# --- the hoses -------------------------------------------------------------------------------
def series_pipes(network: Any, port: int) -> list[int]:
    """The pipes in series with port ``port``: from its node along the branch elements (pipe,
    valve) while a node joins just two of them, so that each carries the port's flow (a
    chamber's hose, with or without its valve on either end); none past a junction."""
    branches = [k for k, rows in enumerate(network.element_rows) if len(rows) > 1]
    at_node: dict[int, list[int]] = {}
    for k in branches:
        for node in network.element_rows[k][:2]:
            at_node.setdefault(int(node), []).append(k)
    ports_at = {int(r) for r in network.port_rows}
    node, came = int(network.port_rows[port]), -1
    out: list[int] = []
    while True:
        onward = [k for k in at_node.get(node, []) if k != came]
        shunts = sum(1 for rows in network.element_rows if len(rows) == 1 and int(rows[0]) == node)
        if len(onward) != 1 or (came >= 0 and (shunts or node in ports_at)):
            return out
        came = onward[0]
        if isinstance(network.elements[came][1], Pipe):
            out.append(came)
        a, b_ = (int(n) for n in network.element_rows[came][:2])
        node = b_ if a == node else a


def hose_flows(his: HydraulicSystem, stroke_rate: np.ndarray) -> tuple[list[int], np.ndarray]:
    """The pipes in series with a port (a chamber's hose, :func:`series_pipes`) and the RMS
    flow [m^3/s] each carries, its chamber's area times its strut's RMS stroke rate,
    ``(n, n_hoses)``. A pipe past a junction is not checked (its flow is no one port's)."""
    net = his.network
    n = np.asarray(his.incidence, dtype=float)
    hoses, flows = [], []
    for port, where in enumerate(net.ports):
        for k in series_pipes(net, port):
            hoses.append(k)
            flows.append(np.abs(n[..., port, where.wheel]) * stroke_rate[..., where.wheel])
    return hoses, (np.stack(np.broadcast_arrays(*flows), axis=-1) if flows else np.zeros(stroke_rate.shape[:-1] + (0,)))


def hose_rules(his: HydraulicSystem, limits: BuildLimits, swing: RoadSwing) -> dict[str, RuleValue]:
    """``hose_velocity_usage`` (``k`` RMS flows over the bore's area, against
    ``hose_velocity``) and ``hose_reynolds_usage`` (``rho v d / mu`` at that velocity, in the
    oil of the case, against ``reynolds_laminar``)."""
    hoses, flows = hose_flows(his, swing.stroke_rate)
    params = his.params
    pipes = [his.network.elements[k][1] for k in hoses]
    d = np.zeros(flows.shape)  # [m] each hose's bore, per design
    for j, pipe in enumerate(pipes):
        assert isinstance(pipe, Pipe)
        d[..., j] = resolve(pipe.diameter, params)
    with np.errstate(divide="ignore", invalid="ignore"):  # no hose: empty arrays
        velocity = limits.sigmas * flows / laws.pipe_area(d)
    rho, mu = (np.asarray(resolve(name, params), dtype=float)[..., None] for name in ("rho", "mu"))
    reynolds = rho * velocity * d / mu
    return {
        "hose_velocity_usage": binding(velocity, np.full(velocity.shape, limits.hose_velocity), "ceiling"),
        "hose_reynolds_usage": binding(reynolds, np.full(reynolds.shape, limits.reynolds_laminar), "ceiling"),
    }


# --- the accumulators' rating ----------------------------------------------------------------
def accumulator_ceilings(his: HydraulicSystem, ratio: Any, max_working: Any) -> np.ndarray:
    """[Pa gauge] The highest working pressure of each accumulator, ``B + (n_acc,)``: its
    rated ratio ``ratio`` times its precharge at the temperature, gauge (a zero precharge is
    rated for nothing), and at most ``max_working``; ``ratio`` and ``max_working`` per
    accumulator ``B + (n_acc,)`` or one for all."""
    precharge = precharges_at_temperature(his) - P_ATM_PA
    return np.minimum(np.asarray(ratio, dtype=float) * np.maximum(precharge, 0.0), np.asarray(max_working, dtype=float))


# --- all of them -----------------------------------------------------------------------------
def build_rules(
    model: CoupledModel,
    limits: BuildLimits,
    swing: RoadSwing | None,
    rating: AccumulatorRating,
    wheel_modes: Callable[[CoupledModel], tuple[np.ndarray, np.ndarray]],
    names: tuple[str, ...] = tuple(RULES),
) -> dict[str, RuleValue]:
    """The rules ``names`` of a batch of models with HIS (``swing``: the road's, needed by the
    rules that say so; ``wheel_modes``: each wheel's hop frequency [Hz] and damping ratio,
    ``(n, 4)`` each)."""
    his = model.his
    assert his is not None
    out: dict[str, RuleValue] = {}
    wanted = set(names)
    if wanted & {"pressure_floor_usage", "pressure_ceiling_usage", "rod_buckling_usage", "hose_velocity_usage", "hose_reynolds_usage"} and swing is None:
        raise ValueError("the pressure, buckling and hose rules need the road's swing")
    ext = (
        pressure_extremes(model, limits, swing)
        if swing is not None and wanted & {"pressure_floor_usage", "pressure_ceiling_usage", "rod_buckling_usage"}
        else None
    )
    if wanted & {"pressure_floor_usage", "pressure_ceiling_usage"}:
        out |= pressure_rules(model, limits, swing, rating, ext)  # type: ignore[arg-type]
    if wanted & {"strut_load_usage", "area_ratio_usage", "annulus_wall_usage"}:
        out |= static_rules(model, limits)
    if "rod_buckling_usage" in wanted:
        out["rod_buckling_usage"] = buckling_rule(model, limits, swing, ext)  # type: ignore[arg-type]
    if wanted & {"hose_velocity_usage", "hose_reynolds_usage"}:
        out |= hose_rules(his, limits, swing)  # type: ignore[arg-type]
    if wanted & {"wheel_hop_usage", "wheel_damping_usage"}:
        frequency, damping = wheel_modes(model)
        out["wheel_hop_usage"] = binding(frequency, np.full(frequency.shape, limits.wheel_hop_hz), "ceiling")
        out["wheel_damping_usage"] = binding(damping, np.full(damping.shape, limits.wheel_damping), "floor")
    return {name: out[name] for name in names}


def overall_usage(rules: dict[str, RuleValue]) -> np.ndarray:
    """The largest usage over ``rules`` per design (NaN where any is NaN: not evaluated)."""
    usages = np.stack([r.usage for r in rules.values()], axis=-1)
    return np.max(usages, axis=-1)
