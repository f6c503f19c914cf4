"""Hydraulic circuits as data, assembled by modified nodal analysis (MNA).

A circuit is a list of elements joined at named nodes plus the cylinder-chamber ports that
push flow into it. Unknowns are the node pressures and one flow per series branch (two for a
distributed pipe), so a zero-resistance valve is an exact short, not a numerical limit.

Two assemblies share the description:

- :func:`port_impedance`: ``Z_port(s)`` batched over ``(..., n_freq)``, lumped or
  distributed pipes (paper Eq. 8-14 in nodal form).
- :func:`lumped_descriptor`: ``E dh/dt = A h + P q_port`` with ``E`` diagonal, the lumped
  network's exact rational realisation, used by the state-space model.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from hisopt.errors import ModelError
from hisopt.linalg import bmm
from hisopt.hydraulics.elements import (
    Accumulator,
    ChamberCompliance,
    Element,
    Pipe,
    PipeModel,
    Valve,
)

Chamber = Literal["top", "bottom"]


@dataclass(frozen=True)
class Port:
    """Cylinder chamber ``chamber`` of wheel ``wheel`` (0 FL, 1 FR, 2 RL, 3 RR) at ``node``."""

    node: str
    wheel: int
    chamber: Chamber

    @property
    def label(self) -> str:
        return f"{self.wheel + 1}{'t' if self.chamber == 'top' else 'b'}"


@dataclass(frozen=True)
class Circuit:
    """One closed hydraulic circuit: elements, ports and a name."""

    name: str
    elements: tuple[Element, ...]
    ports: tuple[Port, ...]

    @property
    def nodes(self) -> tuple[str, ...]:
        """Node names in first-use order (ports first, then elements)."""
        names: dict[str, None] = {}
        for p in self.ports:
            names.setdefault(p.node)
        for e in self.elements:
            for n in _element_nodes(e):
                names.setdefault(n)
        return tuple(names)


@dataclass(frozen=True)
class Cylinders:
    """Double-acting cylinders, one per wheel: top (annulus) and bottom (bore) areas.

    ``top_area``, ``bottom_area``: [m^2], shape ``(..., 4)`` (batch first, wheels last).
    """

    top_area: ArrayLike
    bottom_area: ArrayLike

    def port_area(self, port: Port) -> np.ndarray:
        """[m^2] signed area ``a``: flow out of the chamber per unit stroke extension.

        ``+A_t`` for a top chamber, ``-A_b`` for a bottom chamber (DESIGN section 2).
        """
        if port.chamber == "top":
            return np.asarray(self.top_area, dtype=float)[..., port.wheel]
        return -np.asarray(self.bottom_area, dtype=float)[..., port.wheel]


@dataclass(frozen=True)
class HydraulicSystem:
    """Cylinders plus the circuits their chambers feed."""

    cylinders: Cylinders
    circuits: tuple[Circuit, ...]

    @property
    def ports(self) -> tuple[Port, ...]:
        return tuple(p for c in self.circuits for p in c.ports)

    def incidence(self) -> np.ndarray:
        """``N``: ports x wheels matrix of signed areas, shape ``(..., n_ports, 4)``."""
        rows = []
        for port in self.ports:
            a = self.cylinders.port_area(port)
            onehot = np.zeros(4)
            onehot[port.wheel] = 1.0
            rows.append(np.asarray(a)[..., None] * onehot)
        return np.stack(np.broadcast_arrays(*rows), axis=-2)


def _element_nodes(e: Element) -> tuple[str, ...]:
    if isinstance(e, (Valve, Pipe)):
        return (e.a, e.b)
    return (e.node,)


def _bc(x: ArrayLike) -> np.ndarray:
    """Parameter array with a trailing frequency axis for broadcasting against ``s``."""
    return np.asarray(x, dtype=float)[..., None]


def _branch_count(e: Element, model: PipeModel) -> int:
    if isinstance(e, Valve):
        return 1
    if isinstance(e, Pipe):
        return 2 if model == "distributed" else 1
    return 0


def port_impedance(circuit: Circuit, s: ArrayLike, model: PipeModel = "lumped") -> np.ndarray:
    """Port impedance ``Z_port(s)``: chamber pressures per flow injected at each port.

    Parameters
    ----------
    circuit : the circuit; element parameters have batch shape ``B`` (or are scalars)
    s : [rad/s] Laplace variable, shape ``(F,)`` or ``B + (F,)``; complex allowed
    model : pipe fidelity, ``"lumped"`` (pi-section) or ``"distributed"`` (uniform line)

    Returns
    -------
    ndarray, complex, shape ``broadcast(B, s.shape[:-1]) + (F, n_ports, n_ports)``;
    NaN where the network is singular (no compliance, for example).
    """
    s = np.asarray(s, dtype=complex)
    nodes = circuit.nodes
    index = {n: i for i, n in enumerate(nodes)}
    n_nodes = len(nodes)
    n_branch = sum(_branch_count(e, model) for e in circuit.elements)
    size = n_nodes + n_branch

    # Stamp values are broadcast to one common shape before filling the matrix.
    entries: list[tuple[int, int, np.ndarray]] = []
    row = n_nodes
    for e in circuit.elements:
        if isinstance(e, (Accumulator, ChamberCompliance)):
            i = index[e.node]
            entries.append((i, i, s * _bc(e.compliance)))
        elif isinstance(e, Valve) or (isinstance(e, Pipe) and model == "lumped"):
            a, b = index[e.a], index[e.b]
            if isinstance(e, Pipe):
                half = 0.5 * s * _bc(e.compliance)
                entries += [(a, a, half), (b, b, half)]
                z = _bc(e.resistance) + s * _bc(e.inertance)
            else:
                z = _bc(e.resistance) + 0.0 * s
            entries += [(a, row, 1.0), (b, row, -1.0), (row, a, 1.0), (row, b, -1.0), (row, row, -z)]
            row += 1
        else:  # distributed pipe: two flows, two transfer-matrix rows
            a, b = index[e.a], index[e.b]
            t = e.transfer_matrix(s)
            q1, q2 = row, row + 1
            entries += [(a, q1, 1.0), (b, q2, -1.0)]
            entries += [(q1, a, t[..., 0, 0]), (q1, b, -1.0), (q1, q1, t[..., 0, 1])]
            entries += [(q2, a, t[..., 1, 0]), (q2, q1, t[..., 1, 1]), (q2, q2, -1.0)]
            row += 2

    shape = np.broadcast_shapes(s.shape, *(np.shape(v) for _, _, v in entries))
    mna = np.zeros(shape + (size, size), dtype=complex)
    for i, j, v in entries:
        mna[..., i, j] += v
    inject = np.zeros((size, len(circuit.ports)))
    for k, port in enumerate(circuit.ports):
        inject[index[port.node], k] = 1.0
    with np.errstate(all="ignore"):
        try:
            sol = np.linalg.solve(mna, np.broadcast_to(inject, shape + inject.shape))
        except np.linalg.LinAlgError:
            sol = _solve_or_nan(mna, inject, shape)
    return bmm(inject.T, sol)


def _solve_or_nan(mna: np.ndarray, rhs: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """Solve each system separately; singular ones (a circuit with no compliance) give NaN."""
    flat = mna.reshape((-1,) + mna.shape[-2:])
    out = np.full((flat.shape[0],) + rhs.shape, np.nan, dtype=complex)
    ok = np.abs(np.linalg.det(flat)) > 0
    if ok.any():
        with np.errstate(all="ignore"):
            cond = np.linalg.cond(flat[ok])
        good = np.flatnonzero(ok)[np.isfinite(cond) & (cond < 1e15)]
        if good.size:
            out[good] = np.linalg.solve(flat[good], np.broadcast_to(rhs, (good.size,) + rhs.shape))
    return out.reshape(shape + rhs.shape)


@dataclass(frozen=True)
class LumpedDescriptor:
    """Lumped network ``E dh/dt = A h + P q_port``, ``p_port = P^T h`` (``E`` diagonal).

    ``h`` stacks node pressures then branch flows. ``dynamic`` marks the states with storage
    (nodes with compliance, pipes with inertance); the rest are algebraic.

    Shapes: ``e`` ``B + (n,)`` (diagonal), ``a`` ``B + (n, n)``, ``p`` ``(n, n_ports)``.
    """

    e: np.ndarray
    a: np.ndarray
    p: np.ndarray
    dynamic: np.ndarray
    labels: tuple[str, ...]


def lumped_descriptor(circuit: Circuit) -> LumpedDescriptor:
    """Assemble the lumped network in descriptor form (pipes as pi-sections)."""
    nodes = circuit.nodes
    index = {n: i for i, n in enumerate(nodes)}
    n_nodes = len(nodes)
    branches = [e for e in circuit.elements if isinstance(e, (Valve, Pipe))]
    size = n_nodes + len(branches)
    labels = tuple(f"p[{n}]" for n in nodes) + tuple(f"q[{b.a}->{b.b}]" for b in branches)

    e_entries: list[tuple[int, np.ndarray]] = []
    a_entries: list[tuple[int, int, np.ndarray]] = []
    dynamic = np.zeros(size, dtype=bool)
    row = n_nodes
    for el in circuit.elements:
        if isinstance(el, (Accumulator, ChamberCompliance)):
            e_entries.append((index[el.node], np.asarray(el.compliance)))
            dynamic[index[el.node]] = True
            continue
        a, b = index[el.a], index[el.b]
        # Node rows: C dp/dt = injected - leaving + arriving; branch rows: L dq/dt = p_a - p_b - R q.
        a_entries += [(a, row, -1.0), (b, row, 1.0), (row, a, 1.0), (row, b, -1.0)]
        a_entries.append((row, row, -np.asarray(el.resistance, dtype=float)))
        if isinstance(el, Pipe):
            half = 0.5 * el.compliance
            e_entries += [(a, half), (b, half), (row, el.inertance)]
            dynamic[[a, b, row]] = True
        row += 1

    batch = np.broadcast_shapes(*(np.shape(v) for _, v in e_entries), *(np.shape(v) for *_, v in a_entries))
    e = np.zeros(batch + (size,))
    a_mat = np.zeros(batch + (size, size))
    for i, v in e_entries:
        e[..., i] += v
    for i, j, v in a_entries:
        a_mat[..., i, j] += v
    p = np.zeros((size, len(circuit.ports)))
    for k, port in enumerate(circuit.ports):
        p[index[port.node], k] = 1.0
    if not dynamic[:n_nodes].any():
        raise ModelError(
            f"circuit {circuit.name!r} has no compliance (accumulator, chamber or pipe): "
            "an incompressible closed circuit locks the cylinders; add an accumulator"
        )
    return LumpedDescriptor(e=e, a=a_mat, p=p, dynamic=dynamic, labels=labels)
