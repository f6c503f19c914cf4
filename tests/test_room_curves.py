"""The decision room's curves (docs/model.md §19): the spectra from the evaluator's own channels
(poles and residues, the direct solve where a design's form is not trusted) against every
design's direct solve of its dynamic stiffness (``method="direct"``, the reference).

Error budget (tests/error_budget.py): both paths compute the same PSDs by different arithmetic,
so they agree to the rounding of the eigendecompositions of the two symmetric halves
(:func:`tests.error_budget.pole_budget`, each pole's condition number times its shift's effect
on the band) plus that of the direct solves (:func:`tests.error_budget.solve_budget`, Skeel's
bound on the network and the 7 x 7 solves), a PSD's twice an FRF's. Compared per design and
output relative to that output's largest value over the band (the bounds are normwise: a PSD
far below its peak carries the peak's absolute error). A design whose form is not trusted takes
the direct solve itself: the same arithmetic but for the road PSD's power law written
``G_1 f^-w`` (:func:`hisopt.standards.iso_8608_2016.temporal_power_law`) instead of
:func:`~hisopt.standards.iso_8608_2016.temporal_psd`'s form, a few roundings
(:data:`SAME_SOLVE`).
"""

from __future__ import annotations

import numpy as np
import pytest

import hisopt
import hisopt.evaluation.channels as channels
from hisopt.constants import G_MPS2
from hisopt.evaluation.symmetry import split, state_mirror
from hisopt.evaluation.transient import RESIDUE_CHECK, gravity_softened, modal_form, roll_moment_input, static_roll_gain
from hisopt.problem import problem_from_dict
from hisopt.specification.validation import admissible
from hisopt.studies.decision_room import design_curves
from tests.conftest import ROOT, random_designs
from tests.error_budget import EPS, assert_discriminating, pole_budget, solve_budget

SAME_SOLVE = 64 * EPS
"""[-] Relative difference of a direct solve's PSD taken with the road PSD in its two written
forms (each a handful of roundings in a power and a product)."""


def _problems() -> dict[str, hisopt.Problem]:
    return {name: hisopt.load_problem(ROOT / "problems" / f"{name}.toml") for name in ("roll_plane_his", "roll_plane_his_parts")}


@pytest.fixture(scope="module")
def problems() -> dict[str, hisopt.Problem]:
    return _problems()


def _designs(p: hisopt.Problem, rng: np.random.Generator) -> np.ndarray:
    """Designs across the box: random ones, the box's corners, the baseline and a shorted valve."""
    x = random_designs(p, 24, rng, corners=False)
    x = x[admissible(p, x)][:12]  # a parts problem's bore and rod drawn apart may make no cylinder
    corners = p.lower + (p.upper - p.lower) * np.array([[0.0] * p.lower.size, [1.0] * p.lower.size])
    shorted = p.baseline.copy()
    shorted[list(p.variable_names).index("Rv")] = 0.0  # R_v = 0: the valves merged away (another state space)
    return np.vstack([x, corners, p.baseline, shorted])


def _budget(p: hisopt.Problem, x: np.ndarray, f_hz: np.ndarray) -> np.ndarray:
    """[-] Each design's relative budget of a PSD (module docstring)."""
    out = np.empty(len(x))
    for rows, model in p.model(x).groups():
        ss = model.state_space()
        halves = split(ss, state_mirror(model, ss))
        forms = [h.a for h in halves.values()] if halves is not None else [ss.a]
        out[rows] = pole_budget(forms, f_hz[0], f_hz[-1], power=2) + solve_budget(model, f_hz, power=2)
    return out


def _solve_budget(p: hisopt.Problem, x: np.ndarray, f_hz: np.ndarray) -> np.ndarray:
    """[-] Each design's relative budget of a direct solve's PSD (Skeel's bound, tests/error_budget.py)."""
    out = np.empty(len(x))
    for rows, model in p.model(x).groups():
        out[rows] = solve_budget(model, f_hz, power=2)
    return out


def _step_budget(p: hisopt.Problem, x: np.ndarray, step_g: float) -> np.ndarray:
    """[rad] Each design's budget of its step response from the antisymmetric half against the
    full state space's: a form is trusted when its identity ``phi(0) = 0`` holds within
    ``RESIDUE_CHECK`` of its modes' amplitudes ``sum |r_k / lambda_k|`` (hisopt/evaluation/transient.py),
    the accuracy of either form's sum; the two forms' errors add."""
    out = np.empty(len(x))
    for rows, model in p.model(x).groups():
        a = model.state_space().a
        b = np.broadcast_to(roll_moment_input(model.car, a.shape[-1]), a.shape[:-1])
        gravity = p.spec.handling.gravity_moment
        form, _ = modal_form(gravity_softened(a, b) if gravity else a, b, static_roll_gain(model, gravity))
        out[rows] = 2 * RESIDUE_CHECK * step_g * G_MPS2 * np.sum(np.abs(form.res / form.lam), axis=1)
    return out


def _excess(fast: np.ndarray, exact: np.ndarray, budget: np.ndarray) -> np.ndarray:
    """Per design, the largest ``|fast - exact| / max_f exact`` over frequencies and outputs, over its budget."""
    scale = np.max(exact, axis=1, keepdims=True)
    return np.max(np.abs(fast - exact) / scale, axis=(1, 2)) / budget


@pytest.mark.parametrize("name", ["roll_plane_his", "roll_plane_his_parts"])
def test_the_spectra_equal_the_direct_solve_within_their_budget(problems, rng, name):
    p = problems[name]
    x = _designs(p, rng)
    fast, exact = design_curves(p, x), design_curves(p, x, method="direct")
    budget = _budget(p, x, fast.f_hz)
    assert_discriminating(budget)
    excess = _excess(fast.spectra, exact.spectra, budget)
    assert np.all(excess <= 1.0), (float(excess.max()), int(np.argmax(excess)))
    assert np.all(np.isfinite(fast.spectra)) and np.all(fast.spectra > 0)
    np.testing.assert_array_equal(np.isnan(fast.step), np.isnan(exact.step))
    step = np.abs(fast.step - exact.step) / _step_budget(p, x, fast.step_g)[:, None]
    assert np.all(step[np.isfinite(step)] <= 1.0), float(np.nanmax(step))


def test_a_design_whose_form_is_not_trusted_takes_the_direct_solve(problems, rng, monkeypatch):
    """Forced: with the trust limit at the batch's median eigenvector conditioning, half the
    designs take the direct solve inside one batch (the evaluator's MixedChannels)."""
    p = problems["roll_plane_his_parts"]
    x = _designs(p, rng)[:12]
    ((_, model),) = p.model(x).groups()
    conditioning = channels.ModalChannels(model, model.state_space(), {"roll": p.evaluator().all_outputs["roll"]}).conditioning
    limit = float(np.median(conditioning))
    monkeypatch.setattr(channels, "CONDITION_LIMIT", limit)
    untrusted = conditioning > limit
    assert 0 < untrusted.sum() < len(x)
    fast, exact = design_curves(p, x), design_curves(p, x, method="direct")
    # the same direct solve in a batch of another size: its matrices assembled by products whose
    # kernels (and so roundings) may differ with the batch's shape, so each path is within its
    # own solve's budget of the exact spectrum, the two within twice that
    same = _excess(fast.spectra[untrusted], exact.spectra[untrusted], 2 * _solve_budget(p, x[untrusted], fast.f_hz))
    assert np.all(same <= 1.0), float(same.max())
    excess = _excess(fast.spectra[~untrusted], exact.spectra[~untrusted], _budget(p, x[~untrusted], fast.f_hz))
    assert np.all(excess <= 1.0), float(excess.max())


def test_pipes_of_1e10_m_get_the_direct_solve(problems, rng):
    """Pipes of 1e-10 m make the state matrix span 1 to 1e23: no design's poles and residues are
    trusted (tests/test_accuracy.py), and every spectrum is the direct solve's."""
    data = problems["roll_plane_his"].spec.model_dump(by_alias=True)
    data["his"].update({"pipes": {"diameter": 0.002, "length_front": 1e-10, "length_rear": 1e-10}})
    p = problem_from_dict(data, "pipes of 1e-10 m")
    x = random_designs(p, 4, rng, corners=False)
    ((_, model),) = p.model(x).groups()
    assert channels.road_channels(model, {"roll": p.evaluator().all_outputs["roll"]})[2].all()
    fast, exact = design_curves(p, x), design_curves(p, x, method="direct")
    np.testing.assert_allclose(fast.spectra, exact.spectra, rtol=SAME_SOLVE, atol=0)


def test_a_batch_gives_each_design_its_own_curves(problems, rng):
    """Determinism contract (docs/model.md §10): a batch changes rounding, never more."""
    p = problems["roll_plane_his_parts"]
    x = _designs(p, rng)
    together = design_curves(p, x)
    for i in (0, len(x) - 2, len(x) - 1):  # a random design, the baseline, the shorted valve
        alone = design_curves(p, x[i : i + 1])
        np.testing.assert_allclose(alone.spectra[0], together.spectra[i], rtol=1e-12, atol=0)
        np.testing.assert_allclose(alone.step[0], together.step[i], rtol=1e-12, atol=1e-12 * np.nanmax(np.abs(together.step[i])))


def test_the_curve_method_is_checked(problems):
    p = problems["roll_plane_his"]
    with pytest.raises(ValueError, match="modal, direct"):
        design_curves(p, p.baseline[None, :], method="fast")


def test_distributed_pipes_get_the_direct_solve(rng):
    """The evaluator's channels of distributed pipes are the direct solve (§10.1): the same
    spectra both ways, and the step response of the lumped twin's full state space."""
    p = hisopt.load_problem(ROOT / "problems" / "roll_plane_his_pipes.toml")
    x = random_designs(p, 3, rng, corners=False)
    fast, exact = design_curves(p, x), design_curves(p, x, method="direct")
    np.testing.assert_allclose(fast.spectra, exact.spectra, rtol=SAME_SOLVE, atol=0)
    np.testing.assert_array_equal(fast.step, exact.step)
