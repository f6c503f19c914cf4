"""Exact hypervolume contributions and the greedy least-contributor removal (hisopt/optim/hv_survival.py).

The independent references are moocore's: the definition ``HV(S) - HV(S without p)`` with
:func:`moocore.hypervolume`, and :func:`moocore.hv_contributions` (its naive loop, which SMS-EMOA's
survival in pymoo repeats).

**Error budget.** A contribution is a difference of two hypervolumes. moocore's dimension sweep
sums at most ``n^(k-1)`` positive slab volumes, each a product of ``k`` differences and at most
the total volume ``V`` (the box from the points' ideal to ``ref``); each sum then errs by at most
``(n^(k-1) + k) eps V`` and the difference of two by twice that. hisopt's sweep sums only positive
terms of the contribution itself (error relative to the contribution, below ``V``), and the
5-objective path is ``box - covered`` with moocore's covered volume: both fit within the same
bound, so ``SAFETY * 2 * (n^(k-1) + k) * eps * V`` bounds the difference of the two methods
(:func:`budget`). moocore's :func:`moocore.hv_contributions` (from 3 objectives and with
``ignore_dominated=False``, from 4 by default) also sets a contribution below ``sqrt(eps)``
(absolute, its ``hvc_1point_diff``) to 0: a 0 there admits any value below ``sqrt(eps)`` plus the
budget. On integer coordinates every volume is an integer below 2^53, so both methods are exact
there and are compared for equality, ties included.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys

import moocore
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from hisopt.optim.hv_survival import greedy_least_contributor_removal, hv_contributions, least_contributor_removal_order
from tests.conftest import ROOT

EPS = float(np.finfo(float).eps)
SAFETY = 10.0
MOOCORE_CLIP = math.sqrt(EPS)  # moocore's hvc_1point_diff: contributions below it are returned as 0
SETTINGS = settings(max_examples=150, derandomize=True, database=None, deadline=None, suppress_health_check=list(HealthCheck))


def budget(f: np.ndarray, ref: np.ndarray) -> float:
    """[objective units^k] Bound on the difference of two computations of a contribution (module docstring)."""
    n, k = f.shape
    inside = f[np.all(f < ref, axis=1)]
    volume = float(np.prod(ref - inside.min(axis=0))) if len(inside) else 0.0
    return SAFETY * 2.0 * (float(n) ** (k - 1) + k) * EPS * volume


def by_definition(f: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``HV(S) - HV(S without p)`` for every row, with moocore's hypervolume."""
    total = moocore.hypervolume(f, ref=ref)
    rest = [moocore.hypervolume(np.delete(f, i, axis=0), ref=ref) if len(f) > 1 else 0.0 for i in range(len(f))]
    return total - np.array(rest, dtype=float)


def naive_removal_order(f: np.ndarray, ref: np.ndarray, n_remove: int, contributions=moocore.hv_contributions) -> list[int]:
    """SMS-EMOA's survival as pymoo writes it: argmin of all contributions, delete, repeat."""
    ids = np.arange(len(f))
    removed = []
    for _ in range(n_remove):
        j = int(np.argmin(contributions(f, ref=ref)))
        removed.append(int(ids[j]))
        f, ids = np.delete(f, j, axis=0), np.delete(ids, j)
    return removed


def front(rng: np.random.Generator, n: int, k: int, shape: str) -> np.ndarray:
    """``n`` mutually non-dominated points in [0, 1]^k: on the unit sphere's positive part or on the simplex."""
    x = np.abs(rng.normal(size=(n, k))) + 1e-3
    if shape == "sphere":
        return x / np.linalg.norm(x, axis=1, keepdims=True)
    return x / x.sum(axis=1, keepdims=True)


@st.composite
def point_sets(draw: st.DrawFn, max_n: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """A front with dominated points, duplicates and points on or beyond the reference point mixed in, shuffled."""
    k = draw(st.sampled_from([2, 3, 4, 5]))
    n = draw(st.integers(1, max_n if k < 5 else max_n // 2))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    f = front(rng, n, k, draw(st.sampled_from(["sphere", "simplex"])))
    ref = np.full(k, draw(st.sampled_from([1.0, 1.1, 1.5])))
    extra = [f]
    if draw(st.booleans()):  # dominated: a front point moved up in some objectives
        rows = f[rng.integers(0, n, size=draw(st.integers(1, 4)))]
        extra.append(rows + rng.random(rows.shape) * 0.2 * (rng.random(rows.shape) < 0.7))
    if draw(st.booleans()):  # duplicates
        extra.append(f[rng.integers(0, n, size=draw(st.integers(1, 3)))])
    if draw(st.booleans()):  # on or beyond the reference point in one objective
        rows = f[rng.integers(0, n, size=draw(st.integers(1, 2)))].copy()
        rows[:, rng.integers(0, k)] = ref[0] + draw(st.sampled_from([0.0, 0.3]))
        extra.append(rows)
    f = np.vstack(extra)
    return f[rng.permutation(len(f))], ref


@st.composite
def integer_sets(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    """Points on a small integer grid (many ties, duplicates and dominated points), reference 6."""
    k = draw(st.sampled_from([2, 3, 4, 5]))
    n = draw(st.integers(1, 18 if k < 5 else 10))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    return rng.integers(0, 7, size=(n, k)).astype(float), np.full(k, 6.0)


def allowed_clip(mine: np.ndarray, theirs: np.ndarray, tol: float) -> np.ndarray:
    """Where moocore's 0 may stand for a contribution it clipped (module docstring)."""
    return (theirs == 0.0) & (mine <= MOOCORE_CLIP + tol)


@SETTINGS
@given(point_sets())
def test_contributions_equal_the_definition(case: tuple[np.ndarray, np.ndarray]) -> None:
    f, ref = case
    mine = hv_contributions(f, ref)
    tol = budget(f, ref)
    assert np.all(np.abs(mine - by_definition(f, ref)) <= tol)
    theirs = moocore.hv_contributions(f, ref=ref, ignore_dominated=False)
    assert np.all((np.abs(mine - theirs) <= tol) | allowed_clip(mine, theirs, tol))
    # exact zeros: outside the reference box, or weakly dominated by another row
    dominated = np.array([np.any(np.all(np.delete(f, i, axis=0) <= f[i], axis=1)) for i in range(len(f))], dtype=bool)
    zero = np.any(f >= ref, axis=1) | dominated
    assert np.all(mine[zero] == 0.0)
    if f.shape[1] <= 4:
        assert np.all(mine[~zero] > 0.0)


def test_budget_is_far_below_a_wrong_answer() -> None:
    """The budget must not hide a bug: a sphere front's smallest contribution is many budgets."""
    rng = np.random.default_rng(3)
    for k, n in ((2, 24), (3, 24), (4, 24), (5, 12)):
        f, ref = front(rng, n, k, "sphere"), np.full(k, 1.1)
        assert budget(f, ref) < 1e-4 * by_definition(f, ref).min()


@SETTINGS
@given(integer_sets())
def test_integer_grid_contributions_are_exact(case: tuple[np.ndarray, np.ndarray]) -> None:
    f, ref = case
    assert np.array_equal(hv_contributions(f, ref), by_definition(f, ref))


@SETTINGS
@given(integer_sets(), st.data())
def test_integer_grid_removal_equals_the_naive_loop(case: tuple[np.ndarray, np.ndarray], data: st.DataObject) -> None:
    """Exact volumes: the same indices in the same order as pymoo's loop over moocore, ties (lowest index) included."""
    f, ref = case
    n_remove = data.draw(st.integers(0, len(f)))
    assert least_contributor_removal_order(f, ref, n_remove).tolist() == naive_removal_order(f, ref, n_remove)


@SETTINGS
@given(point_sets(max_n=30), st.data())
def test_removal_follows_the_least_contributor(case: tuple[np.ndarray, np.ndarray], data: st.DataObject) -> None:
    """Each removal is moocore's least contributor among the points left: the same index when the two least
    contributions are further apart than the budget, else one within the budget of the least."""
    f, ref = case
    n_remove = data.draw(st.integers(0, len(f)))
    order = least_contributor_removal_order(f, ref, n_remove)
    assert len(set(order.tolist())) == n_remove
    ids = np.arange(len(f))
    for chosen in order:
        left = f[ids]
        tol = budget(left, ref)
        theirs = moocore.hv_contributions(left, ref=ref)
        exact = by_definition(left, ref)
        j = int(np.flatnonzero(ids == chosen)[0])
        assert exact[j] <= exact.min() + 2 * tol
        two = np.sort(theirs)[:2]
        if len(two) == 1 or (two[1] - two[0] > 2 * tol and two[0] >= MOOCORE_CLIP):
            assert j == int(np.argmin(theirs))
        ids = np.delete(ids, j)


@settings(max_examples=40, derandomize=True, database=None, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.integers(0, 2**32 - 1), st.sampled_from([2, 3, 4, 5]))
def test_removal_equals_the_naive_loop_on_distinct_fronts(seed: int, k: int) -> None:
    """On fronts whose least contributions are distinct at every step, the whole sequence equals pymoo's loop."""
    rng = np.random.default_rng(seed)
    f, ref = front(rng, 40 if k < 5 else 16, k, "sphere"), np.full(k, 1.1)
    n_remove = len(f) // 2
    naive = naive_removal_order(f, ref, n_remove)
    ids, left = np.arange(len(f)), f
    for chosen in naive:  # distinct: the least and second least further apart than the budget, above moocore's clip
        two = np.sort(moocore.hv_contributions(left, ref=ref))[:2]
        assume(two[1] - two[0] > 2 * budget(left, ref) and two[0] >= MOOCORE_CLIP)
        j = int(np.flatnonzero(ids == chosen)[0])
        ids, left = np.delete(ids, j), np.delete(left, j, axis=0)
    assert least_contributor_removal_order(f, ref, n_remove).tolist() == naive
    survivors = greedy_least_contributor_removal(f, ref, n_remove)
    assert survivors.tolist() == sorted(set(range(len(f))) - set(naive))


@SETTINGS
@given(point_sets(max_n=30), st.data())
def test_removal_equals_its_own_contributions_loop_bit_for_bit(case: tuple[np.ndarray, np.ndarray], data: st.DataObject) -> None:
    """The lazy, local updates give exactly what recomputing every contribution after each removal gives."""
    f, ref = case
    n_remove = data.draw(st.integers(0, len(f)))
    assert least_contributor_removal_order(f, ref, n_remove).tolist() == naive_removal_order(f, ref, n_remove, contributions=hv_contributions)


@SETTINGS
@given(point_sets(max_n=30))
def test_deterministic_and_permutation_equivariant(case: tuple[np.ndarray, np.ndarray]) -> None:
    """Same input, same output; rows shuffled, contributions shuffled alike, bit for bit (4 objectives or fewer:
    the sweep's value depends only on the set of neighbours, not on the order they were found in)."""
    f, ref = case
    first = hv_contributions(f, ref)
    assert np.array_equal(first, hv_contributions(f, ref))
    perm = np.random.default_rng(len(f)).permutation(len(f))
    shuffled = hv_contributions(f[perm], ref)
    if f.shape[1] <= 4:
        assert np.array_equal(shuffled, first[perm])
    else:
        assert np.all(np.abs(shuffled - first[perm]) <= budget(f, ref))


THREADS = """
import hashlib, sys
import numpy as np
from hisopt.optim.hv_survival import hv_contributions, least_contributor_removal_order
rng = np.random.default_rng(7)
x = np.abs(rng.normal(size=(120, 4)))
x /= np.linalg.norm(x, axis=1, keepdims=True)
ref = np.full(4, 1.1)
digest = hashlib.sha256(hv_contributions(x, ref).tobytes() + least_contributor_removal_order(x, ref, 60).tobytes())
print(digest.hexdigest())
"""


def test_same_result_on_one_thread_or_two() -> None:
    def run(threads: int) -> str:
        env = dict(os.environ, NUMBA_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads), OPENBLAS_NUM_THREADS=str(threads))
        out = subprocess.run([sys.executable, "-c", THREADS], env=env, cwd=ROOT, capture_output=True, text=True, check=True)
        return out.stdout.strip()

    assert run(1) == run(2)


def test_edge_cases_and_bad_input() -> None:
    ref = np.array([2.0, 2.0])
    assert hv_contributions(np.zeros((0, 2)), ref).shape == (0,)
    assert hv_contributions(np.array([[1.0, 0.5]]), ref).tolist() == [1.5]
    assert greedy_least_contributor_removal(np.array([[1.0, 0.5], [0.5, 1.0]]), ref, 0).tolist() == [0, 1]
    assert greedy_least_contributor_removal(np.array([[1.0, 0.5], [0.5, 1.0]]), ref, 2).tolist() == []
    with pytest.raises(ValueError, match="n_remove must be an integer from 0 to 2"):
        least_contributor_removal_order(np.ones((2, 2)), ref, 3)
    with pytest.raises(ValueError, match="n_remove must be an integer"):
        least_contributor_removal_order(np.ones((2, 2)), ref, 1.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="reference point must have shape"):
        hv_contributions(np.ones((2, 3)), ref)
    with pytest.raises(ValueError, match="finite"):
        hv_contributions(np.array([[np.nan, 1.0]]), ref)
    with pytest.raises(ValueError, match="2-D array"):
        hv_contributions(np.ones(3), ref)


@pytest.mark.parametrize(("k", "n"), [(2, 200), (3, 200), (4, 200)])
def test_survival_sized_removal_equals_its_own_contributions_loop(k: int, n: int) -> None:
    """A survival's size (200 to 100): many near-equal contributions, so the lazy bound is put to the test."""
    f, ref = front(np.random.default_rng(k), n, k, "sphere"), np.full(k, 1.1)
    assert least_contributor_removal_order(f, ref, n // 2).tolist() == naive_removal_order(f, ref, n // 2, contributions=hv_contributions)
