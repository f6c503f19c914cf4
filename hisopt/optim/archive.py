"""Archive of the non-dominated feasible designs a run has evaluated.

With four objectives most Pareto-optimal designs are found on the way and later lost from
the population (survival keeps only ``pop_size`` of them), so the front a run reports is this
archive of every feasible design ever evaluated, not the last population.

Rules (deterministic, independent of timing):

- only feasible, valid designs enter;
- a candidate is rejected when an archived design weakly dominates it (no worse in every
  objective, which includes an identical objective vector: the first design found keeps
  its place) or when an earlier candidate of the same batch does;
- archived designs dominated by an accepted candidate leave;
- members are kept in order of evaluation (their evaluation ids ascend).

Storage and search (the cost of a generation does not grow with the archive): the rows live
in buffers that double their capacity when full; a design that leaves is only flagged, and
the buffers are compacted (order kept) once flagged rows outnumber the live ones. A spatial
index groups the rows present at its last build into leaves of at most :data:`LEAF_SIZE`
designs close in objective space (sort-tile-recursive packing), each with the minimum and
maximum corner of its designs; rows appended since (the *tail*) are scanned one by one, and
the index is rebuilt once the tail is long (:func:`_tail_limit`). A candidate's dominators
can only be in leaves whose minimum corner weakly dominates it, and the designs it removes
only in leaves whose maximum corner it weakly dominates; the other leaves are skipped.
"""

from __future__ import annotations

from dataclasses import dataclass

import moocore
import numpy as np

from hisopt.evaluation.compiled import CompiledOnFirstUse


def weakly_dominates(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``out[i, j]``: ``a[i]`` is no worse than ``b[j]`` in every objective (minimisation).

    Parameters
    ----------
    a : np.ndarray
        [objective units] shape ``(m, k)``
    b : np.ndarray
        [objective units] shape ``(n, k)``

    Returns
    -------
    np.ndarray
        Boolean array of shape ``(m, n)``.
    """
    out = np.ones((len(a), len(b)), dtype=bool)
    for j in range(np.shape(a)[1]):  # one objective at a time: no (m, n, k) temporary
        out &= a[:, None, j] <= b[None, :, j]
    return out


def dominates(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``out[i, j]``: ``a[i]`` Pareto-dominates ``b[j]`` (no worse everywhere, better somewhere)."""
    return weakly_dominates(a, b) & ~weakly_dominates(b, a).T


def non_dominated_mask(f: np.ndarray) -> np.ndarray:
    """[-] Rows of ``f`` (n, k) that no other row dominates; of equal rows only the first.

    Kung's dimension sweep (moocore, ``O(n log^(k-2) n)`` time, ``O(n k)`` memory), so a
    study can merge fronts of any size. A row with a NaN compares with no other row: it is
    kept, and never removes another.
    """
    f = np.asarray(f, dtype=float)
    n = len(f)
    if n == 0 or f.shape[1] == 0:
        return np.arange(n) == 0
    comparable = ~np.isnan(f).any(axis=1)
    out = np.ones(n, dtype=bool)
    out[comparable] = moocore.is_nondominated(f[comparable], keep_weakly=False)
    return out


LEAF_SIZE = 32
"""[-] Most designs in a leaf of the archive's spatial index."""


def _tail_limit(n_indexed: int) -> int:
    """[-] Rows appended since the index was built that trigger its rebuild: a rebuild costs
    ``O(m log m)`` and the tail is scanned linearly, so it grows with the archive, slowly."""
    return max(1024, n_indexed // 32)


def build_index(f: np.ndarray, rows: np.ndarray, leaf_size: int = LEAF_SIZE) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Sort-tile-recursive leaves of the designs ``rows`` of ``f``.

    The rows are cut into ``p`` slabs by the first objective, each slab into ``p`` by the
    second, and so on (``p^k`` leaves of about ``len(rows) / p^k <= leaf_size`` designs).

    Parameters
    ----------
    f : np.ndarray
        [objective units] objectives, shape ``(n, k)``
    rows : np.ndarray
        [-] the rows of ``f`` to index, ``(m,)``
    leaf_size : int
        [-] most designs in a leaf

    Returns
    -------
    perm : np.ndarray
        [-] the rows, leaf after leaf, ``(m,)``
    starts : np.ndarray
        [-] leaf ``b`` is ``perm[starts[b]:starts[b + 1]]``, ``(n_leaves + 1,)``
    lo, hi : np.ndarray
        [objective units] each leaf's minimum and maximum corner (NaN ignored), ``(n_leaves, k)``
    """
    rows = np.asarray(rows, dtype=np.int64)
    m, k = len(rows), f.shape[1]
    if m == 0:
        return rows, np.zeros(1, dtype=np.int64), np.empty((0, k)), np.empty((0, k))
    n_leaves = -(-m // leaf_size)
    p = max(1, int(np.ceil(n_leaves ** (1.0 / k) - 1e-9)))
    fr = f[rows]
    group = np.zeros(m, dtype=np.int64)
    for t in range(k):
        order = np.lexsort((np.nan_to_num(fr[:, t], nan=np.inf), group))
        g_sorted = group[order]
        first = np.flatnonzero(np.r_[True, g_sorted[1:] != g_sorted[:-1]])
        size = np.diff(np.r_[first, m])
        member = np.repeat(np.arange(len(first)), size)
        rank = np.arange(m) - first[member]
        new = np.empty(m, dtype=np.int64)
        new[order] = member * p + rank * p // size[member]
        group = new
    order = np.argsort(group, kind="stable")
    g_sorted = group[order]
    starts = np.flatnonzero(np.r_[True, g_sorted[1:] != g_sorted[:-1]])
    perm = rows[order]
    fp = fr[order]
    with np.errstate(invalid="ignore"):
        lo = np.fmin.reduceat(fp, starts, axis=0)
        hi = np.fmax.reduceat(fp, starts, axis=0)
    return perm, np.r_[starts, m].astype(np.int64), lo, hi


def _offer(
    f: np.ndarray,
    n: int,
    alive: np.ndarray,
    n_indexed: int,
    perm: np.ndarray,
    starts: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    c: np.ndarray,
    entered: np.ndarray,
    removed: np.ndarray,
    gone: np.ndarray,
) -> int:
    """Compiled by numba. ``entered[j]``: no row of ``f[:n]`` weakly dominates ``c[j]``;
    ``removed[:count]`` (the return value): the live rows an entering candidate weakly
    dominates, each once (``gone``, all false on entry, marks them). Rows ``n_indexed:n`` are the tail, the
    others are in the leaves ``perm``/``starts`` with corners ``lo``/``hi``.

    Rows that already left are not skipped in the dominator search: one that weakly
    dominates ``c[j]`` is strictly dominated by a live row (by induction on the removals),
    which then dominates ``c[j]`` too, so the answer is the same. A comparison with NaN is
    false: such a row dominates nothing and nothing dominates it.
    """
    k = f.shape[1]
    n_leaves = starts.shape[0] - 1
    count = 0
    for j in range(c.shape[0]):
        found = False
        for i in range(n - 1, n_indexed - 1, -1):  # the tail, newest first: most dominators are recent
            below = True
            for t in range(k):
                if not f[i, t] <= c[j, t]:
                    below = False
                    break
            if below:
                found = True
                break
        if not found:
            for b in range(n_leaves - 1, -1, -1):
                inside = True
                for t in range(k):
                    if not lo[b, t] <= c[j, t]:  # NaN corner: every row has NaN there
                        inside = False
                        break
                if not inside:
                    continue
                for r in range(starts[b], starts[b + 1]):
                    i = perm[r]
                    below = True
                    for t in range(k):
                        if not f[i, t] <= c[j, t]:
                            below = False
                            break
                    if below:
                        found = True
                        break
                if found:
                    break
        entered[j] = not found
        if found:
            continue
        # no row weakly dominates c[j], so "c[j] weakly dominates" is strict domination
        for i in range(n_indexed, n):
            if alive[i] and not gone[i]:
                above = True
                for t in range(k):
                    if not c[j, t] <= f[i, t]:
                        above = False
                        break
                if above:
                    gone[i] = True
                    removed[count] = i
                    count += 1
        for b in range(n_leaves):
            inside = True
            for t in range(k):
                if not c[j, t] <= hi[b, t]:
                    inside = False
                    break
            if not inside:
                continue
            for r in range(starts[b], starts[b + 1]):
                i = perm[r]
                if alive[i] and not gone[i]:
                    above = True
                    for t in range(k):
                        if not c[j, t] <= f[i, t]:
                            above = False
                            break
                    if above:
                        gone[i] = True
                        removed[count] = i
                        count += 1
    return count


_archive_kernel = CompiledOnFirstUse(_offer)
"""The compiled archive check (compiled on first use, cached on disk)."""


def _search(
    f: np.ndarray,
    n: int,
    alive: np.ndarray,
    index: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    n_indexed: int,
    candidates: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """``(entered, removed rows)`` of candidates (mutually non-dominated) against ``f[:n]``."""
    c = np.ascontiguousarray(candidates, dtype=float)
    entered = np.empty(len(c), dtype=np.bool_)
    removed = np.empty(n, dtype=np.int64)
    gone = np.zeros(n, dtype=np.bool_)
    perm, starts, lo, hi = index
    count = _archive_kernel(f, n, alive, n_indexed, perm, starts, lo, hi, c, entered, removed, gone)
    return entered, np.sort(removed[:count])


def pareto_update(archive_f: np.ndarray, new_f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which archived designs stay and which new designs enter (module rules).

    The batch is filtered first (:func:`non_dominated_mask`); each survivor is then checked
    against the archive by a compiled search over a spatial index (module docstring) that
    stops at the first archived design weakly dominating it; only accepted candidates look
    for the designs they remove. (:class:`Archive` keeps its index between generations;
    this function builds one per call.)

    Parameters
    ----------
    archive_f : np.ndarray
        [objective units] archived objectives, shape ``(m, k)``
    new_f : np.ndarray
        [objective units] candidate objectives (feasible designs only), shape ``(n, k)``

    Returns
    -------
    keep : np.ndarray
        boolean ``(m,)``, archived designs that stay
    accept : np.ndarray
        boolean ``(n,)``, candidates that enter
    """
    new_f = np.asarray(new_f, dtype=float)
    accept = non_dominated_mask(new_f)
    keep = np.ones(len(archive_f), dtype=bool)
    if len(archive_f) and accept.any():
        a = np.ascontiguousarray(archive_f, dtype=float)
        m = len(a)
        entered, removed = _search(a, m, keep, build_index(a, np.arange(m)), m, new_f[accept])
        accept[accept] = entered
        keep[removed] = False
    return keep, accept


@dataclass(frozen=True)
class Offer:
    """What offering a batch to an :class:`Archive` does (computed, not yet applied).

    Attributes
    ----------
    removed : np.ndarray
        [-] storage rows of the archived designs that leave, ascending
    x, f, q : np.ndarray
        [physical units] the entering designs, in batch order
    ids : np.ndarray
        [-] their evaluation ids
    """

    removed: np.ndarray
    x: np.ndarray
    f: np.ndarray
    q: np.ndarray
    ids: np.ndarray


class Archive:
    """Non-dominated feasible designs, updated in place (:meth:`offer`, then :meth:`apply`).

    The attributes are copies of the live designs, in order of evaluation.

    Attributes
    ----------
    x : np.ndarray
        [variable units] designs, shape ``(m, n_var)``
    f : np.ndarray
        [objective units] objectives, shape ``(m, n_obj)``
    q : np.ndarray
        [physical units] every evaluated quantity (objectives, then constraint-only
        quantities), shape ``(m, n_q)``
    ids : np.ndarray
        [-] evaluation ids (position in the run's evaluation history), ascending, ``(m,)``
    """

    def __init__(self, x: np.ndarray, f: np.ndarray, q: np.ndarray, ids: np.ndarray):
        m = len(ids)
        cap = max(64, m)
        self._x = np.empty((cap, np.shape(x)[1]))
        self._f = np.empty((cap, np.shape(f)[1]))
        self._q = np.empty((cap, np.shape(q)[1]))
        self._ids = np.empty(cap, dtype=np.int64)
        self._alive = np.zeros(cap, dtype=np.bool_)
        self._x[:m], self._f[:m], self._q[:m], self._ids[:m] = x, f, q, ids
        self._alive[:m] = True
        self._n = m  # rows in use, live or not
        self._dead = 0
        self._reindex()

    @classmethod
    def empty(cls, n_var: int, n_obj: int, n_q: int) -> Archive:
        """An archive with no designs."""
        return cls(np.empty((0, n_var)), np.empty((0, n_obj)), np.empty((0, n_q)), np.empty(0, dtype=np.int64))

    def __len__(self) -> int:
        return self._n - self._dead

    def _live(self, buf: np.ndarray) -> np.ndarray:
        return buf[: self._n][self._alive[: self._n]] if self._dead else buf[: self._n].copy()

    @property
    def x(self) -> np.ndarray:
        """[variable units] designs, ``(m, n_var)`` (a copy)."""
        return self._live(self._x)

    @property
    def f(self) -> np.ndarray:
        """[objective units] objectives, ``(m, n_obj)`` (a copy)."""
        return self._live(self._f)

    @property
    def q(self) -> np.ndarray:
        """[physical units] every evaluated quantity, ``(m, n_q)`` (a copy)."""
        return self._live(self._q)

    @property
    def ids(self) -> np.ndarray:
        """[-] evaluation ids, ascending, ``(m,)`` (a copy)."""
        return self._live(self._ids)

    def _reindex(self) -> None:
        rows = np.flatnonzero(self._alive[: self._n])
        self._index = build_index(self._f, rows, LEAF_SIZE)
        self._n_indexed = self._n

    def offer(self, x: np.ndarray, f: np.ndarray, q: np.ndarray, ids: np.ndarray, feasible: np.ndarray) -> Offer:
        """What offering a batch of evaluated designs does (the archive is not changed).

        Parameters
        ----------
        x, f, q : np.ndarray
            [physical units] the batch, shapes ``(n, n_var)``, ``(n, n_obj)``, ``(n, n_q)``
        ids : np.ndarray
            [-] evaluation ids of the batch, all greater than the archived ones, ``(n,)``
        feasible : np.ndarray
            [-] designs eligible for the archive (valid and meeting all constraints)
        """
        sel = np.asarray(feasible, dtype=bool)
        fs = np.asarray(f, dtype=float)[sel]
        accept = non_dominated_mask(fs)
        removed = np.empty(0, dtype=np.int64)
        if len(self) and accept.any():
            entered, removed = _search(self._f, self._n, self._alive, self._index, self._n_indexed, fs[accept])
            accept[accept] = entered
        ids_s = np.asarray(ids, dtype=np.int64)[sel][accept]
        return Offer(removed, np.asarray(x, dtype=float)[sel][accept], fs[accept], np.asarray(q, dtype=float)[sel][accept], ids_s)

    def apply(self, offer: Offer) -> None:
        """Apply an :meth:`offer` of this archive's current state (members leave, then enter)."""
        self._alive[offer.removed] = False
        self._dead += len(offer.removed)
        add = len(offer.ids)
        if self._n + add > len(self._ids):
            cap = max(2 * len(self._ids), self._n + add)
            for name in ("_x", "_f", "_q", "_ids", "_alive"):
                old = getattr(self, name)
                new = np.zeros((cap,) + old.shape[1:], dtype=old.dtype)
                new[: self._n] = old[: self._n]
                setattr(self, name, new)
        end = self._n + add
        self._x[self._n : end], self._f[self._n : end], self._q[self._n : end] = offer.x, offer.f, offer.q
        self._ids[self._n : end] = offer.ids
        self._alive[self._n : end] = True
        self._n = end
        if self._dead > len(self):  # compact, keeping the order
            rows = np.flatnonzero(self._alive[: self._n])
            m = len(rows)
            for buf in (self._x, self._f, self._q, self._ids):
                buf[:m] = buf[rows]
            self._alive[:m], self._alive[m : self._n] = True, False
            self._n, self._dead = m, 0
            self._reindex()
        elif self._n - self._n_indexed > _tail_limit(self._n_indexed):
            self._reindex()

    def update(self, x: np.ndarray, f: np.ndarray, q: np.ndarray, ids: np.ndarray, feasible: np.ndarray) -> Archive:
        """Offer a batch of evaluated designs and apply it (:meth:`offer`); returns the archive.

        Parameters
        ----------
        x, f, q : np.ndarray
            [physical units] the batch, shapes ``(n, n_var)``, ``(n, n_obj)``, ``(n, n_q)``
        ids : np.ndarray
            [-] evaluation ids of the batch, all greater than the archived ones, ``(n,)``
        feasible : np.ndarray
            [-] designs eligible for the archive (valid and meeting all constraints)
        """
        self.apply(self.offer(x, f, q, ids, feasible))
        return self

    def order(self) -> np.ndarray:
        """[-] Presentation order: by the first objective, then the next ones, then id."""
        f = self.f
        keys = [self.ids] + [f[:, j] for j in range(f.shape[1] - 1, -1, -1)]
        return np.lexsort(keys)
