"""The coupled car + HIS model (paper Eq. 20-23): dynamic stiffness, FRFs, state space.

``CoupledModel`` is a thin object over pure kernels: it holds a validated vehicle and an
optional hydraulic system (``None`` is the reference vehicle without HIS), both possibly
batched over designs (batch shape ``B``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from hisopt.constants import DOF_NAMES
from hisopt.errors import ModelError
from hisopt.hydraulics.circuit import HydraulicSystem
from hisopt.hydraulics.coupling import hydraulic_descriptor, stroke_impedance
from hisopt.hydraulics.elements import PipeModel
from hisopt.linalg import bmm, bsum
from hisopt.vehicle import (
    VehicleParams,
    damping_matrix,
    mass_matrix,
    road_damping_input,
    road_stiffness_input,
    stiffness_matrix,
    stroke_matrix,
)


@dataclass(frozen=True)
class StateSpace:
    """``dx/dt = A x + B0 u + B1 du/dt`` with road input ``u = z_g`` (4 wheels).

    The first 7 states are ``X`` (``DOF_NAMES``), the next 7 the velocities, then the
    hydraulic storage states. Shapes: ``a`` ``B + (n, n)``, ``b0``/``b1`` ``B + (n, 4)``.
    """

    a: np.ndarray
    b0: np.ndarray
    b1: np.ndarray
    labels: tuple[str, ...]
    kinetic_weights: np.ndarray
    """Per-state kinetic coefficients (mass, inertia, pipe inertance; 0 for displacements
    and pressures): a mode's kinetic energy is ``sum(w |x|^2)``, shape ``B + (n,)``."""

    @property
    def n_states(self) -> int:
        return self.a.shape[-1]

    def frequency_response(self, s: ArrayLike) -> np.ndarray:
        """``X(s) / z_g(s)`` by dense solve, shape ``B + (F, 7, 4)`` (reference path)."""
        s = np.asarray(s, dtype=complex)
        n = self.n_states
        lhs = s[..., None, None] * np.eye(n) - self.a[..., None, :, :]
        rhs = self.b0[..., None, :, :] + s[..., None, None] * self.b1[..., None, :, :]
        return np.linalg.solve(lhs, rhs)[..., :7, :]


@dataclass(frozen=True)
class CoupledModel:
    """7-DOF car, optionally with a HIS. ``his=None`` is the reference vehicle."""

    vehicle: VehicleParams
    his: HydraulicSystem | None = None
    pipe_model: PipeModel = "lumped"

    @property
    def mass(self) -> np.ndarray:
        return mass_matrix(self.vehicle)

    def stiffness(self) -> np.ndarray:
        """Static stiffness ``K + G^T K_his G``, shape ``B + (7, 7)`` (``D(s)`` at ``s -> 0``).

        Only meaningful for circuits whose ``D(s)`` has a finite static limit (lumped).
        """
        k = stiffness_matrix(self.vehicle)
        if self.his is None:
            return k
        # K_his = lim_{s->0} D(s): the real part at a tiny s is exact to rounding for lumped
        # circuits (resistances only add imaginary terms, inertances O(s^2)).
        g = stroke_matrix(self.vehicle)
        d0 = stroke_impedance(self.his, np.array([1e-6j]), "lumped")[..., 0, :, :].real
        return k + bmm(bmm(g.T, d0), g)

    def dynamic_stiffness(self, s: ArrayLike) -> np.ndarray:
        """``s^2 M + s C + K + G^T D(s) G``, shape ``B + (F, 7, 7)`` (paper Eq. 21)."""
        s = np.asarray(s, dtype=complex)
        sb = s[..., None, None]
        kdyn = sb**2 * self.mass + sb * damping_matrix(self.vehicle) + stiffness_matrix(self.vehicle)
        if self.his is not None:
            g = stroke_matrix(self.vehicle)
            kdyn = kdyn + bmm(bmm(g.T, stroke_impedance(self.his, s, self.pipe_model)), g)
        return kdyn

    def road_input(self, s: ArrayLike) -> np.ndarray:
        """Generalised road force per road displacement ``K_t + s C_t`` rows, ``(F, 7, 4)``."""
        s = np.asarray(s, dtype=complex)[..., None, None]
        return road_stiffness_input(self.vehicle) + s * road_damping_input(self.vehicle)

    def frequency_response(self, s: ArrayLike) -> np.ndarray:
        """``H(s) = X(s) / z_g(s)`` by direct solve of the dynamic stiffness, ``B + (F, 7, 4)``.

        Works for either pipe fidelity; this is the reference every fast path is tested on.
        """
        kdyn = self.dynamic_stiffness(s)
        rhs = np.broadcast_to(self.road_input(s), kdyn.shape[:-1] + (4,))
        return np.linalg.solve(kdyn, rhs)

    def state_space(self) -> StateSpace:
        """Exact state-space realisation of the lumped model (pipes as pi-sections).

        Builds the descriptor ``E dz/dt = A z + ...`` of ``z = [X, V, h]`` and eliminates
        the algebraic hydraulic unknowns (pressures of nodes without compliance, valve
        flows) by a batched Schur complement; shorts (``R_v = 0``) stay exact.
        """
        v = self.vehicle
        m_diag = np.diag(self.mass)
        k, c = stiffness_matrix(v), damping_matrix(v)
        b0, b1 = road_stiffness_input(v), road_damping_input(v)
        if self.his is None:
            a = np.block([[np.zeros((7, 7)), np.eye(7)], [-k / m_diag[:, None], -c / m_diag[:, None]]])
            zeros = np.zeros((7, 4))
            labels = DOF_NAMES + tuple(f"d{n}" for n in DOF_NAMES)
            weights = np.r_[np.zeros(7), m_diag]
            return StateSpace(
                a, np.vstack([zeros, b0 / m_diag[:, None]]), np.vstack([zeros, b1 / m_diag[:, None]]), labels, weights
            )

        h = hydraulic_descriptor(self.his)
        g = stroke_matrix(v)
        batch = np.broadcast_shapes(h.e.shape[:-1], h.n.shape[:-2])
        n_h = h.e.shape[-1]
        size = 14 + n_h
        coupling = bmm(bmm(h.port_map, h.n), g)  # h rows <- V: injected port flows, B + (n_h, 7)
        a = np.zeros(batch + (size, size))
        a[..., :7, 7:14] = np.eye(7)
        a[..., 7:14, :7] = -k
        a[..., 7:14, 7:14] = -c
        a[..., 7:14, 14:] = -np.swapaxes(coupling, -1, -2)  # f = -G^T N^T p_port
        a[..., 14:, 7:14] = coupling
        a[..., 14:, 14:] = h.a
        e = np.concatenate(
            [np.ones(batch + (7,)), np.broadcast_to(m_diag, batch + (7,)), np.broadcast_to(h.e, batch + (n_h,))],
            axis=-1,
        )
        bb0 = np.zeros((size, 4))
        bb1 = np.zeros((size, 4))
        bb0[7:14], bb1[7:14] = b0, b1

        dyn = np.concatenate([np.ones(14, dtype=bool), h.dynamic])
        alg = ~dyn
        a_dd = a[..., dyn, :][..., :, dyn]
        if alg.any():
            a_aa = a[..., alg, :][..., :, alg]
            a_ad = a[..., alg, :][..., :, dyn]
            a_da = a[..., dyn, :][..., :, alg]
            try:
                a_dd = a_dd - bmm(a_da, np.linalg.solve(a_aa, a_ad))
            except np.linalg.LinAlgError as exc:
                raise ModelError("the hydraulic network has an algebraic loop with no resistance") from exc
        e_d = e[..., dyn]
        if np.any(e_d <= 0):
            raise ModelError("a hydraulic storage element has zero compliance or inertance")
        a_ss = a_dd / e_d[..., :, None]
        b0_ss, b1_ss = bb0[dyn] / e_d[..., :, None], bb1[dyn] / e_d[..., :, None]
        labels = DOF_NAMES + tuple(f"d{n}" for n in DOF_NAMES) + tuple(l for l, d in zip(h.labels, h.dynamic) if d)
        is_flow = np.array([False] * 14 + [lab.split(":", 1)[1].startswith("q[") for lab in h.labels])
        weights = np.where(is_flow, e, 0.0)
        weights[..., 7:14] = m_diag
        weights = weights[..., dyn]

        # Each closed circuit conserves fluid volume: sum_i C_i p_i = 1^T N_c G X. Eliminating
        # one pressure per circuit removes that conserved (zero-eigenvalue) mode, giving a
        # minimal realisation with a well-conditioned eigenvector basis.
        circuit = np.concatenate([np.full(14, -1), h.circuit])[dyn]
        is_pressure = np.concatenate([np.zeros(14, dtype=bool), ~is_flow[14:]])[dyn]
        size_d = dyn.sum()
        t = np.broadcast_to(np.eye(size_d), batch + (size_d, size_d)).copy()
        keep = np.ones(size_d, dtype=bool)
        for c in range(len(self.his.circuits)):
            nodes = np.flatnonzero(is_pressure & (circuit == c))
            r = nodes[0]
            ports = h.port_circuit == c
            volume_per_x = bmm(bsum(h.n[..., ports, :], axis=-2)[..., None, :], g)[..., 0, :]  # B + (7,)
            t[..., r, :] = 0.0
            t[..., r, :7] = volume_per_x / e_d[..., r, None]
            t[..., r, nodes[1:]] = -e_d[..., nodes[1:]] / e_d[..., r, None]
            keep[r] = False
        return StateSpace(
            bmm(a_ss[..., keep, :], t[..., :, keep]),
            b0_ss[..., keep, :],
            b1_ss[..., keep, :],
            tuple(l for l, k in zip(labels, keep) if k),
            weights[..., keep],
        )
