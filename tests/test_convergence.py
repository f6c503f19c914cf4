"""The run engine's cost-independent parts: the archive update, the progress hypervolume and
the convergence rule, each against an independent computation."""

from __future__ import annotations

import math

import moocore
import numpy as np
import pytest

from hisopt.errors import ConfigError
from hisopt.optim.archive import non_dominated_mask, pareto_update, weakly_dominates
from hisopt.optim.convergence import DIRECTIONS, ProgressHypervolume, converged, hypervolume_estimate, orthant_area


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
