"""The static operating point of a charged HIS at any temperature and payload (docs/model.md §16).

Reference state: the unladen car at its design position (``X = 0``) at the charge
temperature ``T_c``, each circuit charged to ``p_c = max_k p0_abs,k / phi``
(:func:`hisopt.hydraulics.laws.charge_pressure`, ``phi`` the gas fraction at charge), so
accumulator ``k`` holds gas ``V_c,k = p0_abs,k V0_k / p_c`` and the circuit oil
``V_oil = V_lines + sum_k (V0_k - V_c,k)`` (chambers, pipes and ``[his.charge] oil_volume``:
``V_lines``).

At temperature ``T`` (``tau = T / T_c``) under a payload the circuits sit at ``p_c + dp``
with the car at ``X``. The oil mass is fixed: its volume is ``V_oil e (1 - dp / beta)`` with
``e`` the oil's volume ratio (thermal expansion, :func:`hisopt.hydraulics.fluid.thermal_ratios`);
the gas mass is fixed and at the oil's temperature: ``V_k = tau p0_abs,k V0_k / (p_c + dp)``
(:func:`hisopt.hydraulics.laws.isothermal_gas_volume`). Gas plus oil fill the circuit, whose
volume the struts change by ``-(A G X)_c``, so the oil stored relative to the reference state is

    g_c(dp) = sum_k (V_c,k - V_k(dp)) + V_oil (1 - e (1 - dp / beta)) = (A G X)_c

which with the car's force balance is the system of :func:`hisopt.coupled.payload.solve_static_balance`:
one Newton solve, written once with the backend helpers, for numpy batches and CasADi alike.
``g_c(0) != 0`` away from ``T_c``: the gas's pressure and the oil's volume change.

With ``phi -> 1``, ``T = T_c`` and ``gamma = 1`` this is the paper's idealisation and the
payload model of §13 (the accumulator holds no oil at charge).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from hisopt.constants import P_ATM_PA
from hisopt.coupled.payload import NEWTON_STEPS, Payload, solve_static_balance, static_deflection
from hisopt.hydraulics import backend as bk
from hisopt.hydraulics import laws
from hisopt.hydraulics.coupling import HydraulicSystem
from hisopt.hydraulics.layout import Accumulator, ChamberCompliance, Pipe
from hisopt.hydraulics.network import resolve
from hisopt.vehicle import VehicleParams

CircuitCharge = tuple[Any, Any, list[Any]]
"""Per circuit: charge pressure ``p_c`` [Pa abs], oil volume at charge ``V_oil`` [m^3], and each
accumulator's gas ``p0_abs V0`` [Pa m^3] at the charge temperature."""


def circuit_charges(his: HydraulicSystem) -> list[CircuitCharge]:
    """The reference state of every circuit (module docstring): charge pressure, oil volume
    and gas contents, from ``his.params``' ``gas_fraction`` and the layout's elements."""
    net, params = his.network, his.params
    beta = resolve("beta", params)
    lines: list[Any] = [params.get("charge_oil_volume", 0.0)] * net.n_circuits  # oil no element models
    gas: list[list[tuple[Any, Any]]] = [[] for _ in range(net.n_circuits)]
    values = his.values
    for k, (c, e) in enumerate(net.elements):
        if isinstance(e, Accumulator):
            p0_abs = laws.absolute_pressure(resolve(e.precharge, params))
            gas[c].append((resolve(e.volume, params), p0_abs))
        elif isinstance(e, ChamberCompliance):
            lines[c] = lines[c] + values.shunt[k] * beta
        elif isinstance(e, Pipe):
            lines[c] = lines[c] + values.line[k][2] * values.line[k][3] * beta
    out: list[CircuitCharge] = []
    for c in range(net.n_circuits):
        if not gas[c]:  # a circuit of oil alone, filled at atmospheric pressure
            out.append((P_ATM_PA, lines[c], []))
            continue
        highest = gas[c][0][1]
        for _, p0_abs in gas[c][1:]:
            highest = bk.fmax(highest, p0_abs)
        p_c = laws.charge_pressure(highest, params["gas_fraction"])
        contents = [v0 * p0_abs for v0, p0_abs in gas[c]]
        oil = lines[c]
        for (v0, _), content in zip(gas[c], contents, strict=True):
            oil = oil + v0 - laws.isothermal_gas_volume(p_c, content)
        out.append((p_c, oil, contents))
    return out


def charged_stored_oil(charges: list[CircuitCharge], tau: Any, e: Any, beta: Any, dp: list[Any], like: Any) -> tuple[Any, Any]:
    """[m^3], [m^3/Pa] ``g(dp)`` and its diagonal Jacobian (module docstring) as a column and a
    matrix (CasADi when ``like`` is): a :data:`hisopt.coupled.payload.StoredOil`."""
    n = len(charges)
    stored, tangent = [], []
    for c, ((p_c, oil, contents), p) in enumerate(zip(charges, dp, strict=True)):
        v = oil * (1.0 - e * (1.0 - p / beta))
        dv = oil * e / beta
        for content in contents:
            v = v + laws.isothermal_gas_volume(p_c, content) - laws.isothermal_gas_volume(p_c + p, tau * content)
            dv = dv + tau * content / (p_c + p) ** 2
        stored.append((c, 0, v))
        tangent.append((c, c, dv))
    return bk.assemble((n, 1), stored, like=like), bk.assemble((n, n), tangent, like=like)


def charged_static_pressure(vehicle: VehicleParams, payload: Payload | None, his: HydraulicSystem, steps: int = NEWTON_STEPS) -> Any:
    """[Pa] Absolute static pressure of each circuit of a charged HIS at the temperature and
    payload of ``his.params`` and ``payload`` (module docstring).

    Parameters
    ----------
    vehicle : VehicleParams
        the unladen car (``X`` about its CG)
    payload : Payload | None
        the payload (None: unladen)
    his : HydraulicSystem
        [-] the HIS with ``gas_fraction``, ``gas_temperature_ratio`` and ``oil_volume_ratio``
        among its parameters (:func:`hisopt.hydraulics.roll_plane.parameter_values`)

    Returns
    -------
    numpy.ndarray or CasADi column
        [Pa] numpy ``B + (n_circuits,)``, NaN for a design whose solve fails or whose
        accumulator holds no oil there (:func:`accumulator_state`), or a CasADi column.
    """
    params = his.params
    charges = circuit_charges(his)
    tau, e, beta = params.get("gas_temperature_ratio", 1.0), params.get("oil_volume_ratio", 1.0), resolve("beta", params)
    dp = solve_static_balance(vehicle, payload or Payload(), his, lambda p, like: charged_stored_oil(charges, tau, e, beta, p, like), steps)
    if bk.is_casadi(dp):
        return bk.assemble((len(charges), 1), [(c, 0, charges[c][0] + dp[c]) for c in range(len(charges))], like=dp)
    pressure = np.stack([np.broadcast_to(charges[c][0], np.shape(dp)[:-1]) for c in range(len(charges))], axis=-1) + dp
    fraction = accumulator_state(his, pressure)
    empty = np.zeros(np.shape(pressure)[:-1], dtype=bool)
    for f in fraction.values():
        empty |= ~(f < 1.0)
    return np.where(empty[..., None] | ~(pressure > 0.0), np.nan, pressure)


def accumulator_state(his: HydraulicSystem, static_pressure: np.ndarray) -> dict[int, np.ndarray]:
    """[-] Static gas volume over accumulator volume of every accumulator (by element index)
    at the circuits' absolute ``static_pressure`` [Pa], numpy ``B + (n_circuits,)``: at 1 or
    above the accumulator holds no oil (its gas would need more than its volume: the
    separator rests on its seat), and the small-signal model there is not the system's."""
    net, params = his.network, his.params
    tau = params.get("gas_temperature_ratio", 1.0)
    out = {}
    for k, (c, e) in enumerate(net.elements):
        if isinstance(e, Accumulator):
            p0_abs = laws.absolute_pressure(resolve(e.precharge, params))
            v0 = resolve(e.volume, params)
            out[k] = laws.isothermal_gas_volume(static_pressure[..., c], tau * p0_abs * v0) / v0
    return out


def static_displacement(vehicle: VehicleParams, payload: Payload | None, his: HydraulicSystem) -> np.ndarray:
    """[m, rad] The car's static displacement ``X`` from its design position (about the
    unladen CG), numpy ``B + (7,)``: ``K^-1 (Q - G^T A^T dp)`` with ``dp`` the circuits' rise
    above the reference state (a charged HIS's above its charge pressure, the ideal model's
    payload rise; :func:`hisopt.coupled.payload.static_deflection`)."""
    if his.static_pressure is not None:
        charges = np.stack([np.broadcast_to(c[0], his.batch_shape) for c in circuit_charges(his)], axis=-1)
        dp = np.asarray(his.static_pressure) - charges
    elif his.static_rise is not None:
        dp = np.asarray(his.static_rise)
    else:
        dp = np.zeros(his.batch_shape + (his.network.n_circuits,))
    return static_deflection(vehicle, payload or Payload(), his, dp)


def accumulator_quantities(his: HydraulicSystem) -> dict[str, Any]:
    """[-] The accumulators at the static operating point ``his`` is linearised at, for numpy
    batches and CasADi alike (docs/model.md §16.8):

    - ``static_gas_fraction``: the largest gas share ``V / V0`` of any accumulator (1: it
      holds no oil, as the paper's idealisation always has it; a charged accumulator near 1
      runs dry as soon as the oil contracts or the struts extend);
    - ``static_pressure_ratio``: the largest ``p / p0`` of any accumulator, in gauge, ``p0``
      the gas's precharge at the temperature (:func:`hisopt.hydraulics.laws.gauge_pressure_ratio`:
      ``+inf`` for a precharge at or below atmospheric pressure there); an accumulator is rated
      for a largest ratio: about 4 for a bladder, 8 for a diaphragm, stated in gauge;
    - ``pressure_rating_usage``: ``static_pressure_ratio`` over the accumulators' rating
      ``pressure_rating`` (above 1 the design asks more than the part is rated for).
    """
    params, net = his.params, his.network
    tau = params.get("gas_temperature_ratio", 1.0)
    fraction: Any = None
    ratio: Any = None
    for k, (_, e) in enumerate(net.elements):
        if not isinstance(e, Accumulator):
            continue
        v, p_abs, _ = his.values.gas[k]
        precharge = laws.gas_pressure_at_temperature(laws.absolute_pressure(resolve(e.precharge, params)), tau)
        f, r = v / resolve(e.volume, params), laws.gauge_pressure_ratio(p_abs, precharge)
        fraction = f if fraction is None else bk.fmax(fraction, f)
        ratio = r if ratio is None else bk.fmax(ratio, r)
    if fraction is None:  # a layout without accumulators: nothing to run dry
        fraction = ratio = np.full(his.batch_shape, np.nan)
    if not bk.is_casadi(fraction) and not bk.is_casadi(ratio):  # one value per design, though V0 and p0 be fixed
        fraction, ratio = (np.broadcast_to(np.asarray(v, dtype=float), his.batch_shape) for v in (fraction, ratio))
    rating = params.get("pressure_rating", math.nan)
    return {"static_gas_fraction": fraction, "static_pressure_ratio": ratio, "pressure_rating_usage": ratio / rating}


def accumulator_rooms(his: HydraulicSystem) -> list[np.ndarray]:
    """[m^3] Each accumulator's static room, in element order, numpy ``B``: the lesser of its
    static oil volume (what an outflow can draw before it runs dry) and its static gas volume
    (what an inflow can fill before the separator bottoms), at the operating point ``his`` is
    linearised at; 0 for an accumulator without oil (the paper's idealisation,
    docs/model.md §16.9)."""
    out = []
    for k, e, _ in his.network.accumulators():
        gas = np.asarray(his.values.gas[k][0], dtype=float)
        volume = np.asarray(resolve(e.volume, his.params), dtype=float)
        out.append(np.broadcast_to(np.minimum(gas, volume - gas), his.batch_shape))
    return out
