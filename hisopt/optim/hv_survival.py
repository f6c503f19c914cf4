"""Exact hypervolume contributions and SMS-EMOA's greedy least-contributor removal, fast.

SMS-EMOA's survival removes, one at a time, the point whose exclusive hypervolume
contribution is least, recomputing the contributions after each removal. Recomputing all of
them with :func:`moocore.hv_contributions` costs about 100 ms for 200 points in 4-D, so a
generation (about 100 removals) takes seconds. This module computes the same removals exactly
and two orders of magnitude faster, by two observations:

- **Local contributions.** The contribution of ``p`` (minimisation, reference point ``r``) is
  the volume of the box ``[p, r]`` left uncovered by the boxes ``[max(p, q), r]`` of the other
  points ``q``. Only the non-dominated members of the projected set ``{max(p, q)}`` (the
  *neighbours* of ``p``; a few tens for a 4-D front of hundreds) matter. Their uncovered volume
  is a dimension sweep: levels in the 4th objective, in each a sweep over the 3rd with the 2-D
  uncovered area of a staircase, ``O(m^3)`` for ``m`` neighbours, compiled with numba. It is
  summed from positive terms only (no ``box - covered`` difference), so its rounding error is
  relative to the contribution itself, a few ``m eps``, and a point is 0 exactly when another
  point weakly dominates it (a duplicate, a dominated point) or it is not strictly below ``r``
  in every objective.
- **Local updates.** Removing ``q`` changes the contribution of ``p`` only if ``q`` is one of
  ``p``'s neighbours (a projection dominated by another neighbour, or outside the box, removes
  nothing from the uncovered volume). The greedy keeps every point's neighbour set and marks
  only the points that had the removed one as a neighbour. A marked value stays a lower bound
  (contributions only grow as points leave), so up to 4 objectives it is recomputed only when it
  could be the least; from 5 every marked one is recomputed at once.

For 2 and 3 objectives the points are padded with zeros to 4 (reference 1 in the padding:
the factors are exact ones). From 5 objectives on the neighbour sets are the same, and the
covered volume of each is :func:`moocore.hypervolume`'s (``box - covered``: rounding relative
to the box, not to the contribution); speed matters less there. Ties in the greedy go to the
lowest index. Everything runs in a fixed order on one thread: the same input gives the same
output bit for bit.
"""

from __future__ import annotations

import numpy as np
from numba import njit

PAD_OBJECTIVES = 4
"""[-] the compiled sweep's number of objectives; fewer are padded to it."""

SLACK = 1e-9
"""[-] relative rounding allowance on a contribution used as a lower bound: the sweep's sums of
``m^2`` positive terms err by about ``m^2 eps`` relative (1e-13 for 30 neighbours)."""


def _checked(f: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``f`` (n, k) and ``ref`` (k,) as contiguous float arrays, or ValueError."""
    f = np.ascontiguousarray(f, dtype=float)
    ref = np.ascontiguousarray(ref, dtype=float)
    if f.ndim != 2 or f.shape[1] < 1:
        raise ValueError(f"hv_survival: objectives must be a 2-D array (n points, k objectives), got shape {f.shape}")
    if ref.shape != (f.shape[1],):
        raise ValueError(f"hv_survival: reference point must have shape ({f.shape[1]},), got {ref.shape}")
    if not (np.isfinite(f).all() and np.isfinite(ref).all()):
        raise ValueError("hv_survival: objectives and reference point must be finite (no NaN or inf)")
    return f, ref


def _padded(f: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``f`` and ``ref`` padded to :data:`PAD_OBJECTIVES` objectives with 0 and 1."""
    k = f.shape[1]
    f4 = np.zeros((f.shape[0], PAD_OBJECTIVES))
    f4[:, :k] = f
    ref4 = np.ones(PAD_OBJECTIVES)
    ref4[:k] = ref
    return f4, ref4


@njit(cache=True)
def _neighbours(f: np.ndarray, ref: np.ndarray, alive: np.ndarray, order: np.ndarray, p: int, members: np.ndarray, proj: np.ndarray) -> int:
    """Non-dominated projections ``max(f[p], f[q])`` of the live ``q != p`` inside the box.

    Writes their indices to ``members`` and coordinates to the rows of ``proj``, returns how
    many; returns -1 when ``f[p]`` is not strictly below ``ref`` (no box, ``members`` empty) and
    -2 when a live ``q`` weakly dominates ``p`` (``members[0] = q``): both contribute 0.
    ``order`` is the scan order (by coordinate sum: early projections dominate most later ones).
    """
    k = f.shape[1]
    for d in range(k):
        if f[p, d] >= ref[d]:
            return -1
    count = 0
    for t in range(order.shape[0]):
        q = order[t]
        if q == p or not alive[q]:
            continue
        weak = True
        outside = False
        for d in range(k):
            if f[q, d] > f[p, d]:
                weak = False
                if f[q, d] >= ref[d]:
                    outside = True
        if weak:
            members[0] = q
            return -2
        if outside:
            continue
        dominated = False
        for j in range(count):
            below = True
            for d in range(k):
                if proj[j, d] > max(f[p, d], f[q, d]):
                    below = False
                    break
            if below:
                dominated = True
                break
        if dominated:
            continue
        kept = 0
        for j in range(count):  # drop the members the new projection weakly dominates
            above = True
            for d in range(k):
                if max(f[p, d], f[q, d]) > proj[j, d]:
                    above = False
                    break
            if not above:
                if kept != j:
                    members[kept] = members[j]
                    for d in range(k):
                        proj[kept, d] = proj[j, d]
                kept += 1
        count = kept
        members[count] = q
        for d in range(k):
            proj[count, d] = max(f[p, d], f[q, d])
        count += 1
    return count


@njit(cache=True)
def _neighbours4(f: np.ndarray, ref: np.ndarray, alive: np.ndarray, order: np.ndarray, p: int, members: np.ndarray, cols: np.ndarray) -> int:
    """:func:`_neighbours` for 4 objectives, the projections in the columns ``cols[d, :count]``.

    The test of a projection against all members has no early exit, so that it vectorises.
    """
    a0, a1, a2, a3 = f[p, 0], f[p, 1], f[p, 2], f[p, 3]
    if a0 >= ref[0] or a1 >= ref[1] or a2 >= ref[2] or a3 >= ref[3]:
        return -1
    x0, x1, x2, x3 = cols[0], cols[1], cols[2], cols[3]
    count = 0
    for t in range(order.shape[0]):
        q = order[t]
        if q == p or not alive[q]:
            continue
        b0, b1, b2, b3 = f[q, 0], f[q, 1], f[q, 2], f[q, 3]
        if b0 <= a0 and b1 <= a1 and b2 <= a2 and b3 <= a3:
            members[0] = q
            return -2
        if b0 >= ref[0] or b1 >= ref[1] or b2 >= ref[2] or b3 >= ref[3]:
            continue
        c0, c1, c2, c3 = max(a0, b0), max(a1, b1), max(a2, b2), max(a3, b3)
        hit = False
        for j in range(count):
            hit |= (x0[j] <= c0) & (x1[j] <= c1) & (x2[j] <= c2) & (x3[j] <= c3)
        if hit:
            continue
        kept = 0
        for j in range(count):  # drop the members the new projection weakly dominates
            if not (c0 <= x0[j] and c1 <= x1[j] and c2 <= x2[j] and c3 <= x3[j]):
                members[kept] = members[j]
                x0[kept], x1[kept], x2[kept], x3[kept] = x0[j], x1[j], x2[j], x3[j]
                kept += 1
        members[kept] = q
        x0[kept], x1[kept], x2[kept], x3[kept] = c0, c1, c2, c3
        count = kept + 1
    return count


@njit(cache=True)
def _uncovered4(
    p: np.ndarray, ref: np.ndarray, cols: np.ndarray, m: int, by_w: np.ndarray, by_z: np.ndarray, rank_w: np.ndarray, sx: np.ndarray, sy: np.ndarray
) -> float:
    """Volume of the box ``[p, ref]`` (4-D) not covered by the boxes ``[cols[:, i], ref]``, ``i < m``.

    Every ``cols[:, i] >= p``, and strictly greater in some coordinate. Sweep over the 4th
    coordinate: between consecutive levels the uncovered 3-D volume of the members at or below
    the level, itself a sweep over the 3rd coordinate of the uncovered 2-D area under a staircase
    (``sx`` ascending, ``sy`` descending). Every term added is a product of non-negative
    differences: no cancellation.
    """
    xs, ys, zs, ws = cols[0], cols[1], cols[2], cols[3]
    for c in range(2):  # insertion sorts (m is small) by w and by z, ties by position
        key, idx = (ws, by_w) if c == 0 else (zs, by_z)
        for i in range(m):
            idx[i] = i
        for i in range(1, m):
            v = idx[i]
            j = i - 1
            while j >= 0 and key[idx[j]] > key[v]:
                idx[j + 1] = idx[j]
                j -= 1
            idx[j + 1] = v
    for j in range(m):
        rank_w[by_w[j]] = j
    wx = ref[0] - p[0]
    wy = ref[1] - p[1]
    total = wx * wy * (ref[2] - p[2]) * ((ws[by_w[0]] if m > 0 else ref[3]) - p[3])
    for j in range(m):
        w_next = ws[by_w[j + 1]] if j + 1 < m else ref[3]
        dw = w_next - ws[by_w[j]]
        if dw <= 0.0:
            continue  # equal levels: only the last of them has a slab
        count = 0
        area = wx * wy
        z_prev = p[2]
        vol = 0.0
        for t in range(m):
            i = by_z[t]
            if rank_w[i] > j:
                continue
            x = xs[i]
            y = ys[i]
            pos = 0
            while pos < count and sx[pos] <= x:
                pos += 1
            if pos > 0 and sy[pos - 1] <= y:
                continue  # covered by the staircase already
            vol += area * (zs[i] - z_prev)
            z_prev = zs[i]
            start = pos - 1 if pos > 0 and sx[pos - 1] == x else pos
            end = pos
            while end < count and sy[end] >= y:
                end += 1
            shift = end - start - 1  # entries removed minus the one inserted
            if shift > 0:
                for s in range(start + 1, count - shift):
                    sx[s] = sx[s + shift]
                    sy[s] = sy[s + shift]
            elif shift < 0:
                for s in range(count - 1, start - 1, -1):
                    sx[s + 1] = sx[s]
                    sy[s + 1] = sy[s]
            sx[start] = x
            sy[start] = y
            count -= shift
            # uncovered area of [p, ref] (x, y) under the staircase, as positive strips
            area = (sx[0] - p[0]) * wy
            for s in range(count):
                x_next = sx[s + 1] if s + 1 < count else ref[0]
                area += (x_next - sx[s]) * (sy[s] - p[1])
        vol += area * (ref[2] - z_prev)
        total += vol * dw
    return total


@njit(cache=True)
def _removal_order4(f: np.ndarray, ref: np.ndarray, order: np.ndarray, n_remove: int, initial: np.ndarray) -> np.ndarray:
    """Indices removed one by one, least contributor first (lowest index on ties), 4 objectives;
    the contributions before any removal into ``initial`` (n,). One compiled entry point for both
    public functions: numba compiles each entry point with its callees on the first run.

    Lazy: removing a point can only raise the contributions of the others, so a value computed
    before a neighbour left is a lower bound (less :data:`SLACK` for rounding). Only a point whose
    bound could beat the least exact value is recomputed.
    """
    n = f.shape[0]
    alive = np.ones(n, dtype=np.bool_)
    stale = np.zeros(n, dtype=np.bool_)
    members = np.empty(n, dtype=np.int64)
    cols = np.empty((4, n))  # neighbours' projections, by column
    work = np.empty((3, n), dtype=np.int64)
    fwork = np.empty((2, n))
    contrib = np.empty(n)
    neighbour = np.zeros((n, n), dtype=np.bool_)  # neighbour[p, q]: q is one of p's neighbours
    removed = np.empty(n_remove, dtype=np.int64)
    step = 0
    pending = 0  # the first pass evaluates every point; then one removal or re-evaluation per turn
    while True:
        if pending < n:
            target = pending
            pending += 1
        else:
            if pending == n:
                for p in range(n):
                    initial[p] = contrib[p]
                pending += 1
            if step == n_remove:
                break
            best = -1  # least exact value, lowest index on ties
            for p in range(n):
                if alive[p] and not stale[p] and (best < 0 or contrib[p] < contrib[best]):
                    best = p
            target = -1  # a stale point whose bound does not lose to best
            for p in range(n):
                if alive[p] and stale[p]:
                    bound = contrib[p] * (1.0 - SLACK)
                    if best < 0 or bound < contrib[best] or (bound == contrib[best] and p < best):
                        target = p
                        break
            if target < 0:
                removed[step] = best
                step += 1
                alive[best] = False
                for p in range(n):
                    if alive[p] and neighbour[p, best]:
                        stale[p] = True
                continue
        # evaluate target: its neighbours (a weak dominator counts as one) and contribution
        m = _neighbours4(f, ref, alive, order, target, members, cols)
        contrib[target] = _uncovered4(f[target], ref, cols, m, work[0], work[1], work[2], fwork[0], fwork[1]) if m >= 0 else 0.0
        for q in range(n):
            neighbour[target, q] = False
        for j in range(m if m >= 0 else (1 if m == -2 else 0)):
            neighbour[target, members[j]] = True
        stale[target] = False
    return removed


def _scan_order(f: np.ndarray) -> np.ndarray:
    """Scan order of the neighbour search: by coordinate sum, ties by index."""
    return np.argsort(f.sum(axis=1), kind="stable").astype(np.int64)


def _contribution_many(
    f: np.ndarray, ref: np.ndarray, alive: np.ndarray, order: np.ndarray, p: int, members: np.ndarray, proj: np.ndarray
) -> tuple[float, np.ndarray]:
    """Contribution of live ``p`` and its neighbours, 5 or more objectives (moocore's covered volume)."""
    import moocore

    m = _neighbours(f, ref, alive, order, p, members, proj)
    if m == -1:
        return 0.0, members[:0].copy()
    if m == -2:
        return 0.0, members[:1].copy()
    box = float(np.prod(ref - f[p]))
    rows = proj[np.lexsort(proj[:m].T[::-1])]  # one row order for one set: the same rounding
    covered = float(moocore.hypervolume(rows, ref=ref)) if m > 0 else 0.0
    return box - covered, members[:m].copy()


def hv_contributions(f: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """[objective units^k] Exact exclusive hypervolume contribution of every point (minimisation).

    The contribution of ``f[i]`` is the hypervolume of all points minus that of all points but
    ``f[i]``, with respect to the reference point ``ref``. A point that is not strictly below
    ``ref`` in every objective contributes 0 (it bounds no volume), and so does a point weakly
    dominated by another (a dominated point, or one of two duplicates: removing either loses
    nothing); these are exact zeros. Method in the module docstring; equal to
    :func:`moocore.hv_contributions` up to rounding.

    Parameters
    ----------
    f : np.ndarray
        [objective units] objectives (n, k), finite, k >= 1
    ref : np.ndarray
        [objective units] reference point (k,), finite

    Returns
    -------
    np.ndarray
        [objective units^k] contributions (n,), each >= 0 for k <= 4; for k >= 5 a difference of
        two volumes, which rounding can make slightly negative for a vanishing contribution
    """
    f, ref = _checked(f, ref)
    n, k = f.shape
    if n == 0:
        return np.zeros(0)
    order = _scan_order(f)
    if k <= PAD_OBJECTIVES:
        f4, ref4 = _padded(f, ref)
        out = np.empty(n)
        _removal_order4(f4, ref4, order, 0, out)
        return out
    alive = np.ones(n, dtype=np.bool_)
    members = np.empty(n, dtype=np.int64)
    proj = np.empty((n, k))
    return np.array([_contribution_many(f, ref, alive, order, p, members, proj)[0] for p in range(n)])


def least_contributor_removal_order(f: np.ndarray, ref: np.ndarray, n_remove: int) -> np.ndarray:
    """Indices of ``n_remove`` points removed one at a time, each the least contributor of those left.

    After each removal only the contributions that can change are recomputed (those of the
    points that had the removed one as a neighbour; module docstring). Ties go to the lowest
    index. The result equals repeating ``argmin`` of :func:`hv_contributions` over the points
    left and deleting that point, exactly. Memory: an ``n x n`` table of neighbours (n^2 bytes).

    Parameters
    ----------
    f : np.ndarray
        [objective units] objectives (n, k), finite
    ref : np.ndarray
        [objective units] reference point (k,), finite
    n_remove : int
        [-] how many points to remove, 0 <= n_remove <= n

    Returns
    -------
    np.ndarray
        [-] the removed rows' indices into ``f``, in the order removed, (n_remove,) int64
    """
    f, ref = _checked(f, ref)
    n, k = f.shape
    if isinstance(n_remove, bool) or not isinstance(n_remove, int | np.integer) or not 0 <= n_remove <= n:
        raise ValueError(f"hv_survival: n_remove must be an integer from 0 to {n}, got {n_remove!r}")
    n_remove = int(n_remove)
    if n_remove == 0:
        return np.zeros(0, dtype=np.int64)
    order = _scan_order(f)
    if k <= PAD_OBJECTIVES:
        f4, ref4 = _padded(f, ref)
        return _removal_order4(f4, ref4, order, n_remove, np.empty(n))
    alive = np.ones(n, dtype=np.bool_)
    members = np.empty(n, dtype=np.int64)
    proj = np.empty((n, k))
    contrib = np.empty(n)
    neighbours: list[np.ndarray] = []
    for p in range(n):
        contrib[p], near = _contribution_many(f, ref, alive, order, p, members, proj)
        neighbours.append(near)
    removed = np.empty(n_remove, dtype=np.int64)
    for step in range(n_remove):
        live = np.flatnonzero(alive)
        best = int(live[np.argmin(contrib[live])])  # argmin: the first of equal values
        removed[step] = best
        alive[best] = False
        for q in np.flatnonzero(alive).tolist():
            if best in neighbours[q]:
                contrib[q], neighbours[q] = _contribution_many(f, ref, alive, order, q, members, proj)
    return removed


def greedy_least_contributor_removal(f: np.ndarray, ref: np.ndarray, n_remove: int) -> np.ndarray:
    """Survivors of SMS-EMOA's survival: remove the least hypervolume contributor ``n_remove`` times.

    Parameters
    ----------
    f : np.ndarray
        [objective units] objectives (n, k), finite
    ref : np.ndarray
        [objective units] reference point (k,), finite
    n_remove : int
        [-] how many points to remove, 0 <= n_remove <= n

    Returns
    -------
    np.ndarray
        [-] indices into ``f`` of the ``n - n_remove`` survivors, ascending, int64
        (:func:`least_contributor_removal_order` gives the removed ones in order)
    """
    removed = least_contributor_removal_order(f, ref, n_remove)
    keep = np.ones(np.shape(f)[0], dtype=bool)
    keep[removed] = False
    return np.flatnonzero(keep).astype(np.int64)
