"""hisopt's SMS-EMOA: its survival against pymoo's, its operators' rules, its determinism."""

from __future__ import annotations

import numpy as np
import pytest
from pymoo.algorithms.moo.sms import LeastHypervolumeContributionSurvival
from pymoo.core.population import Population
from pymoo.core.problem import Problem as PymooProblem

from hisopt.optim.hv_emoa import REFERENCE_OFFSET, LeastContributorSurvival, search_objectives
from hisopt.optim.operators import FACE_SHARE, BoxSampling, FaceMutation, on_faces
from hisopt.optim.run import optimize
from tests.conftest import DEFAULT_PROBLEM


def population(f: np.ndarray) -> Population:
    pop = Population.new(X=np.zeros((len(f), 2)))
    pop.set("F", f, "G", np.zeros((len(f), 1)))
    return pop


class Box(PymooProblem):  # type: ignore[misc]
    def __init__(self, n_obj: int = 3):
        super().__init__(n_var=4, n_obj=n_obj, n_ieq_constr=1, xl=np.array([0.0, -1.0, 2.0, 0.0]), xu=np.array([1.0, 1.0, 5.0, 1e6]))


@pytest.mark.parametrize("seed", range(4))
def test_survival_keeps_what_pymoos_sms_emoa_keeps(seed):
    """Same normalisation and reference point, removal by moocore's contributions one at a
    time in pymoo: the same survivors in the same order (distinct random contributions, so no
    tie decides)."""
    rng = np.random.default_rng(seed)
    n_obj = 2 + seed % 3
    f = rng.random((30, n_obj))
    f[:20] /= np.linalg.norm(f[:20], axis=1, keepdims=True)  # a non-dominated shell, then some dominated
    f[20:] += 1.0
    ideal, nadir = f[:15].min(axis=0), f[:15].max(axis=0)
    ours = LeastContributorSurvival().do(Box(n_obj), population(f), n_survive=12, ideal=ideal, nadir=nadir)
    pymoos = LeastHypervolumeContributionSurvival(eps=REFERENCE_OFFSET).do(Box(n_obj), population(f), n_survive=12, ideal=ideal, nadir=nadir)
    np.testing.assert_array_equal(ours.get("F"), pymoos.get("F"))


def test_search_objectives_are_log10_and_keep_invalid_designs_infinite():
    f = np.array([[1.0, 100.0], [np.inf, np.inf]])
    np.testing.assert_array_equal(search_objectives(f), [[0.0, 2.0], [np.inf, np.inf]])


def test_on_faces_moves_the_outer_draws_to_the_bounds():
    u = np.array([0.3, 0.3, 0.3, 0.3])
    draw = np.array([0.0, FACE_SHARE / 2 - 1e-9, FACE_SHARE / 2, 1.0 - FACE_SHARE / 2])
    np.testing.assert_array_equal(on_faces(u, draw, FACE_SHARE), [0.0, 0.0, 0.3, 1.0])


def test_box_sampling_is_inside_the_box_spread_and_puts_a_share_on_the_faces():
    problem, n = Box(), 4000
    x = BoxSampling()._do(problem, n, random_state=np.random.default_rng(1))
    assert x.shape == (n, 4) and np.all(x >= problem.xl) and np.all(x <= problem.xu)
    on_face = (x == problem.xl) | (x == problem.xu)
    # each coordinate lands on a face with probability FACE_SHARE, independently: the share of
    # 16,000 draws is within 5 binomial standard deviations (sqrt(p (1 - p) / 16000) = 0.0034)
    assert abs(on_face.mean() - FACE_SHARE) < 5 * np.sqrt(FACE_SHARE * (1 - FACE_SHARE) / on_face.size)
    # the Latin hypercube: the interior draws of each variable fill every tenth of its range
    u = (x - problem.xl) / (problem.xu - problem.xl)
    for j in range(4):
        inner = u[~on_face[:, j], j]
        assert np.all(np.histogram(inner, bins=10, range=(0, 1))[0] > 0)


def test_face_mutation_moves_variables_onto_the_nearer_bound_only():
    problem = Box()
    rng = np.random.default_rng(2)
    x = problem.xl + rng.random((3000, 4)) * (problem.xu - problem.xl)
    y = FaceMutation(face_rate=2.0, eta=1e9)._do(problem, x, random_state=np.random.default_rng(3))
    moved = (y == problem.xl) | (y == problem.xu)
    nearer = np.where(x - problem.xl <= problem.xu - x, problem.xl, problem.xu)
    assert np.all(y[moved] == nearer[moved])
    assert np.all((y >= problem.xl) & (y <= problem.xu))
    # face_rate 2 over 4 variables: each moves with probability 1/2 (+ the rare polynomial
    # step that lands exactly on a bound, none with eta 1e9); 5 binomial standard deviations
    assert abs(moved.mean() - 0.5) < 5 * np.sqrt(0.25 / moved.size)


def test_a_seed_gives_the_same_front_and_another_seed_another():
    a = optimize(DEFAULT_PROBLEM, algorithm="smsemoa", pop_size=20, generations=4, seed=1)
    b = optimize(DEFAULT_PROBLEM, algorithm="smsemoa", pop_size=20, generations=4, seed=1)
    c = optimize(DEFAULT_PROBLEM, algorithm="smsemoa", pop_size=20, generations=4, seed=2)
    assert a.front.equals(b.front) and a.history.equals(b.history)
    assert not a.front.equals(c.front)
