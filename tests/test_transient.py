"""Transient roll quantities (hisopt/evaluation/transient.py, docs/model.md §6.6) against independent
methods: the static roll gradient, the time-domain simulator (scipy's integrator on the same
state space, with the roll moment as an external body force), a direct solve of the dynamic
stiffness on a very fine grid, and the CLI."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

import hisopt
from hisopt.constants import G_MPS2
from hisopt.errors import ConfigError
from hisopt.evaluation.psd import roll_gradient
from hisopt.evaluation.transient import NAMES, direct_response, modal_form, roll_moment_input, transient_quantities
from hisopt.problem import problem_from_dict
from hisopt.simulation.timedomain import simulate
from tests.conftest import ROOT
from tests.error_budget import EPS, SAFETY, assert_discriminating, assert_within, pole_budget, solve_budget, state_space_budget

STEP_G = 0.4
DESIGNS = np.array([[2.0e6, 10e-4, 0.5, 8e5], [0.0, 1e-4, 0.1, 0.0]])


def _form(model, gravity_moment):
    ss = model.state_space()
    n, size = ss.a.shape[0], ss.a.shape[-1]
    b = np.broadcast_to(roll_moment_input(model.vehicle, size), (n, size))
    a = _with_gravity(ss.a, model.vehicle) if gravity_moment else ss.a
    static = -np.linalg.solve(a, b[..., None])[:, 1, 0]
    return modal_form(a, b, static)


def _with_gravity(a, v):
    """The state matrices with the body's weight moment ``m_s g h_0s phi`` on the roll
    acceleration row (state 7 + 1), by hand: its roll stiffness falls by ``m_s g h_0s``."""
    out = np.array(a, dtype=float)
    out[..., 8, 1] += v.m_s * G_MPS2 * v.h_0s / v.I_x
    return out


@pytest.fixture(scope="module")
def axle_roll() -> hisopt.Problem:
    return hisopt.load_problem(ROOT / "problems" / "layout_axle_roll.toml")


def test_moment_input_matches_the_dynamic_stiffness(problem, axle_roll):
    for p in (problem, axle_roll):
        model = p.model(p.baseline[None]).groups()[0][1]
        ss = model.state_space()
        s = 2j * np.pi * np.array([0.3, 1.7, 9.0])
        moment = roll_moment_input(model.vehicle, ss.a.shape[-1])[None]
        f_hz = s.imag / (2 * np.pi)  # the two solves' rounding (tests/error_budget.py)
        budget = solve_budget(model, f_hz, power=1) + state_space_budget(model, f_hz, inputs=moment[..., None])
        assert_discriminating(budget)
        v = model.vehicle
        for gravity in (False, True):  # the weight's moment softens the roll entry of D(s) by m_s g h_0s
            via_states = direct_response(f_hz * np.ones((1, 3)), ss.a, moment, None, v, gravity)
            kdyn = model.dynamic_stiffness(s) - gravity * v.m_s * G_MPS2 * v.h_0s * np.diag(np.eye(7)[1])
            via_stiffness = v.m_s * v.h_0s * np.linalg.inv(kdyn)[..., 1, 1]
            assert_within(via_states, via_stiffness, budget[:, None], "roll per moment")
            assert_within(direct_response(f_hz * np.ones((1, 3)), ss.a, moment, model, v, gravity), via_stiffness, budget[:, None], "model")


def test_steady_state_and_zero_frequency_gain_equal_the_roll_gradient(problem, axle_roll):
    # the paper's problem without the gravity moment, axle_roll (the default) with it
    assert not problem.spec.handling.gravity_moment and axle_roll.spec.handling.gravity_moment
    for p in (problem, axle_roll):
        gravity = p.spec.handling.gravity_moment
        model = p.model(DESIGNS if p is problem else p.baseline[None])
        gradient = roll_gradient(model.stiffness(), model.vehicle, gravity)  # [rad/g]
        group = model.groups()[0][1]
        form, trusted = _form(group, gravity)
        assert trusted.all()
        # the budgets (tests/error_budget.py): the static solve of the state matrix against the
        # 7 x 7 stiffness's, and the poles' rounding at 0 Hz for the pole-residue form's H(0)
        ss = group.state_space()
        moment = np.broadcast_to(roll_moment_input(group.vehicle, ss.a.shape[-1]), ss.a.shape[:-1])[..., None]
        static = state_space_budget(group, np.zeros(1), inputs=moment) + SAFETY * EPS * np.linalg.cond(model.stiffness())
        modal = static + pole_budget([ss.a], 0.0, 0.0, power=1)
        assert_discriminating(modal)
        # the step response settles at the roll gradient times the step, H(0) per m/s^2
        assert_within(form.static * STEP_G * G_MPS2, gradient * STEP_G, static, "static")
        late = form(np.full((len(form.lam), 1), 200.0), 0)[:, 0]
        assert_within(late, gradient / G_MPS2, static, "late")
        assert_within(form.frequency_response(np.zeros((len(form.lam), 1)))[:, 0], gradient / G_MPS2, modal, "H(0)")


@pytest.mark.parametrize("which", ["default", "axle_roll"])
def test_peaks_match_the_time_domain_simulator(problem, axle_roll, which):
    p = problem if which == "default" else axle_roll
    x = DESIGNS if which == "default" else np.vstack([p.baseline, p.lower + 0.3 * (p.upper - p.lower)])
    for design in x:
        model = p.model(design[None])
        q = transient_quantities(model, model.vehicle, NAMES, STEP_G, False)  # the simulator's force is the lateral force's moment alone
        v = model.vehicle
        t = np.linspace(0.0, 4.0, 20_001)
        force = np.zeros(7)
        force[1] = v.m_s * STEP_G * G_MPS2 * v.h_0s
        r = simulate(model, t, np.zeros((len(t), 4)), body_force=force, rtol=1e-10)
        phi, rate = r.displacement[:, 1], r.velocity[:, 1]
        steady = roll_gradient(model.stiffness(), v, False)[0] * STEP_G
        assert q["roll_step_peak"][0] == pytest.approx(np.abs(phi).max(), rel=5e-3)
        assert q["roll_rate_peak"][0] == pytest.approx(np.abs(rate).max(), rel=5e-3)
        assert q["roll_step_overshoot"][0] == pytest.approx(np.abs(phi).max() / steady - 1, rel=5e-3)
        # in fact the refined peaks are never below the samples, and within 1e-6 of them
        assert np.abs(phi).max() <= q["roll_step_peak"][0] * (1 + 1e-8) and np.abs(phi).max() >= q["roll_step_peak"][0] * (1 - 1e-6)
        assert q["roll_step_overshoot"][0] > 0.05  # a real overshoot is being compared


def test_steps_with_the_gravity_moment_match_an_exact_discretisation(axle_roll):
    # issue 40: with the body's weight moment (axle_roll's default) the step response is that of
    # the state matrix softened by hand (_with_gravity), stepped exactly: x_(k+1) = E x_k + F with
    # E = e^(A dt), F = A^-1 (E - I) b a (a constant input between samples, so no discretisation
    # error); the sampled peaks bracket the refined ones as the simulator's do, and the response
    # settles at the roll gradient with the gravity moment times the step
    p = axle_roll
    for design in (p.baseline, p.lower + 0.3 * (p.upper - p.lower)):
        model = p.model(design[None])
        v = model.vehicle
        q = transient_quantities(model, v, NAMES, STEP_G, True)
        without = transient_quantities(model, v, NAMES, STEP_G, False)
        ss = model.groups()[0][1].state_space()
        a = _with_gravity(ss.a[0], v)
        b = roll_moment_input(v, a.shape[-1]) * STEP_G * G_MPS2
        dt, steps = 2e-4, 60_000
        e = scipy.linalg.expm(a * dt)
        f = np.linalg.solve(a, (e - np.eye(len(a))) @ b)
        x, phi, rate = np.zeros(len(a)), np.empty(steps + 1), np.empty(steps + 1)
        phi[0] = rate[0] = 0.0
        for k in range(steps):
            x = e @ x + f
            phi[k + 1], rate[k + 1] = x[1], x[8]
        steady = roll_gradient(model.stiffness(), v, True)[0] * STEP_G
        assert q["roll_step_peak"][0] >= np.abs(phi).max() * (1 - 1e-9) and q["roll_step_peak"][0] <= np.abs(phi).max() * (1 + 1e-6)
        assert q["roll_rate_peak"][0] >= np.abs(rate).max() * (1 - 1e-9) and q["roll_rate_peak"][0] <= np.abs(rate).max() * (1 + 1e-6)
        assert q["roll_step_overshoot"][0] == pytest.approx(q["roll_step_peak"][0] / steady - 1, rel=1e-9)
        assert phi[-1] == pytest.approx(steady, rel=1e-6)  # 12 s: every mode has died out
        assert q["roll_step_peak"][0] > without["roll_step_peak"][0] * 1.01  # the weight's moment is being compared
        # the gain from the softened dynamic stiffness by direct solve at its refined peak
        kdyn = model.dynamic_stiffness(2j * np.pi * q["roll_gain_peak_hz"][:, None])[0, 0]
        kdyn[1, 1] -= v.m_s * G_MPS2 * v.h_0s
        assert q["roll_gain_peak"][0] == pytest.approx(abs(v.m_s * v.h_0s * np.linalg.inv(kdyn)[1, 1]), rel=1e-9)


def test_gain_peak_is_refined_off_the_grid(problem):
    model = problem.model(DESIGNS)
    q = transient_quantities(model, model.vehicle, ["roll_gain_peak", "roll_gain_peak_hz"], STEP_G, False)
    f = np.linspace(0.1, 4.0, 400_001)
    for i in range(len(DESIGNS)):
        sub = model.subset(np.array([i]))
        fine = np.abs(direct_response(f[None], np.zeros((1, 1, 1)), np.zeros((1, 1)), sub, model.vehicle, False))[0]
        j = np.argmax(fine)
        assert q["roll_gain_peak"][i] == pytest.approx(fine[j], rel=1e-6)
        assert q["roll_gain_peak_hz"][i] == pytest.approx(f[j], abs=2e-5)
        assert q["roll_gain_peak"][i] >= fine[j] * (1 - 1e-12)
        coarse = np.abs(direct_response(np.linspace(0.1, 4.0, 14)[None], np.zeros((1, 1, 1)), np.zeros((1, 1)), sub, model.vehicle, False))[0]
        assert coarse.max() < q["roll_gain_peak"][i] * (1 - 1e-3)  # a plain grid misses the peak


def test_unstable_and_singular_designs_give_nan(problem):
    model = problem.model(DESIGNS[:1])
    ss = model.state_space()
    a = ss.a.copy()
    a[0, 8, 8] = +50.0  # negative roll damping: unstable
    q = transient_quantities(type(ss)(a, ss.b0, ss.b1, ss.labels, ss.kinetic_weights), model.vehicle, NAMES, STEP_G, False)
    assert all(np.isnan(q[name]).all() for name in NAMES)
    df = problem.evaluate(np.array([[2e6, 10e-4, 1.0, 8e5]]))  # lam = 1: singular, not evaluated
    assert df["status"].iloc[0] != "ok"


def test_evaluator_and_the_step_size(problem):
    data = problem.spec.model_dump(by_alias=True)
    data["objectives"] = ["sigma_aw", "roll_step_peak", "roll_gain_peak"]
    data["constraints"] = [{"name": "roll_rate_peak", "limit": 1.0}, {"name": "roll_step_overshoot", "limit": 2.0}]
    p = problem_from_dict(data)
    data["handling"] = data["handling"] | {"step_g": 0.8}
    twice = problem_from_dict(data)
    a, b = p.evaluate(DESIGNS), twice.evaluate(DESIGNS)
    np.testing.assert_allclose(b["roll_step_peak"], 2 * a["roll_step_peak"], rtol=1e-12)
    np.testing.assert_allclose(b["roll_step_overshoot"], a["roll_step_overshoot"], rtol=1e-12)
    np.testing.assert_allclose(b["roll_gain_peak"], a["roll_gain_peak"], rtol=1e-12)
    assert a.attrs["units"]["roll_step_peak"] == "rad" and a.attrs["units"]["roll_rate_peak"] == "rad/s"
    assert a.attrs["units"]["roll_gain_peak"] == "rad/(m/s^2)"
    np.testing.assert_allclose(a["sigma_aw"], problem.evaluate(DESIGNS)["sigma_aw"], rtol=1e-12)


def test_problem_file_rules(problem):
    data = problem.spec.model_dump(by_alias=True)
    data["objectives"] = ["sigma_aw", "roll_gain_peak_hz"]
    with pytest.raises(ConfigError, match="roll_gain_peak_hz.*constrain it"):
        problem_from_dict(data)
    data["objectives"] = ["sigma_aw"]
    data["handling"] = {"step_g": 0.0}
    with pytest.raises(ConfigError, match="handling.step_g"):
        problem_from_dict(data)
    data["handling"] = {"gravity_moment": "no"}  # a TOML boolean, not a word
    with pytest.raises(ConfigError, match="handling.gravity_moment: expected a valid boolean"):
        problem_from_dict(data)


def test_a_gravity_moment_that_is_not_a_boolean_is_refused_in_one_line(tmp_path):
    from tests.cli_inprocess import run_cli

    path = tmp_path / "bad.toml"
    path.write_text((ROOT / "problems" / "roll_plane_his.toml").read_text().replace("gravity_moment = false", "gravity_moment = 1"))
    out = run_cli("evaluate", str(path))
    assert out.code == 2 and out.error_lines == [f"error: {path}: handling.gravity_moment: expected a valid boolean, got 1"]


def test_finite_difference_designs_stay_in_the_box():
    from hisopt.optim.gradient.transient_callback import difference_designs

    u = np.array([0.0, 0.5, 1.0])
    designs, spread = difference_designs(u, 1e-3)
    assert designs.shape == (7, 3) and np.all((designs >= 0) & (designs <= 1))
    np.testing.assert_allclose(spread, 2e-3)
    np.testing.assert_allclose(designs[1:4] - designs[4:], np.diag(spread))  # u + up_i e_i - (u - down_i e_i)


def test_refinement_callback_equals_the_evaluator_and_its_slopes(problem):
    from hisopt.optim.gradient.transient_callback import TransientCallback

    names = ["roll_step_peak", "roll_rate_peak", "roll_gain_peak"]
    span = problem.upper - problem.lower
    cb = TransientCallback(problem, names, problem.lower, span)
    u = np.array([0.4, 0.3, 0.6, 0.5])
    value, jac = cb.evaluate(u, jacobian=True)
    data = problem.spec.model_dump(by_alias=True)
    data["objectives"] = names
    q = problem_from_dict(data).evaluator()((problem.lower + span * u)[None])
    np.testing.assert_allclose(value, [q[n][0] for n in names], rtol=1e-12)
    for i in range(4):  # a wider central difference, independently: slopes agree to its truncation and noise
        e = np.eye(4)[i] * 4e-3
        wide = (cb.values((u + e)[None]) - cb.values((u - e)[None]))[0] / 8e-3
        np.testing.assert_allclose(jac[:, i], wide, rtol=1e-2)


def test_refinement_meets_a_step_steer_limit(problem):
    """The CasADi refinement with a roll_step_peak constraint: the refined design improves on
    its start and the evaluator confirms it meets the limit."""
    from hisopt.optim.gradient.casadi_model import CasadiModel
    from hisopt.optim.gradient.refine import Part, RefineSettings, refine_point

    data = problem.spec.model_dump(by_alias=True)
    q0 = problem_from_dict(data | {"objectives": ["roll_step_peak"]}).evaluator()(problem.baseline[None])
    limit = 1.02 * float(q0["roll_step_peak"][0])  # softer roll would help comfort: the limit binds
    data["objectives"] = ["sigma_aw", "max_tire_load_psd"]
    data["constraints"] = [{"name": "roll_step_peak", "limit": limit}]
    p = problem_from_dict(data)
    x0 = p.baseline
    q = p.evaluator()(x0[None])
    f0 = np.array([q[n][0] for n in p.objective_names])
    result = refine_point(p, [Part(None, p, CasadiModel(p, compile=False))], 0, x0, f0, np.full(2, 3.0), RefineSettings(rounds=3))
    q1 = p.evaluator()(result.x[None])
    f1 = np.array([q1[n][0] for n in p.objective_names])
    assert result.accepted and np.all(f1 <= f0) and np.any(f1 < f0 * (1 - 1e-3))
    assert q1["roll_step_peak"][0] <= limit


def test_cli_evaluates_a_problem_with_transient_quantities(tmp_path):
    from tests.cli_inprocess import run_cli

    text = (ROOT / "problems" / "roll_plane_his.toml").read_text()
    text = text.replace('objectives = ["sigma_aw", "max_roll_psd", "max_stroke_psd", "max_tire_load_psd"]', 'objectives = ["sigma_aw", "roll_gain_peak"]')
    text = text.replace("gravity_moment = false", "gravity_moment = false\nstep_g = 0.5")
    text += '\n[[constraints]]\nname = "roll_step_peak"\nlimit = 0.05\n'
    path = tmp_path / "transient.toml"
    path.write_text(text)
    result = run_cli("evaluate", str(path))
    assert result.code == 0, result.stderr
    assert "roll_step_peak [deg]" in result.stdout and "roll_gain_peak [deg/(m/s^2)]" in result.stdout
