"""Time-domain simulation of the lumped car + HIS model (paper Section VI; DESIGN sections 1-2).

Two fidelity levels share one road input (any ``(n_t, 4)`` wheel profile, interpolated in
time, see :class:`RoadInput`) and one result object, :class:`TimeResponse`:

- ``"linear"``: the exact lumped state space ``dx/dt = A x + B0 u + B1 du/dt`` of
  :meth:`hisopt.model.CoupledModel.state_space`, integrated as
  ``d(x - B1 u)/dt = A (x - B1 u) + (B0 + A B1) u`` so a road step needs no impulse.
- ``"nonlinear"``: the same network built from the hydraulic descriptor, with

  * every node carrying an accumulator integrating its *stored oil volume* ``W`` (the flow
    balance of the node) and its pressure given by the adiabatic gas law in absolute
    pressure, ``p_abs = p_abs0 (V0 / (V0 - dV))^gamma`` (``dV`` the gas volume taken by oil,
    plus any linear compliance ``C_o p`` at the node: oil, pipe ends);
  * optional quadratic orifice valves ``dp = R_v q + K_q q |q|`` (``K_q`` [Pa s^2 m^-6]; a
    sharp-edged orifice of area ``A_o`` and discharge coefficient ``C_d`` has
    ``K_q = rho / (2 C_d^2 A_o^2)``), the algebraic valve network being solved by Newton's
    method at each right-hand-side evaluation;
  * optional tyre lift-off: the tyre pushes but never pulls (contact force
    ``F_static - k_t (z_u - z_g) - c_t (dz_u - dz_g) >= 0``).

  Every other element stays linear, so for small inputs it reproduces the linear model. The
  state integrates the full lumped descriptor (one redundant volume per closed circuit,
  conserved exactly), with its exact Jacobian for implicit integrators.

All states are deviations from the static equilibrium on a flat road (``z_g = 0``), where
the accumulators sit at their precharge (DESIGN section 2). Outputs are SI.

References
----------
Paper Eq. (1)-(6), (10), (15)-(21); DESIGN sections 1, 2 and 4.
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline, PchipInterpolator

from hisopt.constants import DOF_NAMES, G_MPS2, WHEEL_NAMES
from hisopt.errors import ConfigError, ModelError
from hisopt.hydraulics.circuit import HydraulicSystem
from hisopt.hydraulics.coupling import hydraulic_descriptor
from hisopt.hydraulics.elements import Accumulator, Pipe, Valve
from hisopt.model import CoupledModel, StateSpace
from hisopt.vehicle import (
    body_to_corners,
    damping_matrix,
    mass_matrix,
    road_damping_input,
    road_stiffness_input,
    stiffness_matrix,
    stroke_matrix,
)

if TYPE_CHECKING:
    import plotly.graph_objects as go

SimulationMode = Literal["linear", "nonlinear"]
"""``"linear"``: exact lumped state space; ``"nonlinear"``: gas law, orifices, tyre lift-off."""

SolverMethod = Literal["auto", "RK45", "DOP853", "Radau", "BDF", "LSODA"]
"""``scipy.integrate.solve_ivp`` method; ``"auto"`` is LSODA (stiffness detected on the fly)."""

_GAS_VOLUME_LIMIT = 0.999
"""[-] Largest share of the gas volume the oil may take before the accumulator bottoms out."""


# --- pure kernels ----------------------------------------------------------------------


def gas_pressure_rise(dv_m3: ArrayLike, v0_m3: float, p_abs0_pa: float, gamma: float) -> NDArray[np.float64]:
    """Pressure rise of a gas-charged accumulator above its precharge (adiabatic/polytropic law).

    ``p - p0 = p_abs0 ((V0 / (V0 - dV))^gamma - 1)``; its slope at ``dV = 0`` is the linear
    stiffness ``gamma p_abs0 / V0`` (DESIGN section 2).

    Parameters
    ----------
    dv_m3
        [m^3] Oil volume stored in the accumulator (gas volume lost), ``< V0``; any shape.
    v0_m3
        [m^3] Gas volume at precharge.
    p_abs0_pa
        [Pa] Absolute precharge (equilibrium) pressure.
    gamma
        [-] Polytropic exponent.

    Returns
    -------
    ndarray
        [Pa] Gauge pressure rise above the precharge, shape of ``dv_m3``.
    """
    dv = np.asarray(dv_m3, dtype=float)
    return p_abs0_pa * ((v0_m3 / (v0_m3 - dv)) ** gamma - 1.0)


def gas_volume(p_pa: ArrayLike, v0_m3: float, p_abs0_pa: float, gamma: float) -> NDArray[np.float64]:
    """Oil volume stored in an accumulator at a pressure rise ``p`` (inverse of the gas law).

    ``dV = V0 (1 - (p_abs0 / (p_abs0 + p))^(1/gamma))``.

    Parameters
    ----------
    p_pa
        [Pa] Pressure rise above the precharge, ``> -p_abs0``; any shape.
    v0_m3
        [m^3] Gas volume at precharge.
    p_abs0_pa
        [Pa] Absolute precharge pressure.
    gamma
        [-] Polytropic exponent.

    Returns
    -------
    ndarray
        [m^3] Stored oil volume, shape of ``p_pa``.
    """
    p = np.asarray(p_pa, dtype=float)
    return v0_m3 * (1.0 - (p_abs0_pa / (p_abs0_pa + p)) ** (1.0 / gamma))


def gas_compliance(p_pa: ArrayLike, v0_m3: float, p_abs0_pa: float, gamma: float) -> NDArray[np.float64]:
    """Tangent compliance ``d(dV)/dp`` of an accumulator at a pressure rise ``p``.

    Parameters
    ----------
    p_pa
        [Pa] Pressure rise above the precharge, ``> -p_abs0``; any shape.
    v0_m3
        [m^3] Gas volume at precharge.
    p_abs0_pa
        [Pa] Absolute precharge pressure.
    gamma
        [-] Polytropic exponent.

    Returns
    -------
    ndarray
        [m^3/Pa] ``V0 / (gamma p_abs) (p_abs0 / p_abs)^(1/gamma)``; ``V0 / (gamma p_abs0)`` at 0.
    """
    p_abs = p_abs0_pa + np.asarray(p_pa, dtype=float)
    return v0_m3 / (gamma * p_abs) * (p_abs0_pa / p_abs) ** (1.0 / gamma)


def orifice_pressure_drop(q_m3ps: ArrayLike, rv: float, kq: float) -> NDArray[np.float64]:
    """Damper valve law ``dp = R_v q + K_q q |q|`` (linear plus turbulent orifice term).

    Parameters
    ----------
    q_m3ps
        [m^3/s] Flow through the valve, any shape.
    rv
        [Pa s m^-3] Linear (laminar) resistance, paper Eq. (10).
    kq
        [Pa s^2 m^-6] Quadratic coefficient, ``rho / (2 C_d^2 A_o^2)`` for an orifice.

    Returns
    -------
    ndarray
        [Pa] Pressure drop in the direction of the flow.
    """
    q = np.asarray(q_m3ps, dtype=float)
    return rv * q + kq * q * np.abs(q)


# --- road input --------------------------------------------------------------------------


Interpolation = Literal["pchip", "cubic", "linear"]
"""How the road is read between samples: ``"pchip"`` (shape-preserving cubic, C1: steps stay
steps), ``"cubic"`` (C2 spline: smoothest, best for sampled random roads; rings at steps) or
``"linear"`` (kinks at every sample, which slow the integrator down)."""


class RoadInput:
    """Road displacement at the four wheels between samples, held outside the record.

    Piecewise cubic Hermite (or linear) in time, evaluated in plain Python per solver stage.

    Parameters
    ----------
    t_s
        [s] Increasing sample times, shape ``(n_t,)``.
    z_m
        [m] Displacements under FL, FR, RL, RR, shape ``(n_t, 4)``.
    interpolation
        See :data:`Interpolation`.
    """

    def __init__(self, t_s: ArrayLike, z_m: ArrayLike, interpolation: Interpolation = "pchip"):
        t = np.asarray(t_s, dtype=float)
        z = np.asarray(z_m, dtype=float)
        if t.ndim != 1 or t.size < 2 or not np.all(np.diff(t) > 0):
            raise ConfigError(f"expected t_s 1-D and increasing with >= 2 samples, got shape {t.shape}")
        if z.shape != (t.size, 4):
            raise ConfigError(f"expected road_m of shape ({t.size}, 4) (FL, FR, RL, RR), got {z.shape}")
        if not np.all(np.isfinite(z)):
            raise ConfigError("road_m contains NaN or inf")
        if interpolation not in ("pchip", "cubic", "linear"):
            raise ConfigError(f"unknown interpolation {interpolation!r}; expected 'pchip', 'cubic' or 'linear'")
        self.t_s, self.z_m, self.interpolation = t, z, interpolation
        self._h = np.diff(t)
        self._secant = np.diff(z, axis=0) / self._h[:, None]
        if interpolation == "pchip":
            self.slopes = PchipInterpolator(t, z, axis=0).derivative()(t)
        elif interpolation == "cubic":
            self.slopes = CubicSpline(t, z, axis=0).derivative()(t)
        else:
            self.slopes = np.gradient(z, t, axis=0)
        self._t_list = t.tolist()  # plain floats: one look-up per solver stage

    def _segment(self, t: float) -> tuple[int, float]:
        i = min(max(bisect_right(self._t_list, t) - 1, 0), len(self._t_list) - 2)
        return i, (t - self._t_list[i]) / self._h[i]

    def value(self, t: float) -> NDArray[np.float64]:
        """[m] Displacements at time ``t`` [s], shape ``(4,)``."""
        if t <= self._t_list[0]:
            return self.z_m[0]
        if t >= self._t_list[-1]:
            return self.z_m[-1]
        i, x = self._segment(t)
        if self.interpolation == "linear":
            return self.z_m[i] + x * self._h[i] * self._secant[i]
        # Cubic Hermite basis on the segment, x in [0, 1].
        x2 = x * x
        x3 = x2 * x
        h = self._h[i]
        return (
            (2 * x3 - 3 * x2 + 1) * self.z_m[i]
            + (x3 - 2 * x2 + x) * h * self.slopes[i]
            + (3 * x2 - 2 * x3) * self.z_m[i + 1]
            + (x3 - x2) * h * self.slopes[i + 1]
        )

    def rate(self, t: float) -> NDArray[np.float64]:
        """[m/s] Time derivative of the interpolant at ``t`` [s] (0 outside the record), ``(4,)``."""
        if t < self._t_list[0] or t >= self._t_list[-1]:
            return np.zeros(4)
        i, x = self._segment(t)
        if self.interpolation == "linear":
            return self._secant[i]
        x2 = x * x
        return (
            6 * (x - x2) * self._secant[i]
            + (3 * x2 - 4 * x + 1) * self.slopes[i]
            + (3 * x2 - 2 * x) * self.slopes[i + 1]
        )

    def sampled_rate(self) -> NDArray[np.float64]:
        """[m/s] Rate at the samples, shape ``(n_t, 4)`` (central differences if linear)."""
        return self.slopes


# --- systems -------------------------------------------------------------------------------


def _single(x: ArrayLike, what: str) -> float:
    """A per-design parameter of a single-design model as a float."""
    arr = np.asarray(x, dtype=float).reshape(-1)
    if np.unique(arr).size != 1:
        raise ConfigError(f"time simulation takes one design; {what} has {arr.size} values")
    return float(arr[0])


def _single_design(a: np.ndarray, trailing: int, what: str) -> np.ndarray:
    """Drop a batch axis of size 1 (one design), keeping ``trailing`` matrix axes."""
    batch = a.shape[: a.ndim - trailing]
    if int(np.prod(batch, dtype=int)) != 1:
        raise ConfigError(f"time simulation takes one design; the model's {what} has batch shape {batch}")
    return a.reshape(a.shape[a.ndim - trailing :])


def _linear_matrices(ss: StateSpace) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return (
        _single_design(np.asarray(ss.a), 2, "state matrix"),
        _single_design(np.asarray(ss.b0), 2, "input matrix"),
        _single_design(np.asarray(ss.b1), 2, "input-rate matrix"),
    )


def state_scales(
    a: np.ndarray,
    b0: np.ndarray,
    b1: np.ndarray,
    output: np.ndarray | None = None,
    f_hz: ArrayLike = (0.5, 1.5, 3.0, 11.0),
) -> NDArray[np.float64]:
    """Typical magnitude of each state per metre of road input (for absolute tolerances).

    The largest ``|(C x)_i(j w)|`` over a few frequencies spanning the body and wheel modes
    and over the four wheel inputs, ``x(j w) = (j w I - A)^-1 (B0 + j w B1)``.

    Parameters
    ----------
    a, b0, b1
        State-space matrices, shapes ``(n, n)``, ``(n, 4)``, ``(n, 4)``.
    output
        Map ``C`` ``(n_out, n)`` to the quantities wanted (default: the states).
    f_hz
        [Hz] Probe frequencies.

    Returns
    -------
    ndarray, shape ``(n_out,)``
        [quantity unit / m] Scales, positive.
    """
    s = 2j * np.pi * np.asarray(f_hz, dtype=float)[:, None, None]
    n = a.shape[-1]
    x = np.linalg.solve(s * np.eye(n) - a, b0 + s * b1)
    if output is not None:
        x = output @ x
    scale = np.abs(x).max(axis=(0, 2))
    return np.where(scale > 0, scale, scale.max())


def full_state_map(model: CoupledModel, labels: tuple[str, ...]) -> tuple[NDArray[np.float64], tuple[str, ...]]:
    """Linear map from state-space states to ``[X, V, every dynamic descriptor state]``.

    :meth:`CoupledModel.state_space` may drop one pressure per circuit (the circuit's
    conserved fluid volume makes it redundant); it is restored from the volume balance
    ``sum_n C_n p_n = (sum over the circuit's ports of N) G X`` (zero initial storage).

    Parameters
    ----------
    model
        Single-design model with a HIS.
    labels
        State labels of its state space (``StateSpace.labels``).

    Returns
    -------
    map, full_labels
        ``(14 + n_dyn, n_states)`` and the labels of the full states.
    """
    if model.his is None:
        return np.eye(len(labels)), labels
    h = hydraulic_descriptor(model.his)
    e = _single_design(np.asarray(h.e), 1, "hydraulic descriptor")
    n_inc = _single_design(np.asarray(h.n), 2, "cylinder incidence")
    dyn = np.flatnonzero(np.asarray(h.dynamic, dtype=bool))
    full = DOF_NAMES + tuple(f"d{n}" for n in DOF_NAMES) + tuple(h.labels[i] for i in dyn)
    pos = {label: j for j, label in enumerate(labels)}
    rmap = np.zeros((len(full), len(labels)))
    missing: list[int] = []
    for i, label in enumerate(full):
        if label in pos:
            rmap[i, pos[label]] = 1.0
        else:
            missing.append(i)
    g = stroke_matrix(model.vehicle)
    circuit = np.asarray(h.circuit)
    for i in missing:
        d = dyn[i - 14] if i >= 14 else None
        if d is None or ":p[" not in full[i] or sum(circuit[dyn[j - 14]] == circuit[d] for j in missing) != 1:
            raise ModelError(f"cannot restore state {full[i]!r} eliminated from the state space")
        c = circuit[d]
        volume_per_x = n_inc[np.asarray(h.port_circuit) == c].sum(axis=0) @ g
        rmap[i, :7] = volume_per_x / e[d]
        for j, dj in enumerate(dyn):
            if j + 14 != i and circuit[dj] == c and ":p[" in h.labels[dj]:
                rmap[i] -= e[dj] / e[d] * rmap[j + 14]
    return rmap, full


@dataclass(frozen=True)
class _Accumulators:
    """Accumulators of a HIS in descriptor order: where they sit and their gas data."""

    names: tuple[str, ...]
    rows: NDArray[np.int_]  # descriptor row of each accumulator's node
    v0: NDArray[np.float64]
    p_abs0: NDArray[np.float64]
    gamma: NDArray[np.float64]
    p0_gauge: NDArray[np.float64]

    @property
    def compliance(self) -> NDArray[np.float64]:
        """[m^3/Pa] Linearised compliance of each accumulator."""
        return self.v0 / (self.gamma * self.p_abs0)


def _descriptor_layout(his: HydraulicSystem) -> tuple[_Accumulators, NDArray[np.bool_]]:
    """Accumulator positions and the valve-branch mask in :func:`hydraulic_descriptor` order.

    Follows :func:`hisopt.hydraulics.circuit.lumped_descriptor`: per circuit, node pressures
    (``circuit.nodes`` order) then one flow per series element (element order).
    """
    names: list[str] = []
    rows: list[int] = []
    gas: list[tuple[float, float, float, float]] = []
    is_valve: list[bool] = []
    offset = 0
    for circuit in his.circuits:
        index = {n: i for i, n in enumerate(circuit.nodes)}
        accs = [e for e in circuit.elements if isinstance(e, Accumulator)]
        for k, acc in enumerate(accs):
            names.append(circuit.name if len(accs) == 1 else f"{circuit.name}{k + 1}")
            rows.append(offset + index[acc.node])
            gas.append(
                (
                    _single(acc.volume, "V0"),
                    _single(acc.absolute_precharge, "p0"),
                    _single(acc.gamma, "gamma"),
                    _single(acc.precharge_gauge, "p0"),
                )
            )
        branches = [e for e in circuit.elements if isinstance(e, (Valve, Pipe))]
        is_valve += [False] * len(index) + [isinstance(b, Valve) for b in branches]
        offset += len(index) + len(branches)
    v0, p_abs0, gamma, p0 = (np.array(col, dtype=float) for col in zip(*gas)) if gas else (np.zeros(0),) * 4
    accs_ = _Accumulators(tuple(names), np.array(rows, dtype=int), v0, p_abs0, gamma, p0)
    return accs_, np.array(is_valve, dtype=bool)


class _NonlinearNetwork:
    """Right-hand side of the nonlinear model (see the module docstring), one design.

    State ``y = [X (7), V (7), w (n_d)]``: ``w`` holds the dynamic hydraulic states of the
    lumped descriptor, except that nodes with accumulators hold their stored oil volume.
    """

    def __init__(self, model: CoupledModel, valve_kq: float, tyre_liftoff: bool):
        v = model.vehicle
        self.m = np.diag(mass_matrix(v))
        # Tyres are split off the conventional matrices so lift-off can clip their force.
        self.kt = np.diag(road_stiffness_input(v)[3:])
        self.ct = np.diag(road_damping_input(v)[3:])
        self.k_susp = stiffness_matrix(v)
        self.k_susp[3:, 3:] -= np.diag(self.kt)
        self.c_susp = damping_matrix(v)
        self.c_susp[3:, 3:] -= np.diag(self.ct)
        front, rear = v.static_wheel_loads(G_MPS2)
        self.f_static = np.array([front, front, rear, rear])
        self.tyre_liftoff = tyre_liftoff

        self.valve_kq = valve_kq
        if model.his is None:  # the reference car: no network, only the tyre nonlinearity
            self._no_network()
            return
        h = hydraulic_descriptor(model.his)
        e = _single_design(np.asarray(h.e), 1, "hydraulic descriptor")
        a = _single_design(np.asarray(h.a), 2, "hydraulic descriptor")
        n_inc = _single_design(np.asarray(h.n), 2, "cylinder incidence")
        self.acc, valve = _descriptor_layout(model.his)
        if valve.size != e.size:
            raise ModelError("hydraulic descriptor layout does not match its circuits")
        dyn = np.asarray(h.dynamic, dtype=bool)
        self.dyn, self.alg = np.flatnonzero(dyn), np.flatnonzero(~dyn)
        self.n_h = e.size
        self.coupling = h.port_map @ n_inc @ stroke_matrix(v)  # node inflow per velocity
        self.a_dyn = a[self.dyn]
        self.cp_dyn = self.coupling[self.dyn]
        self.e_dyn = e[self.dyn]

        # Accumulator nodes: the descriptor compliance is the accumulators' linear share
        # plus any other (linear) compliance at the node (oil, pipe ends), kept linear.
        pos = {int(r): i for i, r in enumerate(self.dyn)}
        acc_nodes = np.unique(self.acc.rows)
        self.acc_state = np.array([pos[int(r)] for r in acc_nodes], dtype=int)
        self.node_accs = [np.flatnonzero(self.acc.rows == r) for r in acc_nodes]
        other = np.array([e[r] - self.acc.compliance[k].sum() for r, k in zip(acc_nodes, self.node_accs)])
        self.other_compliance = np.where(other > 1e-9 * e[acc_nodes], other, 0.0)

        # Algebraic part: pressures of nodes without compliance and valve flows.
        if self.alg.size:
            a_aa = a[np.ix_(self.alg, self.alg)]
            try:
                inv = np.linalg.inv(a_aa)
            except np.linalg.LinAlgError as exc:
                raise ModelError("the hydraulic network has an algebraic loop with no resistance") from exc
            self.a_aa = a_aa
            self.a_ad = a[np.ix_(self.alg, self.dyn)]
            self.cp_alg = self.coupling[self.alg]
            self.solve_lin_d = -inv @ self.a_ad
            self.solve_lin_v = -inv @ self.cp_alg
            self.kq_alg = np.where(valve[self.alg], valve_kq, 0.0)

    def _no_network(self) -> None:
        empty = np.zeros(0)
        self.acc = _Accumulators((), np.zeros(0, dtype=int), empty, empty, empty, empty)
        self.dyn = self.alg = np.zeros(0, dtype=int)
        self.n_h = 0
        self.coupling = np.zeros((0, 7))
        self.a_dyn, self.cp_dyn, self.e_dyn = np.zeros((0, 0)), np.zeros((0, 7)), empty
        self.acc_state = np.zeros(0, dtype=int)
        self.node_accs, self.other_compliance = [], empty

    @property
    def n_states(self) -> int:
        return 14 + self.dyn.size

    def initial_state(self) -> NDArray[np.float64]:
        return np.zeros(self.n_states)

    # hydraulic constitutive laws ----------------------------------------------------------
    def node_pressure(self, w: np.ndarray) -> np.ndarray:
        """[Pa] Pressure rise of each accumulator node from its stored volume, ``(n_acc_nodes, k)``."""
        out = np.empty_like(w)
        for j, (accs, c_o) in enumerate(zip(self.node_accs, self.other_compliance)):
            v0 = self.acc.v0[accs]
            if accs.size == 1 and c_o == 0.0:
                dv = np.minimum(w[j], _GAS_VOLUME_LIMIT * v0[0])
                out[j] = gas_pressure_rise(dv, v0[0], self.acc.p_abs0[accs[0]], self.acc.gamma[accs[0]])
            else:
                out[j] = self._invert_node(w[j], accs, c_o)
        return out

    def _invert_node(self, w: np.ndarray, accs: np.ndarray, c_o: float) -> np.ndarray:
        """Newton on ``sum dV_i(p) + C_o p = w``: concave in ``p``, so after one step the
        iterates approach the root from below, monotonically."""
        p_floor = -0.999 * self.acc.p_abs0[accs].min()
        p = w / (self.acc.compliance[accs].sum() + c_o)
        for _ in range(100):
            vol = c_o * p
            slope = np.full_like(p, c_o)
            for i in accs:
                gas = (self.acc.v0[i], self.acc.p_abs0[i], self.acc.gamma[i])
                vol = vol + gas_volume(p, *gas)
                slope = slope + gas_compliance(p, *gas)
            step = (vol - w) / slope
            p = np.maximum(p - step, p_floor)
            if np.all(np.abs(step) <= 1e-12 * self.acc.p_abs0[accs].max()):
                return p
        raise ModelError("accumulator node pressure did not converge (gas volume exhausted?)")

    def algebraic(self, h_dyn: np.ndarray, vel: np.ndarray) -> np.ndarray:
        """Pressures of compliance-free nodes and valve flows, ``(n_alg, k)``.

        Linear valves: one matrix product. Quadratic orifices: Newton from the linear
        solution, Jacobian ``A_aa - diag(2 K_q |q|)``.
        """
        x = self.solve_lin_d @ h_dyn + self.solve_lin_v @ vel
        if self.valve_kq == 0.0:
            return x
        rhs = self.a_ad @ h_dyn + self.cp_alg @ vel
        scale = np.abs(x).max(axis=0, keepdims=True) + 1e-30
        for _ in range(100):
            resid = self.a_aa @ x + rhs - (self.kq_alg[:, None] * x * np.abs(x))
            jac = self.a_aa[None] - (2.0 * self.kq_alg * np.abs(x).T)[:, None, :] * np.eye(x.shape[0])[None]
            step = np.linalg.solve(jac, resid.T[..., None])[..., 0].T
            x = x - step
            if np.all(np.abs(step) <= 1e-12 * scale):
                return x
        raise ModelError("the quadratic valve network did not converge; check valve_kq and the valve layout")

    def hydraulic_state(self, w: np.ndarray, vel: np.ndarray) -> np.ndarray:
        """All descriptor unknowns ``h`` (node pressures, branch flows), ``(n_h, k)``."""
        h_dyn = w.copy()
        h_dyn[self.acc_state] = self.node_pressure(w[self.acc_state])
        h = np.zeros((self.n_h, w.shape[1]))
        h[self.dyn] = h_dyn
        if self.alg.size:
            h[self.alg] = self.algebraic(h_dyn, vel)
        return h

    def tyre_force(self, x: np.ndarray, vel: np.ndarray, u: np.ndarray, du: np.ndarray) -> np.ndarray:
        """[N] Upward road force on each wheel above its static value, ``(4, k)``.

        ``u``, ``du``: road displacement [m] and rate [m/s], shape ``(4, 1)`` or ``(4, k)``.
        """
        force = self.kt[:, None] * (u - x[3:]) + self.ct[:, None] * (du - vel[3:])
        if self.tyre_liftoff:
            force = np.maximum(force, -self.f_static[:, None])
        return force

    def derivative(self, y: np.ndarray, u: np.ndarray, du: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``dy/dt`` and the descriptor unknowns ``h`` for states ``y`` ``(n, k)``."""
        x, vel, w = y[:7], y[7:14], y[14:]
        h = self.hydraulic_state(w, vel)
        force = -self.k_susp @ x - self.c_susp @ vel - self.coupling.T @ h
        force[3:] += self.tyre_force(x, vel, u, du)
        flows = self.a_dyn @ h + self.cp_dyn @ vel
        dw = flows / self.e_dyn[:, None]
        dw[self.acc_state] = flows[self.acc_state]  # accumulator nodes integrate their volume
        return np.concatenate([vel, force / self.m[:, None], dw]), h

    def jacobian(self, y: np.ndarray, u: np.ndarray, du: np.ndarray) -> np.ndarray:
        """Exact Jacobian ``d(dy/dt)/dy`` at one state ``y`` ``(n,)`` (for implicit solvers).

        Chain rule through the node laws (``dp/dW = 1 / sum of tangent compliances``), the
        algebraic valve network (``dh_a = -J_a^-1 (A_ad dh_d + C_a dV)``) and the tyres
        (no stiffness while a wheel is off the road).
        """
        x, vel, w = y[:7, None], y[7:14, None], y[14:, None]
        h = self.hydraulic_state(w, vel)[:, 0]
        n_d = self.dyn.size
        dpdw = np.ones(n_d)
        for j, (accs, c_o) in enumerate(zip(self.node_accs, self.other_compliance)):
            p = h[self.dyn[self.acc_state[j]]]
            gas = sum(gas_compliance(p, self.acc.v0[i], self.acc.p_abs0[i], self.acc.gamma[i]) for i in accs)
            dpdw[self.acc_state[j]] = 1.0 / (c_o + gas)
        dh_dw = np.zeros((self.n_h, n_d))
        dh_dv = np.zeros((self.n_h, 7))
        dh_dw[self.dyn, np.arange(n_d)] = dpdw
        if self.alg.size:
            jac_a = self.a_aa - np.diag(2.0 * self.kq_alg * np.abs(h[self.alg]))
            sol = -np.linalg.solve(jac_a, np.hstack([self.a_ad * dpdw, self.cp_alg]))
            dh_dw[self.alg], dh_dv[self.alg] = sol[:, :n_d], sol[:, n_d:]
        on = np.ones(4)
        if self.tyre_liftoff:
            on = (self.tyre_force(x, vel, u[:, None], du[:, None])[:, 0] > -self.f_static).astype(float)
        df_dx = -self.k_susp.copy()
        df_dx[3:, 3:] -= np.diag(self.kt * on)
        df_dv = -self.c_susp - self.coupling.T @ dh_dv
        df_dv[3:, 3:] -= np.diag(self.ct * on)
        row = np.where(np.isin(np.arange(n_d), self.acc_state), 1.0, 1.0 / self.e_dyn)[:, None]
        jac = np.zeros((self.n_states, self.n_states))
        jac[:7, 7:14] = np.eye(7)
        jac[7:14, :7] = df_dx / self.m[:, None]
        jac[7:14, 7:14] = df_dv / self.m[:, None]
        jac[7:14, 14:] = -(self.coupling.T @ dh_dw) / self.m[:, None]
        jac[14:, 7:14] = row * (self.a_dyn @ dh_dv + self.cp_dyn)
        jac[14:, 14:] = row * (self.a_dyn @ dh_dw)
        return jac

    def volume_margin(self, w: np.ndarray) -> float:
        """[-] Largest stored volume over gas volume of any accumulator node (1 = bottomed)."""
        worst = 0.0
        for j, accs in enumerate(self.node_accs):
            worst = max(worst, float(np.max(w[self.acc_state[j]])) / float(self.acc.v0[accs].sum()))
        return worst


# --- results ----------------------------------------------------------------------------


@dataclass(frozen=True)
class TimeResponse:
    """A simulated time history; SI units, samples at the road input times.

    Shapes: ``t_s`` ``(n_t,)``; ``road_m``, ``stroke_m``, ``tyre_force_n`` ``(n_t, 4)`` (FL,
    FR, RL, RR); ``displacement``, ``velocity``, ``acceleration`` ``(n_t, 7)`` in DOF order
    ``[z_s, phi, theta, z_u1..z_u4]`` (m or rad, per s, per s^2); accumulator arrays
    ``(n_t, n_acc)``.
    """

    t_s: NDArray[np.float64]
    road_m: NDArray[np.float64]
    displacement: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    stroke_m: NDArray[np.float64]
    """[m] Suspension stroke ``delta = G X``, extension positive."""
    tyre_force_n: NDArray[np.float64]
    """[N] Dynamic tyre load ``k_t (z_u - z_g) + c_t (dz_u - dz_g)`` (DESIGN section 4)."""
    accumulator_pressure_pa: NDArray[np.float64]
    """[Pa] Gauge accumulator pressure, precharge plus dynamic rise."""
    accumulator_volume_m3: NDArray[np.float64]
    """[m^3] Oil stored in each accumulator (gas volume lost)."""
    accumulator_names: tuple[str, ...]
    corners: NDArray[np.float64]
    """``T_z`` (4, 3): body points above the wheels from ``[z_s, phi, theta]``."""
    mode: SimulationMode

    @property
    def corner_acceleration(self) -> NDArray[np.float64]:
        """[m/s^2] Vertical body acceleration above each wheel, ``T_z [z_s, phi, theta]''``, ``(n_t, 4)``."""
        return self.acceleration[:, :3] @ self.corners.T

    def to_frame(self) -> pd.DataFrame:
        """All signals in one table (SI), one row per sample.

        Columns: ``time``; ``road_<w>``; DOF displacements ``z_s, phi, theta, z_u1..z_u4``,
        velocities ``d<dof>``, accelerations ``dd<dof>``; ``a_body_<w>`` (body corners),
        ``stroke_<w>``, ``tyre_force_<w>``; ``p_acc_<name>`` (gauge), ``dv_acc_<name>``.
        """
        cols: dict[str, np.ndarray] = {"time": self.t_s}
        cols |= {f"road_{w}": self.road_m[:, i] for i, w in enumerate(WHEEL_NAMES)}
        cols |= {n: self.displacement[:, i] for i, n in enumerate(DOF_NAMES)}
        cols |= {f"d{n}": self.velocity[:, i] for i, n in enumerate(DOF_NAMES)}
        cols |= {f"dd{n}": self.acceleration[:, i] for i, n in enumerate(DOF_NAMES)}
        corner = self.corner_acceleration
        cols |= {f"a_body_{w}": corner[:, i] for i, w in enumerate(WHEEL_NAMES)}
        cols |= {f"stroke_{w}": self.stroke_m[:, i] for i, w in enumerate(WHEEL_NAMES)}
        cols |= {f"tyre_force_{w}": self.tyre_force_n[:, i] for i, w in enumerate(WHEEL_NAMES)}
        cols |= {f"p_acc_{n}": self.accumulator_pressure_pa[:, i] for i, n in enumerate(self.accumulator_names)}
        cols |= {f"dv_acc_{n}": self.accumulator_volume_m3[:, i] for i, n in enumerate(self.accumulator_names)}
        return pd.DataFrame(cols)

    def plot_signals(
        self, columns: tuple[str, ...] = ("z_s", "phi", "theta"), fig: "go.Figure | None" = None
    ) -> "go.Figure":
        """Stacked time histories of columns of :meth:`to_frame`, one panel each.

        Parameters
        ----------
        columns
            Column names of :meth:`to_frame` (SI units).
        fig
            Figure to add the traces to (its subplot grid must have ``len(columns)`` rows);
            ``None`` makes a new one.
        """
        from plotly.subplots import make_subplots

        frame = self.to_frame()
        unknown = [c for c in columns if c not in frame.columns]
        if unknown:
            raise ConfigError(
                f"unknown signal(s) {unknown}; expected columns of to_frame(), e.g. {list(frame.columns[:8])}"
            )
        from hisopt.report.theme import use_theme

        use_theme()
        if fig is None:
            fig = make_subplots(rows=len(columns), cols=1, shared_xaxes=True, subplot_titles=list(columns))
        for row, col in enumerate(columns, start=1):
            fig.add_scatter(x=frame["time"], y=frame[col], name=f"{col} ({self.mode})", row=row, col=1)
        fig.update_xaxes(title_text="time [s]", row=len(columns), col=1)
        return fig

    def plot_pressures(self, fig: "go.Figure | None" = None) -> "go.Figure":
        """Gauge accumulator pressures [MPa] against time."""
        import plotly.graph_objects as go

        from hisopt.report.theme import use_theme

        use_theme()
        fig = go.Figure() if fig is None else fig
        for i, name in enumerate(self.accumulator_names):
            pressure_mpa = self.accumulator_pressure_pa[:, i] / 1e6
            fig.add_scatter(x=self.t_s, y=pressure_mpa, name=f"accumulator {name} ({self.mode})")
        fig.update_layout(xaxis_title="time [s]", yaxis_title="gauge pressure [MPa]")
        return fig


# --- simulation ---------------------------------------------------------------------------


def _integrate(
    fun: Callable[[float, np.ndarray], np.ndarray],
    y0: np.ndarray,
    road: RoadInput,
    method: str,
    rtol: float,
    atol: np.ndarray,
    jac: Callable[[float, np.ndarray], np.ndarray],
) -> np.ndarray:
    """``solve_ivp`` over the road record with outputs at its samples, ``(n, n_t)``."""
    options: dict[str, object] = {}
    if method in ("Radau", "BDF", "LSODA"):  # explicit methods warn about an unused jac
        options["jac"] = jac
    sol = solve_ivp(
        fun,
        (float(road.t_s[0]), float(road.t_s[-1])),
        y0,
        method=method,
        t_eval=road.t_s,
        rtol=rtol,
        atol=atol,
        max_step=float(np.diff(road.t_s).min()),  # resolve every input segment
        vectorized=True,
        **options,
    )
    if not sol.success:
        raise ModelError(f"time integration failed ({method}): {sol.message}")
    return sol.y


def simulate(
    model: CoupledModel,
    t_s: ArrayLike,
    road_m: ArrayLike,
    mode: SimulationMode = "linear",
    *,
    valve_kq: float = 0.0,
    tyre_liftoff: bool = False,
    interpolation: Interpolation = "pchip",
    method: SolverMethod = "auto",
    rtol: float = 1e-8,
) -> TimeResponse:
    """Simulate the car (with or without HIS) driven by road displacements at the wheels.

    The car starts at rest in its static equilibrium on a flat road; a profile that does not
    start at 0 therefore begins with a transient.

    Parameters
    ----------
    model
        Single-design lumped model (``pipe_model="lumped"``; distributed pipes have no
        finite state space).
    t_s
        [s] Increasing sample times, shape ``(n_t,)``; outputs are given at these times.
    road_m
        [m] Road displacement under FL, FR, RL, RR, shape ``(n_t, 4)`` (e.g. from
        :func:`hisopt.road.random_profile`, :func:`~hisopt.road.step_profile`,
        :func:`~hisopt.road.bump_profile`), read between samples as ``interpolation`` says.
    mode
        ``"linear"`` (exact state space) or ``"nonlinear"`` (gas law, options below).
    valve_kq
        [Pa s^2 m^-6] Quadratic orifice coefficient ``K_q`` of every damper valve,
        ``dp = R_v q + K_q q |q|`` (nonlinear mode only).
    tyre_liftoff
        [-] Let wheels leave the road when the dynamic load exceeds the static load
        (nonlinear mode only).
    interpolation
        ``"pchip"`` (default; keeps steps monotone), ``"cubic"`` (smoothest: fastest and
        most faithful for sampled random roads) or ``"linear"`` (:data:`Interpolation`).
    method
        Integrator of ``scipy.integrate.solve_ivp``; ``"auto"`` is LSODA, which switches
        between Adams and BDF as stiffness requires (exact Jacobian in linear mode).
        Explicit ``"DOP853"`` is often fastest for smooth (``"cubic"``) random roads.
    rtol
        [-] Relative tolerance; absolute tolerances follow from each state's typical size.

    Returns
    -------
    TimeResponse
    """
    if model.pipe_model != "lumped":
        raise ConfigError(f"time simulation needs pipe_model='lumped', got {model.pipe_model!r}")
    if mode not in ("linear", "nonlinear"):
        raise ConfigError(f"unknown mode {mode!r}; expected 'linear' or 'nonlinear'")
    if mode == "linear" and (valve_kq != 0.0 or tyre_liftoff):
        raise ConfigError("valve_kq and tyre_liftoff need mode='nonlinear'")
    if not valve_kq >= 0.0:
        raise ConfigError(f"expected valve_kq >= 0 [Pa s^2 m^-6], got {valve_kq!r}")
    if not 0.0 < rtol < 1.0:
        raise ConfigError(f"expected 0 < rtol < 1, got {rtol!r}")
    road = RoadInput(t_s, road_m, interpolation)
    ss = model.state_space()
    a, b0, b1 = _linear_matrices(ss)
    u_scale = max(float(np.abs(road.z_m).max()), 1e-6)
    # LSODA switches between Adams (non-stiff) and BDF (stiff: chamber or pipe compliance)
    # by itself, and one evaluation per step suits steps capped at the input spacing.
    chosen = "LSODA" if method == "auto" else method
    if mode == "linear":
        return _simulate_linear(model, ss, road, chosen, rtol, u_scale)
    return _simulate_nonlinear(model, ss, road, chosen, rtol, u_scale, valve_kq, tyre_liftoff)


def _simulate_linear(
    model: CoupledModel, ss: StateSpace, road: RoadInput, method: str, rtol: float, u_scale: float
) -> TimeResponse:
    a, b0, b1 = _linear_matrices(ss)
    forcing = b0 + a @ b1  # input matrix of the shifted state x - B1 u

    def fun(t: float, y: np.ndarray) -> np.ndarray:
        f = forcing @ road.value(t)
        return a @ y + (f[:, None] if y.ndim == 2 else f)

    atol = 1e-3 * rtol * u_scale * state_scales(a, b0, b1)
    y = _integrate(fun, np.zeros(a.shape[0]), road, method, rtol, atol, lambda t, y: a)
    u, du = road.z_m.T, road.sampled_rate().T
    x = y + b1 @ u
    dx = a @ x + b0 @ u + b1 @ du
    names: tuple[str, ...] = ()
    p = np.zeros((0, x.shape[1]))
    vol = np.zeros_like(p)
    if model.his is not None:
        acc, _ = _descriptor_layout(model.his)
        rmap, full = full_state_map(model, ss.labels)
        labels = hydraulic_descriptor(model.his).labels
        p = rmap[[full.index(labels[r]) for r in acc.rows]] @ x
        vol = acc.compliance[:, None] * p  # linearised gas law
        names = acc.names
        p = p + acc.p0_gauge[:, None]
    return _response(model, road, x[:7], x[7:14], dx[7:14], p, vol, names, "linear")


def _simulate_nonlinear(
    model: CoupledModel,
    ss: StateSpace,
    road: RoadInput,
    method: str,
    rtol: float,
    u_scale: float,
    valve_kq: float,
    tyre_liftoff: bool,
) -> TimeResponse:
    net = _NonlinearNetwork(model, valve_kq, tyre_liftoff)
    a, b0, b1 = _linear_matrices(ss)
    scale = state_scales(a, b0, b1, full_state_map(model, ss.labels)[0]) * u_scale
    # Accumulator nodes integrate volume: their typical size is compliance x pressure.
    scale[14 + net.acc_state] *= net.e_dyn[net.acc_state]
    has_ct = bool(np.any(net.ct))
    zeros = np.zeros((4, 1))

    def fun(t: float, y: np.ndarray) -> np.ndarray:
        column = y.ndim == 1
        yy = y[:, None] if column else y
        du = road.rate(t)[:, None] if has_ct else zeros
        dy, _ = net.derivative(yy, road.value(t)[:, None], du)
        return dy[:, 0] if column else dy

    def jac(t: float, y: np.ndarray) -> np.ndarray:
        return net.jacobian(y, road.value(t), road.rate(t) if has_ct else zeros[:, 0])

    y = _integrate(fun, net.initial_state(), road, method, rtol, 1e-3 * rtol * scale, jac)
    if net.volume_margin(y[14:]) >= _GAS_VOLUME_LIMIT * (1.0 - 1e-9):
        raise ModelError("an accumulator bottomed out (oil filled its gas volume): reduce the input or raise V0")
    dy, h = net.derivative(y, road.z_m.T, road.sampled_rate().T)
    p_nodes = h[net.dyn][net.acc_state]
    p = np.zeros((len(net.acc.names), y.shape[1]))
    vol = np.zeros_like(p)
    for j, accs in enumerate(net.node_accs):
        for i in accs:
            p[i] = p_nodes[j]
            vol[i] = gas_volume(p_nodes[j], net.acc.v0[i], net.acc.p_abs0[i], net.acc.gamma[i])
    p = p + net.acc.p0_gauge[:, None]
    response = _response(model, road, y[:7], y[7:14], dy[7:14], p, vol, net.acc.names, "nonlinear")
    if tyre_liftoff:  # report the clipped tyre force, as the model applied it
        force = -net.tyre_force(y[:7], y[7:14], road.z_m.T, road.sampled_rate().T).T
        response = replace(response, tyre_force_n=force)
    return response


def _response(
    model: CoupledModel,
    road: RoadInput,
    x: np.ndarray,
    v: np.ndarray,
    acc: np.ndarray,
    p: np.ndarray,
    vol: np.ndarray,
    names: tuple[str, ...],
    mode: SimulationMode,
) -> TimeResponse:
    """Assemble a :class:`TimeResponse` from ``(7, n_t)`` mechanical histories."""
    veh = model.vehicle
    kt = np.diag(road_stiffness_input(veh)[3:])
    ct = np.diag(road_damping_input(veh)[3:])
    tyre = kt * (x[3:].T - road.z_m) + ct * (v[3:].T - road.sampled_rate())
    return TimeResponse(
        t_s=road.t_s,
        road_m=road.z_m,
        displacement=x.T,
        velocity=v.T,
        acceleration=acc.T,
        stroke_m=(stroke_matrix(veh) @ x).T,
        tyre_force_n=tyre,
        accumulator_pressure_pa=p.T,
        accumulator_volume_m3=vol.T,
        accumulator_names=names,
        corners=body_to_corners(veh),
        mode=mode,
    )


__all__ = [
    "RoadInput",
    "SimulationMode",
    "SolverMethod",
    "TimeResponse",
    "gas_compliance",
    "gas_pressure_rise",
    "gas_volume",
    "orifice_pressure_drop",
    "simulate",
    "full_state_map",
    "state_scales",
]
