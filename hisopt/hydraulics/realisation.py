"""From a descriptor system to a minimal state space, and back (docs/model.md §3.8).

The coupled car + lumped HIS is a descriptor system ``diag(e) dz/dt = A z + B0 u + B1 du/dt``
whose unknowns ``z`` are of two kinds: *dynamic* ones with storage (``e > 0``: positions,
velocities, pressures of nodes with a compliance, pipe flows) and *algebraic* ones (``e = 0``:
pressures of nodes without compliance, valve flows). Two exact reductions give a minimal
state space:

1. **Algebraic elimination.** The algebraic rows ``0 = A_aa z_a + A_ad z_d`` (no input enters
   them) give ``z_a = S z_d`` with ``S = -A_aa^-1 A_ad``, a Schur complement
   ``A_dd + A_da S``; a zero-resistance valve between two storage nodes would make ``A_aa``
   singular and is contracted beforehand (:func:`hisopt.hydraulics.shorts.contract_shorts`).
2. **Invariant elimination.** A closed circuit conserves its oil: ``c^T z_d = 0`` with ``c``
   the compliances on its pressures and minus the volume its ports displace per unit
   position. Each invariant's pivot state ``z_r = -(1/c_r) sum_{j != r} c_j z_j`` is
   dropped: ``z_d = T x``. The zero eigenvalue the invariant would leave is gone, and the
   eigenvector basis stays well conditioned.

The inverse, used by the time domain to report every pressure and flow, is ``z_d = T x`` and
``z_a = S z_d``. All arrays are batched over designs (leading axes ``B``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hisopt.errors import ModelError


@dataclass(frozen=True)
class Descriptor:
    """``diag(e) dz/dt = a z + b0 u + b1 du/dt`` with structure.

    Attributes
    ----------
    e : np.ndarray
        storage coefficients, ``B + (n,)`` (0 on algebraic unknowns)
    a : np.ndarray
        ``B + (n, n)``
    b0, b1 : np.ndarray
        input maps, ``(n, m)`` or ``B + (n, m)``; zero on algebraic rows
    dynamic : np.ndarray
        [-] unknowns with storage, ``(n,)``
    invariants : tuple[tuple[int, np.ndarray], ...]
        per conserved quantity ``(pivot, c)``: unknown index of the state to drop
        and the coefficients ``c`` over all unknowns, ``B + (n,)`` (zero on algebraic ones)
    labels : tuple[str, ...]
        name per unknown
    """

    e: np.ndarray
    a: np.ndarray
    b0: np.ndarray
    b1: np.ndarray
    dynamic: np.ndarray
    invariants: tuple[tuple[int, np.ndarray], ...]
    labels: tuple[str, ...]


@dataclass(frozen=True)
class Realisation:
    """A minimal state space ``dx/dt = a x + b0 u + b1 du/dt`` and the way back to ``z``.

    Attributes
    ----------
    a : np.ndarray
        ``B + (n_x, n_x)``; ``b0``, ``b1``: ``B + (n_x, m)``
    labels : tuple[str, ...]
        the kept unknowns' labels, ``(n_x,)``
    kept : np.ndarray
        unknown index of each state, ``(n_x,)``
    expand : np.ndarray
        ``T``, dynamic unknowns from states, ``B + (n_d, n_x)``
    recover : np.ndarray
        ``S``, algebraic unknowns from dynamic ones, ``B + (n_a, n_d)``
    dynamic_index, algebraic_index : np.ndarray
        unknown indices of the dynamic and algebraic unknowns
    """

    a: np.ndarray
    b0: np.ndarray
    b1: np.ndarray
    labels: tuple[str, ...]
    kept: np.ndarray
    expand: np.ndarray
    recover: np.ndarray
    dynamic_index: np.ndarray
    algebraic_index: np.ndarray

    def full_map(self) -> np.ndarray:
        """Every unknown from the states: ``z = F x``, ``B + (n, n_x)``."""
        n = self.dynamic_index.size + self.algebraic_index.size
        batch = self.expand.shape[:-2]
        out = np.zeros(batch + (n, self.a.shape[-1]))
        out[..., self.dynamic_index, :] = self.expand
        if self.algebraic_index.size:
            out[..., self.algebraic_index, :] = self.recover @ self.expand
        return out


def realise(d: Descriptor) -> Realisation:
    """The minimal realisation of a descriptor (module docstring).

    Raises
    ------
    ModelError
        The algebraic part is singular (a loop of zero resistance) or a storage coefficient
        is not positive.
    """
    dyn = np.flatnonzero(d.dynamic)
    alg = np.flatnonzero(~d.dynamic)
    batch = d.a.shape[:-2]
    e_d = d.e[..., dyn]
    if np.any(~(e_d > 0)):
        raise ModelError("a hydraulic storage element has zero compliance or inertance")
    position = {int(u): i for i, u in enumerate(dyn)}
    keep = np.ones(dyn.size, dtype=bool)
    pivot_rows = {}
    for pivot, c in d.invariants:
        r = position[pivot]
        c_d = np.broadcast_to(c, batch + c.shape[-1:])[..., dyn]
        row = -c_d / c_d[..., r, None]
        row[..., r] = 0.0
        pivot_rows[r] = row
        keep[r] = False
    rows = np.flatnonzero(keep)
    kept = dyn[rows]
    # Only the kept states' rows are needed: a pivot's derivative follows from its invariant.
    a_kd = d.a[..., kept[:, None], dyn[None, :]]
    recover = np.zeros(batch + (alg.size, dyn.size))
    if alg.size:
        a_aa = d.a[..., alg[:, None], alg[None, :]]
        a_ad = d.a[..., alg[:, None], dyn[None, :]]
        try:
            recover = -np.linalg.solve(a_aa, a_ad)
        except np.linalg.LinAlgError as exc:
            raise ModelError("the hydraulic network has an algebraic loop with no resistance") from exc
        a_kd = a_kd + d.a[..., kept[:, None], alg[None, :]] @ recover
    e_k = e_d[..., rows, None]
    a_ks = a_kd / e_k
    b0 = np.broadcast_to(d.b0, batch + d.b0.shape[-2:])[..., kept, :] / e_k
    b1 = np.broadcast_to(d.b1, batch + d.b1.shape[-2:])[..., kept, :] / e_k
    # T: the identity on the kept states, the invariants' rows on the pivots.
    t = np.zeros(batch + (dyn.size, rows.size))
    t[..., rows, np.arange(rows.size)] = 1.0
    for r, row in pivot_rows.items():
        t[..., r, :] = row[..., rows]
    # a_ks @ t, written as the kept block plus one outer product per eliminated pivot
    # (t is the identity but for the pivots' rows): the same sums, far fewer operations.
    a_kept = a_ks[..., :, rows]
    for r in pivot_rows:
        a_kept = a_kept + a_ks[..., :, r][..., :, None] * t[..., r, None, :]
    return Realisation(
        a=a_kept,
        b0=b0,
        b1=b1,
        labels=tuple(d.labels[u] for u, k in zip(dyn, keep, strict=True) if k),
        kept=dyn[keep],
        expand=t,
        recover=recover,
        dynamic_index=dyn,
        algebraic_index=alg,
    )
