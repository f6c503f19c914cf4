"""Coupled model: state space vs frequency domain, static limits, symmetry."""

import numpy as np

from hisopt.coupled.modal import refine_roots
from hisopt.coupled.model import CoupledModel
from tests.conftest import random_designs
from tests.error_budget import assert_discriminating, assert_frf_within, solve_budget, state_space_budget, state_space_frf

F_HZ = np.geomspace(0.3, 100, 80)
S = 2j * np.pi * F_HZ


def test_state_space_frf_equals_direct_solve(problem, rng):
    x = random_designs(problem, 8, rng)
    model = problem.model(x)
    direct = model.frequency_response(S)
    budget = solve_budget(model, F_HZ, power=1) + state_space_budget(model, F_HZ)  # tests/error_budget.py
    assert_discriminating(budget)
    assert_frf_within(state_space_frf(model.state_space(), F_HZ), direct, budget, "state space")


def test_state_space_with_pipes_equals_lumped_direct_solve(problem, rng):
    pipes = {"diameter": 0.01, "length_front": 1.0, "length_rear": 2.5}
    p = problem.with_values(pipes=pipes, chamber_volume=1e-4)
    model = p.model(random_designs(p, 4, rng, corners=False))
    direct = model.frequency_response(S)
    budget = solve_budget(model, F_HZ, power=1) + state_space_budget(model, F_HZ)  # tests/error_budget.py
    assert_discriminating(budget)
    assert_frf_within(state_space_frf(model.state_space(), F_HZ), direct, budget, "state space with pipes")


def test_static_stiffness_symmetric_positive_definite(problem, rng):
    k = problem.model(random_designs(problem, 10, rng)).stiffness()
    np.testing.assert_allclose(k, np.swapaxes(k, -1, -2), rtol=1e-12, atol=1e-9)
    assert np.linalg.eigvalsh(k).min() > 0


def test_low_frequency_body_follows_road_and_tyre_force_vanishes(problem, rng):
    """At f -> 0 rear wheels see the same track as the front: body follows, no tyre force."""
    model = problem.model(random_designs(problem, 5, rng))
    s = 2j * np.pi * np.array([1e-5])
    h = model.frequency_response(s)[..., 0, :, :]  # (n, 7, 4)
    track = np.array([[1, 0], [0, 1], [1, 0], [0, 1.0]])  # left, right tracks, no delay
    x = h @ track
    tyre = x[..., 3:, :] - track  # wheel minus road displacement
    assert np.abs(tyre).max() < 1e-8
    v = problem.spec.vehicle
    # Body heave and roll follow the mean and difference of the tracks.
    np.testing.assert_allclose(x[..., 0, :], 0.5, rtol=1e-7)
    np.testing.assert_allclose(x[..., 1, 0], 0.5 / v.t_f, rtol=1e-7)


def test_left_right_mirror_symmetry(problem, rng):
    """Swapping left and right inputs mirrors roll and the wheels (circuits A and B swap)."""
    model = problem.model(random_designs(problem, 4, rng))
    h = model.frequency_response(S)
    swap = [1, 0, 3, 2]
    mirror = np.diag([1, -1, 1, 1, 1, 1, 1.0])[[0, 1, 2, 4, 3, 6, 5]]
    # the mirrored inputs' columns come from the same LU: equal within its rounding
    assert_frf_within(h[..., swap], mirror @ h, solve_budget(model, F_HZ, power=1), "mirror")


def test_state_space_eigenvalues_are_roots_of_dynamic_stiffness(problem, rng):
    for x in random_designs(problem, 3, rng, corners=False):
        model = problem.model(x)
        lam = np.linalg.eigvals(model.state_space().a[0])
        lam = lam[(lam.imag > 1e-6) & (np.abs(lam) > 1e-6)]
        sv = np.linalg.svd(model.dynamic_stiffness(lam)[0], compute_uv=False)
        assert np.all(sv[:, -1] / sv[:, 0] < 1e-10)
        # Newton on det K_dyn from perturbed starts converges back to the eigenvalues.
        refined = refine_roots(model, lam * (1 + 1e-3 * (1 + 1j)))
        np.testing.assert_allclose(refined, lam, rtol=1e-8)


def test_reference_vehicle_has_no_his(problem):
    ref = problem.model(his=False)
    assert isinstance(ref, CoupledModel) and ref.his is None
    assert ref.state_space().n_states == 14
