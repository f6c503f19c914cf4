"""A HIS for a batch of designs and its coupling to the strokes (paper Eq. 15-21).

:class:`HydraulicSystem` pairs a compiled :class:`~hisopt.hydraulics.network.Network` with
parameter values (floats, numpy arrays of batch shape ``B``, or CasADi expressions) and gives
what the car sees of it: port flows ``q = N d(delta)/dt`` enter the circuits and the fluid
pushes back on the strokes with ``f_delta = -N^T p_port``, so the strokes feel

    D(s) = s N^T Z_port(s) N            (force per stroke displacement, 4 x 4)

and statically ``K_his = lim_{s->0} D(s)``; docs/model.md §3.7.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from hisopt.hydraulics import backend as bk
from hisopt.hydraulics import laws
from hisopt.hydraulics import network as nw
from hisopt.hydraulics.network import ElementValues, Network
from hisopt.hydraulics.shorts import contracted_layout

AXLE_OF_WHEEL = ("front", "front", "rear", "rear")


def wheel_areas(params: Mapping[str, Any]) -> tuple[Any, Any]:
    """[m^2] Top and bottom chamber areas per wheel from ``dA``, ``lam`` (front axle) and
    ``dA_rear``, ``lam_rear`` (rear axle; absent: equal to the front).

    numpy: arrays of shape ``B + (4,)``; CasADi: lists of four expressions.
    """
    front = laws.cylinder_areas(params["dA"], params["lam"])
    rear = laws.cylinder_areas(params.get("dA_rear", params["dA"]), params.get("lam_rear", params["lam"]))
    per_wheel = (front, front, rear, rear)
    top = [w[0] for w in per_wheel]
    bottom = [w[1] for w in per_wheel]
    if any(bk.is_casadi(v) for v in top + bottom):
        return top, bottom
    return np.stack(np.broadcast_arrays(*top), axis=-1), np.stack(np.broadcast_arrays(*bottom), axis=-1)


@dataclass(frozen=True)
class HydraulicSystem:
    """A network with parameter values for a batch of designs (or one symbolic design).

    Attributes
    ----------
    network : Network
        the compiled structure
    params : Mapping[str, Any]
        every parameter the layout refers to, the fluid (``rho``, ``mu``, ``beta``) and
        the cylinder geometry (``dA``, ``lam``, ``dA_rear``, ``lam_rear``)
    """

    network: Network
    params: Mapping[str, Any]
    static_rise: Any = None
    """[Pa] Static pressure rise of each circuit above its precharge under a payload (numpy
    ``B + (n_circuits,)`` or a CasADi column; :func:`hisopt.coupled.payload.static_pressure_rise`):
    the accumulators are linearised there. ``None``: at the precharge."""
    static_pressure: Any = None
    """[Pa] Absolute static pressure of each circuit of a charged HIS (numpy
    ``B + (n_circuits,)`` or a CasADi column; :mod:`hisopt.coupled.charge`): the accumulators
    are linearised there, each holding its gas at the oil's temperature. ``None``: the
    accumulators at their precharge (plus ``static_rise``)."""
    origin: tuple[int, ...] | None = None
    """Per element of :attr:`network`, its element index in the network this one was
    contracted from (:meth:`contracted`); None: this network is the original."""

    @cached_property
    def values(self) -> ElementValues:
        """The constitutive laws applied to every element."""
        return nw.element_values(self.network, self.params, self.static_rise, self.static_pressure, self.origin)

    @cached_property
    def areas(self) -> tuple[Any, Any]:
        """[m^2] Top and bottom chamber areas per wheel (:func:`wheel_areas`)."""
        return wheel_areas(self.params)

    @cached_property
    def incidence(self) -> Any:
        """``N`` [m^2]: signed chamber areas, ports x wheels (numpy ``B + (n_ports, 4)``)."""
        return nw.incidence(self.network, *self.areas)

    @cached_property
    def batch_shape(self) -> tuple[int, ...]:
        """Batch shape ``B`` of the parameter values (numpy): of every array among them, not
        only the cylinders' (whose sizes may be fixed while a valve varies)."""
        shapes = [np.shape(v) for v in self.params.values() if isinstance(v, np.ndarray)]
        return tuple(np.broadcast_shapes(np.shape(self.incidence)[:-2], *shapes))

    def port_impedance(self, s: Any) -> Any:
        """``Z_port(s)`` [Pa s m^-3] (:func:`hisopt.hydraulics.network.port_impedance`)."""
        return nw.port_impedance(self.network, self.values, s)

    def accumulator_pressures(self, s: np.ndarray) -> np.ndarray:
        """[Pa s m^-3] Each accumulator's node pressure per port flow, ``M(s)^-1 P`` at the
        accumulators' rows (numpy, either pipe fidelity): ``B + (F, n_accumulators, n_ports)``,
        zero on other circuits' ports, NaN where ``M(s)`` is singular. Times the accumulator's
        compliance it is its oil volume per port flow (docs/model.md §16.9)."""
        return self.unknowns_per_port_flow(s, [row for _, _, row in self.network.accumulators()])

    def unknowns_per_port_flow(self, s: np.ndarray, rows: list[int]) -> np.ndarray:
        """The network unknowns ``rows`` (pressures [Pa s m^-3], flows [-]) per port flow,
        ``M(s)^-1 P`` at those rows (numpy, either pipe fidelity): ``B + (F, len(rows), n_ports)``,
        zero on other circuits' ports, NaN where ``M(s)`` is singular."""
        net = self.network
        m = nw.network_matrix(net, self.values, s)
        out = np.zeros(m.shape[:-2] + (len(rows), len(net.ports)), dtype=complex)
        for circuit_rows, ports, sol in nw.circuit_solutions(net, m):
            for j, row in enumerate(rows):
                if row in circuit_rows:
                    out[..., j, ports] = sol[..., int(np.flatnonzero(circuit_rows == row)[0]), :]
        return out

    def accumulator_compliances(self) -> np.ndarray:
        """[m^3/Pa] Each accumulator's linearised compliance at the operating point, numpy
        ``B + (n_accumulators,)``."""
        shunt = self.values.shunt
        parts = [np.broadcast_to(np.asarray(shunt[k], dtype=float), self.batch_shape) for k, _, _ in self.network.accumulators()]
        return np.stack(parts, axis=-1) if parts else np.zeros(self.batch_shape + (0,))

    def stroke_impedance(self, s: Any) -> Any:
        """``D(s) = s N^T Z_port(s) N`` [N/m], numpy ``B + (F, 4, 4)`` for ``s`` of shape ``(F,)``
        or ``B + (F,)``."""
        z = self.port_impedance(s)
        n = self.incidence
        if bk.is_casadi(z):
            return s * bk.matmul(bk.matmul(n.T, z), n)
        s = np.asarray(s, dtype=complex)
        nf = np.asarray(n)[..., None, :, :]
        return s[..., None, None] * (np.swapaxes(nf, -1, -2) @ z @ nf)

    def static_stiffness(self) -> Any:
        """[N/m] ``K_his = lim_{s->0} D(s)`` (:func:`hisopt.hydraulics.network.static_stiffness`)."""
        return nw.static_stiffness(self.network, self.values, self.incidence)

    def low_frequency_damping(self) -> Any:
        """[N s/m] ``C_lf = lim_{s->0} (D(s) - K_his) / s`` of the lumped network, numpy
        ``B + (4, 4)`` (:func:`hisopt.hydraulics.network.low_frequency_damping`)."""
        lumped = self.lumped()
        return nw.low_frequency_damping(lumped.network, lumped.values, lumped.incidence)

    def descriptor(self) -> tuple[Any, Any]:
        """``(e, A)`` of the lumped network ``diag(e) dh/dt = A h + P q_port``."""
        return nw.lumped_descriptor(self.network, self.values)

    def shorted_valves(self) -> np.ndarray:
        """[-] Per design and valve, ``R = 0`` (an exact short), shape ``B + (n_valves,)``."""
        valves = self.network.valves()
        if not valves:
            return np.zeros(self.batch_shape + (0,), dtype=bool)
        r = [np.broadcast_to(np.asarray(self.values.resistance[k], dtype=float), self.batch_shape) for k, _, _ in valves]
        return np.stack(r, axis=-1) == 0.0

    def subset(self, rows: np.ndarray) -> HydraulicSystem:
        """The designs ``rows`` of a batch of shape ``(n,)``."""
        params = {k: (np.asarray(v)[rows] if np.ndim(v) else v) for k, v in self.params.items()}
        rise = self.static_rise
        if rise is not None and np.ndim(rise) > 1:
            rise = np.asarray(rise)[rows]
        pressure = self.static_pressure
        if pressure is not None and np.ndim(pressure) > 1:
            pressure = np.asarray(pressure)[rows]
        return HydraulicSystem(self.network, params, rise, pressure, self.origin)

    def contracted(self, shorted: frozenset[int]) -> HydraulicSystem:
        """The same designs with the valves ``shorted`` (element indices) merged away."""
        layout, kept = contracted_layout(self.network.layout, shorted)
        origin = kept if self.origin is None else tuple(self.origin[k] for k in kept)
        return HydraulicSystem(nw.compile_network(layout, self.network.fidelity), self.params, self.static_rise, self.static_pressure, origin)

    def lumped(self) -> HydraulicSystem:
        """The same designs with lumped (pi-section) pipes: the rational model whose state
        space places the frequency nodes of a distributed-pipe problem."""
        if self.network.fidelity == "lumped":
            return self
        return HydraulicSystem(nw.compile_network(self.network.layout, "lumped"), self.params, self.static_rise, self.static_pressure, self.origin)
