"""Coupling of the HIS circuits to the 7-DOF car (paper Eq. 15-21, DESIGN section 2).

Port flows ``q = N G dX/dt`` enter the circuits; the fluid acts on the strokes with
``f_delta = -N^T p_port``. In the frequency domain this adds ``G^T D(s) G`` with
``D(s) = s N^T Z_port(s) N`` to the car's dynamic stiffness; in the time domain the lumped
network's descriptor states join the mechanical ones.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from hisopt.hydraulics.circuit import HydraulicSystem, lumped_descriptor, port_impedance
from hisopt.hydraulics.elements import PipeModel
from hisopt.linalg import bmm


def stroke_impedance(system: HydraulicSystem, s: ArrayLike, model: PipeModel = "lumped") -> np.ndarray:
    """``D(s) = s N^T Z_port(s) N``: force per stroke displacement, shape ``B + (F, 4, 4)``.

    Parameters
    ----------
    system : the HIS, batch shape ``B``
    s : [rad/s] Laplace variable, shape ``(F,)`` or ``B + (F,)``
    model : pipe fidelity
    """
    s = np.asarray(s, dtype=complex)
    n_all = system.incidence()
    total = 0.0
    start = 0
    for circuit in system.circuits:
        n = n_all[..., start : start + len(circuit.ports), :][..., None, :, :]
        start += len(circuit.ports)
        z = port_impedance(circuit, s, model)
        total = total + bmm(bmm(np.swapaxes(n, -1, -2), z), n)
    return s[..., None, None] * total


@dataclass(frozen=True)
class HydraulicDescriptor:
    """All circuits' lumped descriptors stacked block-diagonally (see ``lumped_descriptor``).

    ``port_map`` (``n_h x n_ports``) picks port pressures from ``h``; ``n`` is the port
    incidence ``B + (n_ports, 4)``; ``circuit`` gives each state's circuit index and
    ``port_circuit`` each port's.
    """

    e: np.ndarray
    a: np.ndarray
    port_map: np.ndarray
    dynamic: np.ndarray
    labels: tuple[str, ...]
    n: np.ndarray
    circuit: np.ndarray
    port_circuit: np.ndarray


def hydraulic_descriptor(system: HydraulicSystem) -> HydraulicDescriptor:
    """Stack the circuits' lumped descriptors into one block-diagonal network."""
    parts = [lumped_descriptor(c) for c in system.circuits]
    batch = np.broadcast_shapes(*(p.e.shape[:-1] for p in parts))
    size = sum(p.e.shape[-1] for p in parts)
    n_ports = sum(p.p.shape[1] for p in parts)
    e = np.zeros(batch + (size,))
    a = np.zeros(batch + (size, size))
    port_map = np.zeros((size, n_ports))
    i = k = 0
    for part in parts:
        m, q = part.e.shape[-1], part.p.shape[1]
        e[..., i : i + m] = part.e
        a[..., i : i + m, i : i + m] = part.a
        port_map[i : i + m, k : k + q] = part.p
        i, k = i + m, k + q
    labels = tuple(
        f"{c.name}:{label}" for c, part in zip(system.circuits, parts) for label in part.labels
    )
    dynamic = np.concatenate([p.dynamic for p in parts])
    circuit = np.concatenate([np.full(p.e.shape[-1], i) for i, p in enumerate(parts)])
    port_circuit = np.concatenate([np.full(p.p.shape[1], i) for i, p in enumerate(parts)])
    return HydraulicDescriptor(e, a, port_map, dynamic, labels, system.incidence(), circuit, port_circuit)
