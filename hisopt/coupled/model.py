"""The coupled car + HIS model (paper Eq. 20-23): dynamic stiffness, FRFs, state space.

``CoupledModel`` is a thin object over pure kernels: it holds a validated vehicle and an
optional hydraulic system (``None`` is the reference vehicle without HIS), both possibly
batched over designs (batch shape ``B``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from hisopt.arguments import of_type
from hisopt.constants import DOF_NAMES, G_MPS2
from hisopt.errors import ModelError
from hisopt.hydraulics import backend as bk
from hisopt.hydraulics.coupling import HydraulicSystem
from hisopt.hydraulics.network import PipeModel
from hisopt.hydraulics.realisation import Descriptor, Realisation, realise
from hisopt.hydraulics.shorts import singular_shorts
from hisopt.linalg import bsum
from hisopt.vehicle import (
    VehicleParams,
    at_frequencies,
    damping_matrix,
    dynamic_stiffness_matrix,
    mass_matrix,
    road_damping_input,
    road_stiffness_input,
    stiffness_matrix,
    stroke_matrix,
)
from hisopt.vehicle.batch import VehicleBatch


def coupled_stiffness(car: Any, vehicle: VehicleParams | VehicleBatch, stroke: Any) -> Any:
    """``car + G^T stroke G``: a car matrix with the HIS's stroke stiffness acting through ``G``.

    ``K + G^T K_his G`` (static) and ``s^2 M + s C + K + G^T D(s) G`` (dynamic, paper Eq. 21)
    of the numpy model and of the CasADi model (:mod:`hisopt.optim.gradient.casadi_model`).

    Parameters
    ----------
    car : np.ndarray
        [N/m, N m/rad] the car's matrix, numpy ``(..., 7, 7)``
    vehicle : VehicleParams | VehicleBatch
        the car (its stroke map ``G``), or a batch of cars (``G`` per design, meeting a
        ``stroke`` with a frequency axis as ``B + (1, 4, 7)``)
    stroke : np.ndarray or casadi matrix
        [N/m] the HIS's 4 x 4 stroke stiffness: numpy ``B + (..., 4, 4)`` (batched) or a
        CasADi matrix (or :class:`~hisopt.hydraulics.backend.Complex` pair)

    Returns
    -------
    np.ndarray or casadi matrix
        numpy ``B + (..., 7, 7)``, or a CasADi matrix when ``stroke`` is one
    """
    g = stroke_matrix(vehicle)
    if isinstance(vehicle, VehicleBatch) and np.ndim(stroke) > g.ndim:  # a dynamic stiffness: B + (F, 4, 4)
        g = at_frequencies(g, vehicle)
    return car + bk.matmul(bk.matmul(bk.transpose(g), stroke), g)


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
    realisation: Realisation | None = None
    """How the states map back to every unknown of the coupled descriptor (``None`` without
    HIS: the states are the unknowns): ``[X, V, hydraulic unknowns]`` = ``full_map() @ x``."""

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


def gravity_stiffness(stiffness: Any, vehicle: VehicleParams | VehicleBatch, gravity_moment: bool) -> Any:
    """The static stiffness ``stiffness`` (numpy ``B + (7, 7)`` or CasADi) with the body's
    gravity moment: when the body rolls by ``phi`` about the roll axis its CG moves
    ``h_0s phi`` sideways and its weight adds ``m_s g h_0s phi``, so the roll entry is reduced
    by ``m_s g h_0s`` (docs/model.md §6.4); without ``gravity_moment``, the paper's convention,
    ``stiffness`` itself."""
    if not gravity_moment:
        return stiffness
    moment = vehicle.m_s * G_MPS2 * vehicle.h_0s
    if bk.is_casadi(stiffness):
        return stiffness - bk.assemble((7, 7), [(1, 1, moment)], like=stiffness)
    k = np.array(stiffness, dtype=float)
    k[..., 1, 1] -= moment
    return k


@dataclass(frozen=True)
class CoupledModel:
    """7-DOF car, optionally with a HIS. ``his=None`` is the reference vehicle."""

    vehicle: VehicleParams | VehicleBatch
    his: HydraulicSystem | None = None

    def __post_init__(self) -> None:
        of_type(self.vehicle, (VehicleParams, VehicleBatch), "vehicle", "a VehicleParams (a problem's spec.vehicle) or a VehicleBatch")
        if self.his is not None:
            of_type(self.his, HydraulicSystem, "his", "a HydraulicSystem (a problem's model().his) or None")

    @property
    def car(self) -> VehicleParams:
        """The one car of this model (a batch of one car is that car).

        Raises
        ------
        ModelError
            The model holds a batch of cars, which the transient quantities, the roll
            gradient and the time-domain simulation do not take yet.
        """
        if isinstance(self.vehicle, VehicleBatch) and self.vehicle.shape == (1,):
            return self.vehicle.car(0)
        if isinstance(self.vehicle, VehicleBatch):
            raise ModelError("a batch of cars reaches only the frequency-domain model so far (CoupledModel.car)")
        return self.vehicle

    @property
    def pipe_model(self) -> PipeModel:
        """Pipe fidelity of the HIS network (``"lumped"`` without HIS)."""
        return "lumped" if self.his is None else self.his.network.fidelity

    @property
    def mass(self) -> np.ndarray:
        return mass_matrix(self.vehicle)

    def stiffness(self) -> np.ndarray:
        """Static stiffness ``K + G^T K_his G``, shape ``B + (7, 7)`` (``D(s)`` at ``s -> 0``)."""
        k = stiffness_matrix(self.vehicle)
        if self.his is None:
            return k
        return coupled_stiffness(k, self.vehicle, self.his.static_stiffness())

    def dynamic_stiffness(self, s: ArrayLike) -> np.ndarray:
        """``s^2 M + s C + K + G^T D(s) G``, shape ``B + (F, 7, 7)`` (paper Eq. 21)."""
        s = np.asarray(s, dtype=complex)
        kdyn = dynamic_stiffness_matrix(self.vehicle, s)
        if self.his is None:
            return kdyn
        return coupled_stiffness(kdyn, self.vehicle, self.his.stroke_impedance(s))

    def road_input(self, s: ArrayLike) -> np.ndarray:
        """Generalised road force per road displacement ``K_t + s C_t`` rows, ``(F, 7, 4)``."""
        s = np.asarray(s, dtype=complex)[..., None, None]
        v = self.vehicle
        return at_frequencies(road_stiffness_input(v), v) + s * at_frequencies(road_damping_input(v), v)

    def frequency_response(self, s: ArrayLike) -> np.ndarray:
        """``H(s) = X(s) / z_g(s)`` by direct solve of the dynamic stiffness, ``B + (F, 7, 4)``.

        Works for either pipe fidelity; this is the reference every fast path is tested on.
        """
        kdyn = self.dynamic_stiffness(s)
        rhs = np.broadcast_to(self.road_input(s), kdyn.shape[:-1] + (4,))
        return np.linalg.solve(kdyn, rhs)

    def accumulator_response(self, s: ArrayLike, h_x: np.ndarray) -> np.ndarray:
        """[m^3/m] Each accumulator's oil volume per wheel input, ``B + (F, n_accumulators, 4)``,
        from the motion ``h_x = X / z_g`` (:meth:`frequency_response`) by direct solve, either
        pipe fidelity: the compliance times the node pressure the port flows ``s N G X`` raise
        (docs/model.md §16.9)."""
        n_acc = 0 if self.his is None else len(self.his.network.accumulators())
        return self.hydraulic_response(s, h_x)[..., :n_acc, :]

    def hydraulic_response(self, s: ArrayLike, h_x: np.ndarray) -> np.ndarray:
        """The hydraulic outputs per wheel input by direct solve, either pipe fidelity,
        ``B + (F, n_accumulators + n_valves + n_ports, 4)``: each accumulator's oil volume
        [m^3/m], then the flow through each nonlinear valve [m^3/s/m] (in element order,
        :meth:`~hisopt.hydraulics.network.Network.flow_valves`), then each port's (chamber's)
        pressure [Pa/m], from the motion
        ``h_x = X / z_g``: the network's response to the port flows ``s N G X``."""
        if self.his is None:
            return np.zeros(np.shape(h_x)[:-2] + (0, 4), dtype=complex)
        s = np.asarray(s, dtype=complex)
        net = self.his.network
        g = at_frequencies(stroke_matrix(self.vehicle), self.vehicle)
        flows = s[..., None, None] * (np.asarray(self.his.incidence)[..., None, :, :] @ g @ h_x)  # (.., F, ports, 4)
        rows = [row for _, _, row in net.accumulators()] + [rows[2] for _, _, rows in net.flow_valves()] + [int(r) for r in net.port_rows]
        unknowns = self.his.unknowns_per_port_flow(s, rows) @ flows
        n_acc = len(net.accumulators())
        volumes = self.his.accumulator_compliances()[..., None, :, None] * unknowns[..., :n_acc, :]
        return np.concatenate([volumes, unknowns[..., n_acc:, :]], axis=-2)

    def accumulator_states(self, ss: StateSpace) -> np.ndarray:
        """[m^3] Each accumulator's oil volume from the states of ``ss`` (this model's
        :meth:`state_space`), ``B + (n_accumulators, n_states)``: its compliance times its
        node pressure's row of the realisation's map back to the unknowns (docs/model.md §16.9)."""
        n_acc = 0 if self.his is None else len(self.his.network.accumulators())
        return self.hydraulic_states(ss)[..., :n_acc, :]

    def hydraulic_states(self, ss: StateSpace) -> np.ndarray:
        """The hydraulic outputs from the states of ``ss`` (this model's :meth:`state_space`),
        ``B + (n_accumulators + n_valves + n_ports, n_states)``, rows of the realisation's map
        back to the unknowns: each accumulator's oil volume [m^3] (its compliance times its node
        pressure, docs/model.md §16.9), then each nonlinear valve's flow [m^3/s] (0 for a valve
        a short leaves joining a node to itself: no pressure drives it), then each port's
        (chamber's) pressure [Pa]."""
        if self.his is None or ss.realisation is None:
            return np.zeros(ss.a.shape[:-2] + (0, ss.a.shape[-1]))
        lumped = self if self.pipe_model == "lumped" else CoupledModel(self.vehicle, self.his.lumped())
        his = lumped.groups()[0][1].his  # the network the realisation was built on (lumped, shorts merged)
        assert his is not None
        full = ss.realisation.full_map()
        rows = [14 + row for _, _, row in his.network.accumulators()]
        volumes = his.accumulator_compliances()[..., :, None] * full[..., rows, :]
        # element indices through the original network: this model's may be contracted already
        origin = his.origin if his.origin is not None else tuple(range(len(his.network.elements)))
        where = {k: i for i, k in enumerate(origin)}
        own = self.his.origin if self.his.origin is not None else tuple(range(len(self.his.network.elements)))
        flows = [
            full[..., 14 + his.network.element_rows[where[own[k]]][2], :] if own[k] in where else np.zeros(full.shape[:-2] + (full.shape[-1],))
            for k, _, _ in self.his.network.flow_valves()
        ]
        ports = full[..., [14 + int(r) for r in his.network.port_rows], :]  # the chambers' pressures: ports survive a contraction
        return np.concatenate([volumes, *(f[..., None, :] for f in flows), ports], axis=-2)

    def descriptor(self) -> Descriptor:
        """The coupled lumped model ``diag(e) dz/dt = A z + B0 u + B1 du/dt``, ``z = [X, V, h]``.

        Port flows ``q = N G V`` enter the network, the fluid acts on the car with
        ``-G^T N^T p_port``; each circuit's oil volume is an invariant (docs/model.md §3.8).
        """
        if self.his is None:
            raise ModelError("the car without HIS has no hydraulic descriptor")
        v = self.vehicle
        net = self.his.network
        m_diag = np.diagonal(self.mass, axis1=-2, axis2=-1)
        e_h, a_h = self.his.descriptor()
        g = stroke_matrix(v)
        n_inc = np.asarray(self.his.incidence)
        batch = np.broadcast_shapes(np.shape(e_h)[:-1], n_inc.shape[:-2], g.shape[:-2])
        n_h = net.size
        size = 14 + n_h
        coupling = net.injection @ n_inc @ g  # h rows <- V: injected port flows, B + (n_h, 7)
        a = np.zeros(batch + (size, size))
        a[..., :7, 7:14] = np.eye(7)
        a[..., 7:14, :7] = -stiffness_matrix(v)
        a[..., 7:14, 7:14] = -damping_matrix(v)
        a[..., 7:14, 14:] = -np.swapaxes(coupling, -1, -2)  # f = -G^T N^T p_port
        a[..., 14:, 7:14] = coupling
        a[..., 14:, 14:] = a_h
        e = np.concatenate([np.ones(batch + (7,)), np.broadcast_to(m_diag, batch + (7,)), np.broadcast_to(e_h, batch + (n_h,))], axis=-1)
        b0 = np.zeros(g.shape[:-2] + (size, 4))
        b1 = np.zeros(g.shape[:-2] + (size, 4))
        b0[..., 7:14, :], b1[..., 7:14, :] = road_stiffness_input(v), road_damping_input(v)
        dynamic = np.concatenate([np.ones(14, dtype=bool), net.dynamic])
        invariants = []
        accumulator_rows = {row for _, _, row in net.accumulators()}
        for c in range(net.n_circuits):
            rows = net.circuit_rows(c)
            stored = rows[net.dynamic[rows] & ~net.is_flow[rows]]
            # The pivot is an accumulator's node where there is one: the largest compliance
            # (best conditioned), and the node a mirror image of the circuit maps to its own.
            with_gas = [int(r) for r in stored if int(r) in accumulator_rows]
            pivot = with_gas[0] if with_gas else int(stored[0])
            coeff = np.zeros(batch + (size,))
            coeff[..., 14 + stored] = e[..., 14 + stored]
            # (B, 1, 4) @ (4, 7): one small product per design, the same in any batch
            coeff[..., :7] = -(bsum(n_inc[..., net.port_circuit == c, :], axis=-2)[..., None, :] @ g)[..., 0, :]
            invariants.append((14 + pivot, coeff))
        labels = DOF_NAMES + tuple(f"d{n}" for n in DOF_NAMES) + net.labels
        return Descriptor(e, a, b0, b1, dynamic, tuple(invariants), labels)

    def state_space(self) -> StateSpace:
        """Exact minimal state-space realisation of the lumped model (pipes as pi-sections).

        Algebraic hydraulic unknowns (pressures of nodes without compliance, valve flows) are
        eliminated by a batched Schur complement and one pressure per closed circuit by its
        volume balance (:mod:`hisopt.hydraulics.realisation`); shorts (``R_v = 0``) stay exact:
        a short between two storage nodes merges them, which needs every design of the batch
        to share its pattern of shorts (:meth:`groups` splits a batch). Computed once per
        model: the road channels and the roll step response of a batch share it.
        """
        cached = self.__dict__.get("_state_space")
        if cached is None:
            cached = self._realised_state_space()
            object.__setattr__(self, "_state_space", cached)  # a frozen model: its realisation never changes
        return cached

    def _realised_state_space(self) -> StateSpace:
        v = self.vehicle
        m_diag = np.diagonal(self.mass, axis1=-2, axis2=-1)
        if self.his is None:
            return _state_space_without_his(v, m_diag)
        if self.his.network.fidelity != "lumped":
            return CoupledModel(self.vehicle, self.his.lumped()).state_space()
        groups = self.groups()
        if len(groups) > 1:
            raise ModelError("designs of this batch short different valves; take CoupledModel.groups() one at a time")
        model = groups[0][1]
        d = model.descriptor()
        r = realise(d)
        is_flow = np.concatenate([np.zeros(14, dtype=bool), model.his.network.is_flow])  # type: ignore[union-attr]
        weights = np.array(np.broadcast_to(np.where(is_flow, d.e, 0.0), np.broadcast_shapes(d.e.shape, m_diag.shape[:-1] + (1,))))
        weights[..., 7:14] = m_diag
        return StateSpace(r.a, r.b0, r.b1, r.labels, weights[..., r.kept], r)

    def subset(self, rows: np.ndarray) -> CoupledModel:
        """The designs ``rows`` (indices or a boolean mask) of a batch of models."""
        return CoupledModel(_rows(self.vehicle, rows), None if self.his is None else self.his.subset(rows))

    def groups(self) -> list[tuple[np.ndarray, CoupledModel]]:
        """The batch split by the valves each design shorts (``R = 0``): ``(rows, model)`` pairs
        whose models have the shorted valves merged away (one group when none is shorted)."""
        if self.his is None:  # the car without circuits: one group of its cars
            return [(np.arange(int(np.prod(self.vehicle.shape)) if isinstance(self.vehicle, VehicleBatch) else 1), self)]
        if self.his.network.fidelity != "lumped":
            return [(np.arange(int(np.prod(self.his.batch_shape))), self)]
        if not self.his.network.valves():
            return [(np.arange(int(np.prod(self.his.batch_shape))), self)]
        net = self.his.network
        valves = [k for k, _, _ in net.valves()]
        flat = self.his.shorted_valves().reshape(-1, len(valves))
        if not flat.any():
            return [(np.arange(flat.shape[0]), self)]
        patterns, inverse = np.unique(flat, axis=0, return_inverse=True)
        merges = [singular_shorts(net, frozenset(k for k, short in zip(valves, p, strict=True) if short)) for p in patterns]
        keys = sorted(set(merges), key=sorted)
        if keys == [frozenset()]:
            return [(np.arange(flat.shape[0]), self)]
        out = []
        for key in keys:
            rows = np.flatnonzero(np.isin(inverse.ravel(), [i for i, m in enumerate(merges) if m == key]))
            his = self.his.subset(rows) if len(keys) > 1 else self.his
            vehicle = _rows(self.vehicle, rows) if len(keys) > 1 else self.vehicle
            out.append((rows, CoupledModel(vehicle, his.contracted(key) if key else his)))
        return out


def _rows(vehicle: VehicleParams | VehicleBatch, rows: np.ndarray) -> VehicleParams | VehicleBatch:
    """The cars of designs ``rows``: one car stays itself; a batch keeps those rows."""
    return vehicle if isinstance(vehicle, VehicleParams) else vehicle.rows(rows)


def _state_space_without_his(v: VehicleParams | VehicleBatch, m_diag: np.ndarray) -> StateSpace:
    """The car alone: ``x = [X, V]``, ``A = [0, I; -M^-1 K, -M^-1 C]``, batch shape of ``v``."""
    k, c = stiffness_matrix(v), damping_matrix(v)
    batch = m_diag.shape[:-1]
    a = np.zeros(batch + (14, 14))
    a[..., :7, 7:] = np.eye(7)
    a[..., 7:, :7], a[..., 7:, 7:] = -k / m_diag[..., :, None], -c / m_diag[..., :, None]
    b0, b1 = np.zeros(batch + (14, 4)), np.zeros(batch + (14, 4))
    b0[..., 7:, :], b1[..., 7:, :] = road_stiffness_input(v) / m_diag[..., :, None], road_damping_input(v) / m_diag[..., :, None]
    weights = np.concatenate([np.zeros(batch + (7,)), m_diag], axis=-1)
    return StateSpace(a, b0, b1, DOF_NAMES + tuple(f"d{n}" for n in DOF_NAMES), weights)
