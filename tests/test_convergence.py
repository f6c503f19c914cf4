"""The run engine's cost-independent parts: the archive update, the progress hypervolume and
the convergence rule, each against an independent computation."""

from __future__ import annotations

import math

import moocore
import numpy as np
import pytest

from hisopt.errors import ConfigError
from hisopt.optim import archive as archive_module
from hisopt.optim.archive import Archive, build_index, non_dominated_mask, pareto_update, weakly_dominates
from hisopt.optim.convergence import DIRECTIONS, ProgressHypervolume, converged, hypervolume_estimate, orthant_area
from hisopt.optim.decision import hypervolume, slab_hypervolume


def plain_update(archive_f: np.ndarray, new_f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The archive rules written out with dense dominance matrices (the former implementation)."""
    accept = non_dominated_mask(new_f)
    if len(archive_f) and accept.any():
        accept[accept] = ~weakly_dominates(archive_f, new_f[accept]).any(axis=0)
    keep = np.ones(len(archive_f), dtype=bool)
    if len(archive_f) and accept.any():
        keep = ~weakly_dominates(new_f[accept], archive_f).any(axis=0)
    return keep, accept


@pytest.mark.parametrize("seed", range(6))
def test_compiled_archive_update_follows_the_rules(seed):
    """Same members in the same order as the dense rule, over a whole run of batches with
    ties (values on a coarse grid, so equal objective vectors and equal coordinates occur)."""
    rng = np.random.default_rng(seed)
    archive = np.empty((0, 4))
    reference = np.empty((0, 4))
    for _ in range(40):
        batch = rng.integers(0, 6, size=(30, 4)).astype(float) + rng.integers(0, 2, size=(30, 1))
        keep, accept = pareto_update(archive, batch)
        keep_ref, accept_ref = plain_update(reference, batch)
        assert np.array_equal(keep, keep_ref) and np.array_equal(accept, accept_ref)
        archive = np.concatenate([archive[keep], batch[accept]])
        reference = np.concatenate([reference[keep_ref], batch[accept_ref]])
    assert np.array_equal(archive, reference) and non_dominated_mask(archive).all()


def archive_batches(seed: int, n_batches: int) -> list[np.ndarray]:
    """Batches on a coarse grid (ties, equal vectors) that drift towards the origin, so later
    batches remove many archived designs (compactions), with a few NaN rows."""
    rng = np.random.default_rng(seed)
    out = []
    for b in range(n_batches):
        batch = rng.integers(0, 8, size=(40, 4)).astype(float) + rng.integers(0, 2, size=(40, 1))
        batch -= 4.0 * b / n_batches * (rng.random((40, 1)) < 0.5)  # some batches dominate much of the archive
        batch[rng.random(40) < 0.02, rng.integers(0, 4)] = np.nan
        out.append(batch)
    return out


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("leaf, tail", [(1, 1), (3, 5), (32, 1024)])
def test_archive_storage_and_index_follow_the_dense_rule(monkeypatch, seed, leaf, tail):
    """The in-place archive (growing buffers, flagged removals, compaction, spatial index
    rebuilt after ``tail`` appended rows, leaves of ``leaf`` designs) holds exactly the members,
    in the same order, as the dense rule applied batch by batch to plain arrays."""
    monkeypatch.setattr(archive_module, "LEAF_SIZE", leaf)
    monkeypatch.setattr(archive_module, "_tail_limit", lambda n: tail)
    archive = Archive.empty(2, 4, 5)
    reference = np.empty((0, 4))
    ref_ids = np.empty(0, dtype=np.int64)
    start = 0
    compactions = 0
    for batch in archive_batches(seed, 30):
        n = len(batch)
        ids = np.arange(start, start + n)
        feasible = np.arange(n) % 7 != 3
        x = np.column_stack([ids, -ids]).astype(float)
        q = np.column_stack([batch, ids.astype(float)])
        dead_before = archive._dead
        offer = archive.offer(x, batch, q, ids, feasible)
        keep_ref, accept_ref = plain_update(reference, batch[feasible])
        assert np.array_equal(offer.ids, ids[feasible][accept_ref])
        archive.apply(offer)
        compactions += archive._dead < dead_before + len(offer.removed)
        reference = np.concatenate([reference[keep_ref], batch[feasible][accept_ref]])
        ref_ids = np.concatenate([ref_ids[keep_ref], ids[feasible][accept_ref]])
        assert np.array_equal(archive.ids, ref_ids) and len(archive) == len(ref_ids)
        assert np.array_equal(archive.f, reference, equal_nan=True)
        assert np.array_equal(archive.x[:, 0], ref_ids) and np.array_equal(archive.q[:, 4], ref_ids)
        start += n
    assert compactions > 0  # the removal patterns did exercise compaction


def test_spatial_index_leaves_bound_their_designs():
    """Every indexed row is in exactly one leaf, and within that leaf's corners."""
    rng = np.random.default_rng(0)
    f = np.round(rng.random((1000, 4)), 2)
    f[5, 2] = np.nan
    rows = np.flatnonzero(rng.random(1000) < 0.7)
    perm, starts, lo, hi = build_index(f, rows, leaf_size=8)
    assert np.array_equal(np.sort(perm), rows) and starts[0] == 0 and starts[-1] == len(rows)
    for b in range(len(starts) - 1):
        fb = f[perm[starts[b] : starts[b + 1]]]
        with np.errstate(invalid="ignore"):
            assert np.all((fb >= lo[b]) | np.isnan(fb)) and np.all((fb <= hi[b]) | np.isnan(fb))
    assert (np.diff(starts) <= 4 * 8).all()  # STR tiles: a few times the leaf size at most (ties)


@pytest.mark.parametrize("k", [3, 4])
@pytest.mark.parametrize("slabs", [1, 2, 7, 40])
def test_slab_hypervolume_equals_moocore(k, slabs):
    """Against moocore on all points at once, with ties in every coordinate (coarse grid,
    dominated and duplicate points). Error budget: both sides add up at most a few thousand
    box volumes of the same sign, each exact to a few ulps, so they agree to ~n * 1e-16
    relative; 1e-11 bounds that with room."""
    rng = np.random.default_rng(k * 100 + slabs)
    for n in (1, 5, 300, 2000):
        z = np.round(rng.random((n, k)), 2)
        if n > 5:
            z[: n // 2] = moocore.generate_ndset(n // 2, k, method="simplex", seed=slabs)
        ref = np.full(k, 1.1)
        assert slab_hypervolume(z, ref, slabs) == pytest.approx(moocore.hypervolume(z, ref=ref), rel=1e-11)


def test_hypervolume_of_a_large_front_uses_slabs_and_stays_exact():
    rng = np.random.default_rng(1)
    z = moocore.generate_ndset(9000, 4, method="simplex", seed=2) * 0.9 + 0.01 * rng.random((9000, 4))
    ref = np.full(4, 1.0)
    f = 10.0**z  # hypervolume() works on log10 objectives
    assert hypervolume(f, ref) == pytest.approx(moocore.hypervolume(z, ref=ref), rel=1e-11)


def test_archive_update_with_nan_compares_with_nothing():
    archive = np.array([[1.0, 1.0], [np.nan, 0.0]])
    keep, accept = pareto_update(archive, np.array([[0.5, 0.5], [2.0, 2.0]]))
    assert keep.tolist() == [False, True] and accept.tolist() == [True, False]


def test_progress_hypervolume_incremental_equals_from_scratch_and_ignores_removed_designs():
    """Adding designs batch by batch, dominated ones included, gives bit for bit the estimate
    of the final non-dominated set computed at once (rho is a max; a dominated design never
    reaches farther than its dominator)."""
    rng = np.random.default_rng(3)
    ref = np.array([1.0, 1.0, 1.0, 1.0])
    tracker = ProgressHypervolume(ref)
    seen = []
    for _ in range(10):
        z = rng.random((25, 4)) * 1.1  # some beyond the reference point
        tracker.add(z)
        seen.append(z)
    every = np.concatenate(seen)
    front = every[non_dominated_mask(every)]
    assert tracker.value() == hypervolume_estimate(front, ref)


@pytest.mark.parametrize("seed", [0, 1])
def test_progress_hypervolume_estimates_the_exact_value(seed):
    """Against moocore's exact hypervolume. Error budget: the estimator is a sample mean of
    ``|S+|/k rho^k`` over DIRECTIONS directions; four standard errors of plain Monte Carlo
    (the sample's own standard deviation / sqrt(DIRECTIONS)) bound it (the Sobol directions do
    better than plain Monte Carlo), plus nothing else: both sides are exact arithmetic otherwise."""
    rng = np.random.default_rng(seed)
    points = moocore.generate_ndset(300, 4, method="simplex", seed=seed) * 0.8 + 0.05 * rng.random((300, 4))
    ref = np.full(4, 1.0)
    tracker = ProgressHypervolume(ref)
    tracker.add(points)
    exact = moocore.hypervolume(points, ref=ref)
    terms = tracker.scale * tracker.rho**4
    budget = 4.0 * terms.std() / math.sqrt(DIRECTIONS)
    assert abs(tracker.value() - exact) <= budget
    one = ProgressHypervolume(ref)  # a single box: volume prod(ref - z)
    one.add(np.array([[0.2, 0.4, 0.5, 0.1]]))
    box = 0.8 * 0.6 * 0.5 * 0.9
    assert abs(one.value() - box) <= 4.0 * (one.scale * one.rho**4).std() / math.sqrt(DIRECTIONS)


def test_orthant_area_closed_forms():
    assert orthant_area(2) == pytest.approx(math.pi / 2, rel=1e-15)  # a quarter circle's arc
    assert orthant_area(3) == pytest.approx(4 * math.pi / 8, rel=1e-15)  # an eighth of the sphere


def test_convergence_rule():
    history = [1.0, 2.0, 2.5, 2.6, 2.601, 2.6015]
    assert not converged(history[:2], window=2, tolerance=0.01)  # not a whole window yet
    assert not converged(history[:4], window=2, tolerance=0.01)  # 2.6 - 2.0 > 0.026
    assert converged(history, window=2, tolerance=0.01)  # 2.6015 - 2.6 <= 0.026015
    assert not converged([0.0, 0.0, 0.0], window=1, tolerance=0.01)  # no volume yet: no stop


def test_bad_stop_settings_name_the_key(problem):
    from hisopt.optim.settings import resolve_settings
    from hisopt.problem import problem_from_dict

    with pytest.raises(ConfigError, match="--until"):
        resolve_settings(problem, until="soon")
    spec = problem.spec.model_dump(mode="json", by_alias=True)
    for key, value in (("until", "soon"), ("tolerance", 0.0), ("window", 0)):
        bad = spec | {"optimizer": spec["optimizer"] | {key: value}}
        with pytest.raises(ConfigError, match=f"optimizer.{key}"):
            problem_from_dict(bad, "p.toml")
