"""The nonlinear car + HIS for time-domain simulation (paper Section VI; docs/model.md §3).

The lumped network of the linear model with three nonlinearities (laws from
:mod:`hisopt.hydraulics.laws`):

- every node carrying an accumulator integrates its *stored oil volume* ``W`` (the node's
  flow balance), and its pressure follows the polytropic gas law in absolute pressure,
  ``p_abs = p_abs0 (V0 / (V0 - dV))^gamma`` (``dV`` the gas volume taken by oil, plus any
  linear compliance ``C_o p`` at the node: oil, pipe ends);
- optional quadratic orifice valves ``dp = R_v q + K_q q |q|`` (``valve_kq`` for every linear
  valve, and each orifice element with its own ``R`` and ``K_q``; docs/model.md §12.2), and
  each physical damper valve by its own law
  (:func:`hisopt.hydraulics.laws.damper_valve_pressure_drop`: bleed orifice, blow-off, laminar
  part; docs/model.md §3.10), the algebraic valve network solved by Newton's method at each
  right-hand-side evaluation from the linear solution (every valve at its equivalent
  resistance);
- optional tyre lift-off: the tyre pushes but never pulls (contact force
  ``F_static - k_t (z_u - z_g) - c_t (dz_u - dz_g) >= 0``).

Every other element stays linear, so for small inputs it reproduces the linear model. The
state integrates the full lumped descriptor (one redundant volume per closed circuit,
conserved exactly), with its exact Jacobian for implicit integrators. All states are
deviations from the static equilibrium on a flat road.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hisopt.constants import G_MPS2, P_ATM_PA
from hisopt.coupled.model import CoupledModel
from hisopt.errors import ConfigError, ModelError
from hisopt.hydraulics import laws
from hisopt.hydraulics.coupling import HydraulicSystem
from hisopt.vehicle import damping_matrix, mass_matrix, road_damping_input, road_stiffness_input, stiffness_matrix, stroke_matrix

GAS_VOLUME_LIMIT = 0.999
"""[-] Largest share of the gas volume the oil may take before the accumulator bottoms out."""


def _single(x: ArrayLike, what: str) -> float:
    """A per-design parameter of a single-design model as a float."""
    arr = np.asarray(x, dtype=float).reshape(-1)
    if np.unique(arr).size != 1:
        raise ConfigError(f"time simulation takes one design; {what} has {arr.size} values")
    return float(arr[0])


def single_design(a: np.ndarray, trailing: int, what: str) -> np.ndarray:
    """Drop a batch axis of size 1 (one design), keeping ``trailing`` matrix axes."""
    batch = a.shape[: a.ndim - trailing]
    if int(np.prod(batch, dtype=int)) != 1:
        raise ConfigError(f"time simulation takes one design; the model's {what} has batch shape {batch}")
    return a.reshape(a.shape[a.ndim - trailing :])


@dataclass(frozen=True)
class Accumulators:
    """The accumulators of one design's network: where they sit and their gas data.

    ``rows``: the descriptor row of each accumulator's node; ``v0`` [m^3], ``p_abs0`` [Pa],
    ``gamma`` [-]: gas volume, absolute pressure and exponent at the operating point;
    ``p0_gauge`` [Pa] the gauge operating pressure.
    """

    names: tuple[str, ...]
    rows: NDArray[np.int_]
    v0: NDArray[np.float64]
    p_abs0: NDArray[np.float64]
    gamma: NDArray[np.float64]
    p0_gauge: NDArray[np.float64]

    @property
    def compliance(self) -> NDArray[np.float64]:
        """[m^3/Pa] Linearised compliance of each accumulator."""
        return laws.accumulator_compliance(self.v0, self.p_abs0, self.gamma)


def accumulators(his: HydraulicSystem) -> Accumulators:
    """The accumulators of a single-design HIS, in element order (named by their circuit,
    with a number when a circuit has several)."""
    net = his.network
    found = net.accumulators()
    circuits = [net.elements[k][0] for k, _, _ in found]
    names, gas = [], []
    for i, ((k, _, _), c) in enumerate(zip(found, circuits, strict=True)):
        same = [j for j, cj in enumerate(circuits) if cj == c]
        name = net.layout.circuits[c].name
        names.append(name if len(same) == 1 else f"{name}{same.index(i) + 1}")
        gas.append(tuple(_single(v, "accumulator parameter") for v in his.values.gas[k]))
    v0, p_abs0, gamma = (np.array(col, dtype=float) for col in zip(*gas, strict=True)) if gas else (np.zeros(0),) * 3
    rows = np.array([row for _, _, row in found], dtype=int)
    return Accumulators(tuple(names), rows, v0, p_abs0, gamma, p_abs0 - P_ATM_PA)


@dataclass(frozen=True)
class DamperGroup:
    """Damper valves that share a form of :func:`hisopt.hydraulics.laws.damper_valve_pressure_drop`
    (all with a blow-off, or all bleed only), for one vectorised call: ``positions`` their
    flow rows among the algebraic unknowns, ``kq`` [Pa s^2 m^-6], ``cracking`` [Pa] and
    ``blowoff`` [Pa s m^-3] columns ``(m, 1)`` (None for bleed-only valves)."""

    positions: NDArray[np.int_]
    kq: NDArray[np.float64]
    cracking: NDArray[np.float64] | None
    blowoff: NDArray[np.float64] | None

    def law(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """[Pa] The valves' drops beyond their laminar part at flows ``q`` ``(m, k)``, and
        [Pa s m^-3] their tangents ``d(drop)/dq`` there."""
        drop = laws.damper_valve_pressure_drop(q, self.kq, self.cracking, self.blowoff)
        return drop, laws.damper_valve_slope(q, self.kq, self.cracking, self.blowoff, drop=drop)


def damper_groups(laws_at: dict[int, tuple[float, float | None, float | None]], position: dict[int, int]) -> list[DamperGroup]:
    """The damper valves' laws ``{flow row: (K, p_c, R_b)}`` as :class:`DamperGroup` s, their
    rows placed by ``position`` (descriptor row -> algebraic index)."""
    groups = []
    for blowoff in (True, False):
        rows = [r for r, (_, p_c, _) in laws_at.items() if (p_c is not None) == blowoff]
        if rows:
            table = np.array([[laws_at[r][i] if blowoff or i == 0 else np.nan for i in range(3)] for r in rows], dtype=float)
            at = np.array([position[r] for r in rows], dtype=int)
            groups.append(DamperGroup(at, table[:, :1], table[:, 1:2] if blowoff else None, table[:, 2:] if blowoff else None))
    return groups


class NonlinearModel:
    """Right-hand side of the nonlinear model (see the module docstring), one design.

    State ``y = [X (7), V (7), w (n_d)]``: ``w`` holds the dynamic hydraulic states of the
    lumped descriptor, except that nodes with accumulators hold their stored oil volume.
    """

    def __init__(
        self,
        model: CoupledModel,
        valve_kq: float,
        tyre_liftoff: bool,
        *,
        gas_law: bool = True,
        valve_law: bool = True,
        gravity_moment: float = 0.0,
    ):
        v = model.car
        self.m = np.diag(mass_matrix(v))
        # Tyres are split off the conventional matrices so lift-off can clip their force.
        self.kt = np.diag(road_stiffness_input(v)[3:])
        self.ct = np.diag(road_damping_input(v)[3:])
        self.k_susp = stiffness_matrix(v)
        self.k_susp[3:, 3:] -= np.diag(self.kt)
        self.k_susp[1, 1] -= gravity_moment  # [N m/rad] the weight's moment as the body rolls
        self.gas_law = gas_law
        self.c_susp = damping_matrix(v)
        self.c_susp[3:, 3:] -= np.diag(self.ct)
        self.f_static = v.static_corner_loads(G_MPS2)
        self.tyre_liftoff = tyre_liftoff

        self.valve_kq = valve_kq
        self.dampers: list[DamperGroup] = []
        if model.his is None:  # the reference car: no network, only the tyre nonlinearity
            self._no_network()
            return
        his = model.his
        net = his.network
        e_h, a_h = his.descriptor()
        e = single_design(np.asarray(e_h), 1, "hydraulic descriptor")
        a = single_design(np.asarray(a_h), 2, "hydraulic descriptor").copy()
        n_inc = single_design(np.asarray(his.incidence), 2, "cylinder incidence")
        self.acc = accumulators(his)
        kq_row = np.zeros(net.size)  # quadratic coefficient of each valve flow row
        laws_at: dict[int, tuple[float, float | None, float | None]] = {}  # damper valves: flow row -> (K, p_c, R_b)
        for k, _, rows in net.valves():
            if not valve_law:  # every valve at the equivalent resistance the model was built with
                continue
            if k in his.values.damper:  # a damper valve: its law, its laminar part in A
                r_lam, kq, p_c, r_b = (None if v is None else _single(v, "damper valve parameter") for v in his.values.damper[k])
                assert r_lam is not None and kq is not None
                a[rows[2], rows[2]] += _single(his.values.resistance[k], "damper valve resistance") - r_lam
                laws_at[rows[2]] = (kq, p_c, r_b)
            elif k in his.values.orifice:  # an orifice: its own law, its laminar part in A
                r_lam, kq = (_single(v, "orifice parameter") for v in his.values.orifice[k])
                a[rows[2], rows[2]] += _single(his.values.resistance[k], "orifice resistance") - r_lam
                kq_row[rows[2]] = kq
            else:
                kq_row[rows[2]] = valve_kq
        self.dyn, self.alg = np.flatnonzero(net.dynamic), np.flatnonzero(~net.dynamic)
        self.n_h = e.size
        self.coupling = net.injection @ n_inc @ stroke_matrix(v)  # node inflow per velocity
        self.a_dyn = a[self.dyn]
        self.cp_dyn = self.coupling[self.dyn]
        self.e_dyn = e[self.dyn]

        # Accumulator nodes: the descriptor compliance is the accumulators' linear share
        # plus any other (linear) compliance at the node (oil, pipe ends), kept linear.
        pos = {int(r): i for i, r in enumerate(self.dyn)}
        acc_nodes = np.unique(self.acc.rows)
        self.acc_state = np.array([pos[int(r)] for r in acc_nodes], dtype=int)
        self.node_accs = [np.flatnonzero(self.acc.rows == r) for r in acc_nodes]
        other = np.array([e[r] - self.acc.compliance[k].sum() for r, k in zip(acc_nodes, self.node_accs, strict=True)])
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
            self.kq_alg = kq_row[self.alg]
            self.dampers = damper_groups(laws_at, {int(r): i for i, r in enumerate(self.alg)})
            self.flow_alg = net.is_flow[self.alg]

    def _no_network(self) -> None:
        empty = np.zeros(0)
        self.acc = Accumulators((), np.zeros(0, dtype=int), empty, empty, empty, empty)
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
        for j, (accs, c_o) in enumerate(zip(self.node_accs, self.other_compliance, strict=True)):
            if not self.gas_law:  # each accumulator at its linearised compliance
                out[j] = w[j] / (self.acc.compliance[accs].sum() + c_o)
                continue
            v0 = self.acc.v0[accs]
            if accs.size == 1 and c_o == 0.0:
                dv = np.minimum(w[j], GAS_VOLUME_LIMIT * v0[0])
                out[j] = laws.gas_pressure_rise(dv, v0[0], self.acc.p_abs0[accs[0]], self.acc.gamma[accs[0]])
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
                vol = vol + laws.gas_volume(p, *gas)
                slope = slope + laws.gas_compliance(p, *gas)
            step = (vol - w) / slope
            p = np.maximum(p - step, p_floor)
            if np.all(np.abs(step) <= 1e-12 * self.acc.p_abs0[accs].max()):
                return p
        raise ModelError("accumulator node pressure did not converge (gas volume exhausted?)")

    def gas_volume(self, p: np.ndarray, i: int) -> np.ndarray:
        """[m^3] Oil stored in accumulator ``i`` at the pressure rise ``p`` [Pa] (its gas law,
        or its linearised compliance with the gas law off)."""
        if not self.gas_law:
            return self.acc.compliance[i] * p
        return laws.gas_volume(p, self.acc.v0[i], self.acc.p_abs0[i], self.acc.gamma[i])

    def gas_compliance(self, p: Any, i: int) -> Any:
        """[m^3/Pa] Tangent compliance of accumulator ``i`` at the pressure rise ``p`` [Pa]."""
        if not self.gas_law:
            return float(self.acc.compliance[i])
        return laws.gas_compliance(p, self.acc.v0[i], self.acc.p_abs0[i], self.acc.gamma[i])

    def valve_law(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The nonlinear part of each algebraic row at the unknowns ``x`` ``(n_alg, k)`` and its
        tangent: ``K_q q |q|`` on orifice rows, a damper valve's drop beyond its laminar part
        on its rows (:func:`hisopt.hydraulics.laws.damper_valve_pressure_drop`), 0 elsewhere."""
        drop = self.kq_alg[:, None] * x * np.abs(x)
        slope = 2.0 * self.kq_alg[:, None] * np.abs(x)
        for group in self.dampers:
            drop[group.positions], slope[group.positions] = group.law(x[group.positions])
        return drop, slope

    def algebraic(self, h_dyn: np.ndarray, vel: np.ndarray) -> np.ndarray:
        """Pressures of compliance-free nodes and valve flows, ``(n_alg, k)``.

        Linear valves: one matrix product. Quadratic orifices and damper valves: Newton from
        the linear solution (each valve at its equivalent resistance), Jacobian
        ``A_aa - diag(d(drop)/dq)``, until every step is below 1e-12 of the largest pressure
        (pressure rows) or flow (flow rows) of its column.
        """
        x = self.solve_lin_d @ h_dyn + self.solve_lin_v @ vel
        if not (self.kq_alg.any() or self.dampers):
            return x
        rhs = self.a_ad @ h_dyn + self.cp_alg @ vel
        size = np.abs(x)
        scale = np.empty_like(x)
        scale[self.flow_alg] = size[self.flow_alg].max(axis=0) + 1e-30
        scale[~self.flow_alg] = size[~self.flow_alg].max(axis=0, initial=0.0) + 1e-30
        eye = np.eye(x.shape[0])[None]
        for _ in range(100):
            drop, slope = self.valve_law(x)
            resid = self.a_aa @ x + rhs - drop
            jac = self.a_aa[None] - slope.T[:, None, :] * eye
            step = np.linalg.solve(jac, resid.T[..., None])[..., 0].T
            x = x - step
            if np.all(np.abs(step) <= 1e-12 * scale):
                return x
        raise ModelError("the nonlinear valve network did not converge; check valve_kq, the damper valves and the valve layout")

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

    @property
    def linear_network(self) -> bool:
        """Whether the algebraic part (valve flows, compliance-free nodes) is linear: every
        valve at a constant resistance, so ``h`` is a fixed linear map of ``(h_dyn, V)``."""
        return not (self.alg.size and (self.kq_alg.any() or self.dampers))

    def _rate_matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``[dV/dt; dw/dt] = M_s [X; V] + M_h h_dyn`` with a linear network: ``(M_s, M_h)``
        and the wheels' inverse masses ``(4, 1)``; built once."""
        if "_rate" not in self.__dict__:
            n_d = self.dyn.size
            h_d, h_v = np.zeros((self.n_h, n_d)), np.zeros((self.n_h, 7))
            h_d[self.dyn, np.arange(n_d)] = 1.0
            if self.alg.size:
                h_d[self.alg], h_v[self.alg] = self.solve_lin_d, self.solve_lin_v
            inv_m = 1.0 / self.m[:, None]
            row = np.where(np.isin(np.arange(n_d), self.acc_state), 1.0, 1.0 / self.e_dyn)[:, None]
            m_s = np.vstack(
                [
                    np.hstack([-self.k_susp * inv_m, (-self.c_susp - self.coupling.T @ h_v) * inv_m]),
                    np.hstack([np.zeros((n_d, 7)), row * (self.a_dyn @ h_v + self.cp_dyn)]),
                ]
            )
            m_h = np.vstack([-(self.coupling.T @ h_d) * inv_m, row * (self.a_dyn @ h_d)])
            self._rate = (m_s, m_h, inv_m[3:])
        return self._rate

    def rate(self, y: np.ndarray, u: np.ndarray, du: np.ndarray) -> np.ndarray:
        """``dy/dt`` of :meth:`derivative` alone, for states ``y`` ``(n, k)``: with a linear
        network by precomputed matrices (the integrator's hot path), else through it."""
        if not self.linear_network:
            return self.derivative(y, u, du)[0]
        m_s, m_h, inv_m = self._rate_matrices()
        w = y[14:]
        h_dyn = w.copy()
        h_dyn[self.acc_state] = self.node_pressure(w[self.acc_state])
        rest = m_s @ y[:14] + m_h @ h_dyn
        rest[3:7] += self.tyre_force(y[:7], y[7:14], u, du) * inv_m
        return np.concatenate([y[7:14], rest])

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
        for j, (accs, c_o) in enumerate(zip(self.node_accs, self.other_compliance, strict=True)):
            p = h[self.dyn[self.acc_state[j]]]
            gas = np.sum([self.gas_compliance(p, int(i)) for i in accs])
            dpdw[self.acc_state[j]] = 1.0 / (c_o + gas)
        dh_dw = np.zeros((self.n_h, n_d))
        dh_dv = np.zeros((self.n_h, 7))
        dh_dw[self.dyn, np.arange(n_d)] = dpdw
        if self.alg.size:
            jac_a = self.a_aa - np.diag(self.valve_law(h[self.alg][:, None])[1][:, 0])
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
