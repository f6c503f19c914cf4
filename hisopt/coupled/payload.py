"""A payload: the laden car and the laden operating point of the HIS (docs/model.md §13).

A payload of mass ``m_p`` at ``(x, y, z)`` from the unladen CG changes two things:

1. **the car** (:func:`laden_vehicle`): sprung mass ``m_s + m_p``, the CG moved by
   ``m_p (x, y, z) / (m_s + m_p)`` (so ``l_f``, ``l_r``, ``h_0s`` and the lateral offset
   ``y_cg`` change), roll and pitch inertia about the new CG by the parallel-axis theorem;
2. **the static pressure of each circuit** (:func:`static_pressure_rise`): the payload's
   weight is shared by the springs, the tyres and the HIS; the circuits' pressures rise by
   ``dp`` (one value per circuit: at rest no oil flows through a valve or pipe), found from
   the car's linear stiffness and each circuit's nonlinear gas law, and each accumulator is
   then linearised at its laden point (:func:`hisopt.hydraulics.network.element_values`).

Every function but :func:`static_deflection` is written once with
:mod:`hisopt.hydraulics.backend`, so numpy batches of designs and the CasADi refinement's
symbols evaluate the same expressions.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from hisopt.constants import G_MPS2
from hisopt.hydraulics import backend as bk
from hisopt.hydraulics import laws
from hisopt.hydraulics.coupling import HydraulicSystem
from hisopt.hydraulics.layout import Accumulator, ChamberCompliance, Pipe
from hisopt.plausibility import payload_problem
from hisopt.quantities import si
from hisopt.vehicle import VehicleParams, stiffness_matrix, stroke_matrix

NEWTON_STEPS = 8
"""[-] Newton steps of the static solve, always all of them (the same expression graph for
every design and for CasADi). From the linearised solution the gas laws' curvature leaves an
error that the steps square: 8 reach rounding for circuit pressures up to many times the
precharge (docs/model.md §13.3)."""

NEWTON_TOLERANCE = 1e-9
"""[-] Largest residual of the static oil balance, relative to the oil the struts push into
a circuit, accepted after :data:`NEWTON_STEPS` (numpy); a design beyond it gets NaN."""


class Payload(BaseModel):
    """A rigid payload on the sprung body (problem-file table ``[payload]``).

    Positions are from the unladen CG along the vehicle axes (x forward, y left, z up).
    A payload of 0 kg is no payload: the car and its HIS are exactly the unladen ones.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    mass: float = Field(0.0, ge=0, description="payload mass", json_schema_extra=si("kg"))
    x: float = Field(0.0, description="position forward of the unladen CG", json_schema_extra=si("m"))
    y: float = Field(0.0, description="position to the left of the unladen CG", json_schema_extra=si("m"))
    z: float = Field(0.0, description="position above the unladen CG", json_schema_extra=si("m"))
    I_x: float = Field(0.0, ge=0, description="roll inertia of the payload about its own centre", json_schema_extra=si("kg m^2"))
    I_y: float = Field(0.0, ge=0, description="pitch inertia of the payload about its own centre", json_schema_extra=si("kg m^2"))

    @property
    def active(self) -> bool:
        """True for a payload with mass (0 kg changes nothing)."""
        return self.mass > 0.0


# --- the laden car ---------------------------------------------------------------------------
def cg_shift(vehicle: VehicleParams, payload: Payload) -> tuple[float, float, float]:
    """[m] Move of the CG ``m_p (x, y, z) / (m_s + m_p)`` along x, y, z."""
    share = payload.mass / (vehicle.m_s + payload.mass)
    return share * payload.x, share * payload.y, share * payload.z


def laden_problem(vehicle: VehicleParams, payload: Payload) -> str | None:
    """Why the car cannot carry ``payload`` (it lies outside the body or under the road, its
    weight would sag the body onto the road: :func:`hisopt.plausibility.payload_problem`; the
    CG would leave the wheelbase or the track, or sink below the roll axis), as
    ``"<key>: <reason>"``, or None."""
    if not payload.active:
        return None
    impossible = payload_problem(vehicle, payload)
    if impossible:
        return impossible
    cx, cy, cz = cg_shift(vehicle, payload)
    if not -vehicle.l_r < cx < vehicle.l_f:
        return (
            f"payload.x: moves the CG {cx:+.4g} m forward, outside the wheelbase; expected the laden CG "
            f"between the axles ({-vehicle.l_r:g} m < m_p x / (m_s + m_p) < {vehicle.l_f:g} m)"
        )
    half = min(vehicle.t_f, vehicle.t_r)
    if not abs(vehicle.y_cg + cy) < half:
        return f"payload.y: moves the CG {cy:+.4g} m to the left, outside the track; expected |y_cg + m_p y / (m_s + m_p)| < {half:g} m"
    if vehicle.h_0s + cz < 0:
        return f"payload.z: moves the CG {cz:+.4g} m up, below the roll axis; expected h_0s + m_p z / (m_s + m_p) >= 0"
    return None


def laden_vehicle(vehicle: VehicleParams, payload: Payload) -> VehicleParams:
    """The car with ``payload`` on its body (pure; 0 kg returns ``vehicle`` itself).

    Sprung mass ``m_s + m_p``; the CG moves by ``c = m_p r / (m_s + m_p)`` (``r`` the
    payload's position), so ``l_f - c_x``, ``l_r + c_x``, ``h_0s + c_z``, ``y_cg + c_y``.
    About the new CG, the parallel-axis theorem for body and payload gives
    ``I_x + I_px + mu (y^2 + z^2)`` and ``I_y + I_py + mu (x^2 + z^2)`` with the reduced mass
    ``mu = m_s m_p / (m_s + m_p)`` (``m_s c^2 + m_p (r - c)^2 = mu r^2``). The product of
    inertia ``mu x y`` of a payload off both axes is left out: the model's mass matrix is
    diagonal (docs/model.md §13.1).

    Raises
    ------
    ValueError
        The laden CG leaves the wheelbase or the track (:func:`laden_problem`).
    """
    if not payload.active:
        return vehicle
    problem = laden_problem(vehicle, payload)
    if problem:
        raise ValueError(problem)
    cx, cy, cz = cg_shift(vehicle, payload)
    m = vehicle.m_s + payload.mass
    mu = vehicle.m_s * payload.mass / m
    x, y, z = payload.x, payload.y, payload.z
    update = {
        "m_s": m,
        "I_x": vehicle.I_x + payload.I_x + mu * (y * y + z * z),
        "I_y": vehicle.I_y + payload.I_y + mu * (x * x + z * z),
        "l_f": vehicle.l_f - cx,
        "l_r": vehicle.l_r + cx,
        "h_0s": vehicle.h_0s + cz,
        "h_cg": vehicle.h_cg + cz,  # the body's extent moves with it; only the plausibility checks read it
        "y_cg": vehicle.y_cg + cy,
    }
    return VehicleParams(**(vehicle.model_dump() | update))


def payload_force(payload: Payload, g: float = G_MPS2) -> np.ndarray:
    """[N, N m, N m] The payload's weight as a generalised force on ``X`` about the unladen
    CG, shape (7,).

    A vertical force ``F_z`` at ``(x, y)`` does the work ``F_z (z_s + y phi - x theta)``
    (body_to_corners' kinematics: positive roll lifts the left, positive pitch lowers the
    front), so the weight ``W = m_p g`` downwards gives ``Q = -W [1, y, -x, 0, 0, 0, 0]``.
    """
    w = payload.mass * g
    return -w * np.array([1.0, payload.y, -payload.x, 0.0, 0.0, 0.0, 0.0])


# --- the laden operating point of the HIS ------------------------------------------------------
def circuit_areas(his: HydraulicSystem) -> Any:
    """``A`` [m^2]: the oil each circuit takes in per unit stroke of each wheel (the sum of its
    ports' signed chamber areas), numpy ``B + (n_circuits, 4)`` or a CasADi matrix."""
    net = his.network
    ports_of = np.zeros((len(net.ports), net.n_circuits))
    ports_of[np.arange(len(net.ports)), net.port_circuit] = 1.0
    return bk.matmul(ports_of.T, his.incidence)


def _storage(his: HydraulicSystem) -> list[tuple[Any, list[tuple[Any, Any, Any]]]]:
    """Per circuit: its oil compliance [m^3/Pa] (chambers, pipe volumes) and the
    ``(V0, p_abs0, gamma)`` of each accumulator at its unladen operating point."""
    net, values = his.network, his.values
    out: list[tuple[Any, list[tuple[Any, Any, Any]]]] = [(0.0, []) for _ in range(net.n_circuits)]
    for k, (c, e) in enumerate(net.elements):
        oil, gas = out[c]
        if isinstance(e, Accumulator):
            gas.append(values.gas[k])
        elif isinstance(e, ChamberCompliance):
            out[c] = (oil + values.shunt[k], gas)
        elif isinstance(e, Pipe):
            out[c] = (oil + values.line[k][2] * values.line[k][3], gas)
    return out


def _stored_oil(storage: list[tuple[Any, list[tuple[Any, Any, Any]]]], dp: list[Any], like: Any) -> tuple[Any, Any]:
    """[m^3], [m^3/Pa] Oil stored in each circuit at the rises ``dp`` (one value per circuit)
    and its tangent ``d(stored)/d(dp)``: ``g(dp)`` as a column, its diagonal Jacobian as a
    matrix (CasADi when ``like`` is)."""
    n = len(storage)
    stored, tangent = [], []
    for c, ((oil, gas), p) in enumerate(zip(storage, dp, strict=True)):
        v, dv = oil * p, oil
        for v0, p_abs0, gamma in gas:
            v = v + laws.gas_volume(p, v0, p_abs0, gamma)
            dv = dv + laws.gas_compliance(p, v0, p_abs0, gamma)
        stored.append((c, 0, v))
        tangent.append((c, c, dv))
    return bk.assemble((n, 1), stored, like=like), bk.assemble((n, n), tangent, like=like)


def _per_circuit(dp: Any, n: int) -> list[Any]:
    """The entries of a column ``dp`` (numpy ``B + (n, 1)`` or CasADi)."""
    return [dp[c] if bk.is_casadi(dp) else dp[..., c, 0] for c in range(n)]


def static_pressure_rise(vehicle: VehicleParams, payload: Payload, his: HydraulicSystem, steps: int = NEWTON_STEPS) -> Any:
    """[Pa] The static pressure rise ``dp`` of each circuit under ``payload``.

    Static equilibrium of the linear car (springs and tyres, ``K``) with the fluid's force
    ``-G^T A^T dp`` (:func:`circuit_areas`; docs/model.md §3.2) and the payload's weight
    ``Q`` (:func:`payload_force`), and each circuit's oil balance (stored oil = oil the struts
    push in):

        K X + G^T A^T dp = Q,        g_c(dp_c) = (A G X)_c

    where ``g_c`` sums the polytropic law :func:`hisopt.hydraulics.laws.gas_volume` of each of
    the circuit's accumulators about its unladen point and the oil compliance of its chambers
    and pipes times ``dp_c`` (a circuit without accumulator: oil only). Eliminating ``X``:

        g(dp) + S dp = b,    S = A G K^-1 G^T A^T,    b = A G K^-1 Q

    solved by ``steps`` Newton steps from the linearised solution ``(g'(0) + S) dp = b``.

    Parameters
    ----------
    vehicle : VehicleParams
        the unladen car (``X`` about its CG)
    payload : Payload
        the payload
    his : HydraulicSystem
        [-] the HIS at its unladen operating point (numpy batch ``B`` or CasADi symbols)

    Returns
    -------
    numpy.ndarray or CasADi column
        [Pa] numpy ``B + (n_circuits,)`` (NaN for a design whose solve did not converge, see
        :data:`NEWTON_TOLERANCE`) or a CasADi column ``(n_circuits, 1)``.
    """
    storage = _storage(his)
    return solve_static_balance(vehicle, payload, his, lambda dp, like: _stored_oil(storage, dp, like), steps)


StoredOil = Callable[[list[Any], Any], tuple[Any, Any]]
"""``(dp, like) -> (g, g')``: the oil stored in each circuit at the rises ``dp`` (one value
per circuit) relative to the reference state, as a column, and its diagonal Jacobian as a
matrix (CasADi when ``like`` is)."""


def solve_static_balance(vehicle: VehicleParams, payload: Payload, his: HydraulicSystem, stored_oil: StoredOil, steps: int = NEWTON_STEPS) -> Any:
    """[Pa] The rises ``dp`` that solve ``g(dp) + S dp = b`` (:func:`static_pressure_rise`) for
    any oil balance ``g`` (``stored_oil``; :mod:`hisopt.coupled.operating_point` adds the
    charged circuit's), by ``steps`` Newton steps from the linearised solution
    ``(g'(0) + S) dp = b - g(0)``; numpy ``B + (n_circuits,)`` (NaN for a design whose
    residual exceeds :data:`NEWTON_TOLERANCE` of the largest right-hand side) or a CasADi
    column."""
    k = stiffness_matrix(vehicle)
    g = stroke_matrix(vehicle)
    flexibility = g @ np.linalg.solve(k, g.T)  # G K^-1 G^T, strokes per stroke force
    stroke = g @ np.linalg.solve(k, payload_force(payload))  # G K^-1 Q, strokes without HIS
    a = circuit_areas(his)
    s_mat = bk.matmul(bk.matmul(a, flexibility), bk.transpose(a))
    b = bk.matmul(a, stroke[:, None])
    n = his.network.n_circuits
    like = s_mat if bk.is_casadi(s_mat) else 0.0
    stored0, tangent0 = stored_oil([0.0] * n, like)
    rhs = b - stored0
    dp = bk.solve(tangent0 + s_mat, rhs)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        for _ in range(steps):
            stored, tangent = stored_oil(_per_circuit(dp, n), like)
            dp = dp - bk.solve(tangent + s_mat, stored + bk.matmul(s_mat, dp) - b)
        if bk.is_casadi(dp):
            return dp
        stored, _ = stored_oil(_per_circuit(dp, n), like)
        residual = np.abs(stored + s_mat @ dp - b)[..., 0]
        scale = np.max(np.abs(rhs[..., 0]), axis=-1, keepdims=True)
        ok = np.all(residual <= NEWTON_TOLERANCE * scale, axis=-1, keepdims=True)
    return np.where(ok, dp[..., 0], np.nan)


def static_deflection(vehicle: VehicleParams, payload: Payload, his: HydraulicSystem | None, dp: Any = None) -> np.ndarray:
    """[m, rad] The static displacement ``X`` of the car under ``payload`` about the unladen
    equilibrium and CG: ``K^-1 (Q - G^T A^T dp)``, numpy ``B + (7,)``.

    Parameters
    ----------
    his : HydraulicSystem | None
        the unladen HIS, or None for the car without HIS
    dp : Any, optional
        [Pa] :func:`static_pressure_rise` (computed when None)
    """
    k = stiffness_matrix(vehicle)
    q = payload_force(payload)
    if his is None:
        return np.linalg.solve(k, q)
    if dp is None:
        dp = static_pressure_rise(vehicle, payload, his)
    a = np.asarray(circuit_areas(his))
    force = q - (stroke_matrix(vehicle).T @ np.swapaxes(a, -1, -2) @ np.asarray(dp)[..., None])[..., 0]
    return np.linalg.solve(k, force[..., None])[..., 0]
