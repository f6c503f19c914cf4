"""A payload: the laden car and the laden operating point of the HIS (docs/model.md §13).

Independent references: the static circuit pressure of a payload at the CG of the paper's
roll-plane layout from the strut forces by hand (a quadratic in closed form for an isothermal
gas, a bracketing root finder for the polytropic one); the laden mass, CG and inertia by the
parallel-axis theorem written out for body and payload; the laden accumulator stiffness
``gamma p_abs0 / V0 (p_abs / p_abs0)^(1 + 1/gamma)``; the CasADi graph against numpy.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from scipy.optimize import brentq

import hisopt
from hisopt.constants import G_MPS2, P_ATM_PA
from hisopt.coupled.modal import modal_table
from hisopt.coupled.model import CoupledModel
from hisopt.coupled.payload import Payload, laden_vehicle, payload_force, static_deflection, static_pressure_rise
from hisopt.errors import ConfigError
from hisopt.evaluation import channels, evaluate
from hisopt.evaluation.symmetry import split, state_mirror
from hisopt.hydraulics.coupling import HydraulicSystem
from hisopt.problem import problem_from_dict
from hisopt.vehicle import VehicleParams, body_to_corners, mass_matrix, stiffness_matrix
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT, random_designs


def laden_problem(payload: dict | None, source=DEFAULT_PROBLEM, vehicle: dict | None = None, **his) -> hisopt.Problem:
    data = tomllib.loads(source.read_text())
    data["his"] |= his
    data["vehicle"] |= vehicle or {}
    if payload is not None:
        data["payload"] = payload
    return problem_from_dict(data, warn_implausible=False)  # the hand checks include p0 = 0 (a plausibility warning)


# --- no payload ----------------------------------------------------------------------------------
def test_zero_payload_changes_nothing(problem, rng):
    x = random_designs(problem, 6, rng)
    empty = laden_problem({"mass": 0.0, "x": 0.7, "y": -0.3, "z": 0.4, "I_x": 5.0, "I_y": 9.0})
    assert laden_vehicle(problem.spec.vehicle, empty.spec.payload) is problem.spec.vehicle
    assert empty.vehicle == problem.vehicle
    a, b = problem.model(x), empty.model(x)
    assert b.his.static_rise is None
    np.testing.assert_array_equal(a.state_space().a, b.state_space().a)
    ra, rb = problem.evaluator()(x), empty.evaluator()(x)
    for name in problem.objective_names:
        np.testing.assert_array_equal(ra[name], rb[name], err_msg=name)
    ma, mb = hisopt.modal_analysis(problem, x[0]), hisopt.modal_analysis(empty, x[0])
    np.testing.assert_array_equal(ma["frequency_hz"], mb["frequency_hz"])


def test_a_zero_static_rise_is_the_precharge_linearisation_exactly(problem, rng):
    """The laden formulas at ``dp = 0`` reproduce today's element values bit for bit."""
    x = random_designs(problem, 6, rng)
    his = problem.model(x).his
    zero = HydraulicSystem(his.network, his.params, np.zeros(x.shape[:1] + (2,)))
    for k in his.values.shunt:
        np.testing.assert_array_equal(his.values.shunt[k], zero.values.shunt[k])
        for u, v in zip(his.values.gas[k], zero.values.gas[k], strict=True):
            np.testing.assert_array_equal(u, v)


# --- the laden car -------------------------------------------------------------------------------
def test_laden_vehicle_by_hand():
    v = VehicleParams(m_s=1000.0, I_x=400.0, I_y=2000.0, l_f=1.2, l_r=1.4, h_0s=0.3)
    p = Payload(mass=200.0, x=0.6, y=0.3, z=0.12, I_x=10.0, I_y=20.0)
    lv = laden_vehicle(v, p)
    c = np.array([0.6, 0.3, 0.12]) * 200.0 / 1200.0  # (0.1, 0.05, 0.02) m
    body, load = -c, np.array([0.6, 0.3, 0.12]) - c  # from the new CG
    assert lv.m_s == pytest.approx(1200.0, rel=1e-15)
    assert (lv.l_f, lv.l_r, lv.h_0s, lv.y_cg) == pytest.approx((1.1, 1.5, 0.32, 0.05), rel=1e-14)
    i_x = 400.0 + 1000.0 * (body[1] ** 2 + body[2] ** 2) + 10.0 + 200.0 * (load[1] ** 2 + load[2] ** 2)
    i_y = 2000.0 + 1000.0 * (body[0] ** 2 + body[2] ** 2) + 20.0 + 200.0 * (load[0] ** 2 + load[2] ** 2)
    assert (lv.I_x, lv.I_y) == pytest.approx((i_x, i_y), rel=1e-14)
    assert lv.wheelbase == pytest.approx(v.wheelbase, rel=1e-15)
    # the corners from the new CG: half track minus the CG's lateral offset
    np.testing.assert_allclose(body_to_corners(lv)[:, 1], [0.74 - 0.05, -0.74 - 0.05, 0.74 - 0.05, -0.74 - 0.05], rtol=1e-15)
    # static corner loads: total weight, and its moments about the new CG vanish
    loads = lv.static_corner_loads(G_MPS2)
    sprung = loads - G_MPS2 * np.array([lv.m_uf, lv.m_uf, lv.m_ur, lv.m_ur])
    assert sprung.sum() == pytest.approx(1200.0 * G_MPS2, rel=1e-14)
    np.testing.assert_allclose(body_to_corners(lv)[:, 1:].T @ sprung, 0.0, atol=1e-9)


def test_payload_force_is_the_weight_in_the_corner_kinematics():
    """``Q . X`` is the weight's work: minus W times the payload point's rise."""
    p = Payload(mass=150.0, x=0.4, y=-0.2)
    x = np.array([0.01, 0.02, -0.03, 0.0, 0.0, 0.0, 0.0])
    rise = x[0] + p.y * x[1] - p.x * x[2]  # z_s + y phi - x theta (body_to_corners' rows)
    assert payload_force(p) @ x == pytest.approx(-150.0 * G_MPS2 * rise, rel=1e-14)


def test_lateral_payload_breaks_the_mirror_and_is_evaluated_whole(rng, monkeypatch):
    p = laden_problem({"mass": 150.0, "y": 0.5})
    x = random_designs(p, 4, rng, corners=False)
    model = p.model(x)
    ss = model.state_space()
    assert split(ss, state_mirror(model, ss)) is None
    centred = laden_problem({"mass": 150.0})  # the check is not blind: a centred payload splits
    m_c = centred.model(x)
    ss_c = m_c.state_space()
    assert split(ss_c, state_mirror(m_c, ss_c)) is not None
    fast = p.evaluator()(x)
    monkeypatch.setattr(channels, "split", lambda ss, mirror: None)
    full = evaluate.Evaluator(p)(x)
    for name in p.objective_names:
        np.testing.assert_allclose(fast[name], full[name], rtol=1e-10, atol=0, err_msg=name)


# --- the static pressure rise ---------------------------------------------------------------------
@pytest.mark.parametrize("gamma", [1.0, 1.4])
@pytest.mark.parametrize("design", [(2.0e6, 10e-4, 0.5), (0.0, 25e-4, 0.8), (4.0e6, 1e-4, 0.1)])
def test_payload_at_the_cg_raises_the_pressure_by_hand(gamma, design):
    """A payload ``W`` at the CG of the symmetric default car, roll-plane layout.

    By symmetry both circuits rise by the same ``dp``; each strut's fluid force is then
    ``-(a_A + a_B) dp = (A_b - A_t) dp = dA dp`` (extending). The axle loads follow the lever
    rule whatever the springs (the pitch plane is statically determinate, the tyres are in
    series), so with ``P_f = W l_r / 2L`` per front strut the front compression is
    ``(P_f - dA dp) / k_s``, the rear likewise, and circuit A takes in
    ``dA (c_f + c_r) = dA (W / 2 - 2 dA dp) / k_s`` (``k_sf = k_sr = k_s``). Its accumulator
    stores ``V0 (1 - (p_abs0 / (p_abs0 + dp))^(1/gamma))``: for ``gamma = 1`` a quadratic in
    ``dp``, otherwise bracketed to rounding.
    """
    p0, d_a, lam = design
    w_kg = 350.0
    p = laden_problem({"mass": w_kg}, p0=p0, dA=d_a, lam=lam, gamma=gamma)
    model = p.model()
    dp = model.his.static_rise[0]
    v0, k_s, p_abs0, w = 1.0e-3, 18_000.0, p0 + P_ATM_PA, w_kg * G_MPS2
    beta, alpha = 2 * d_a**2 / k_s, d_a * w / (2 * k_s)  # stored(dp) + beta dp = alpha
    if gamma == 1.0:
        b = v0 + beta * p_abs0 - alpha
        expected = (-b + math.sqrt(b * b + 4 * beta * alpha * p_abs0)) / (2 * beta)
    else:
        f = lambda q: v0 * (1 - (p_abs0 / (p_abs0 + q)) ** (1 / gamma)) + beta * q - alpha  # noqa: E731
        expected = brentq(f, 0.0, alpha / beta, xtol=1e-14, rtol=4 * np.finfo(float).eps, maxiter=200)
    np.testing.assert_allclose(dp, [expected, expected], rtol=1e-9)
    # the laden accumulator: stiffness gamma p_abs0 / V0 (p_abs / p_abs0)^(1 + 1/gamma)
    k_acc = gamma * p_abs0 / v0 * ((p_abs0 + expected) / p_abs0) ** (1 + 1 / gamma)
    for k in model.his.values.shunt:
        assert 1.0 / model.his.values.shunt[k][0] == pytest.approx(k_acc, rel=1e-9)


def test_static_solution_is_the_same_in_the_laden_frame(problem, rng):
    """The oil balance holds, and the rise does not depend on the frame: the laden car with
    the payload's weight at its position from the new CG gives the same ``dp``."""
    p = laden_problem({"mass": 250.0, "x": -0.6, "y": 0.35, "z": 0.3})
    x = random_designs(p, 5, rng)
    his = p.model(x).his
    unladen = HydraulicSystem(his.network, his.params)
    payload = p.spec.payload
    lv = p.vehicle
    shifted = Payload(mass=payload.mass, x=payload.x - (p.spec.vehicle.l_f - lv.l_f), y=payload.y - lv.y_cg)
    np.testing.assert_allclose(static_pressure_rise(lv, shifted, unladen), his.static_rise, rtol=1e-10)
    # equilibrium of forces and of oil, by the residuals
    v = p.spec.vehicle
    xs = static_deflection(v, payload, unladen, his.static_rise)
    from hisopt.coupled.payload import circuit_areas
    from hisopt.vehicle import stroke_matrix

    a = circuit_areas(unladen)
    pushed = (a @ (stroke_matrix(v) @ xs[..., None]))[..., 0]
    g = stroke_matrix(v)
    force = (stiffness_matrix(v) @ xs[..., None])[..., 0] + (g.T @ np.swapaxes(a, -1, -2) @ his.static_rise[..., None])[..., 0]
    np.testing.assert_allclose(force, np.broadcast_to(payload_force(payload), force.shape), atol=1e-9 * payload.mass * G_MPS2)
    params = his.params
    stored = np.stack([1e-3 * (1 - ((params["p0"] + P_ATM_PA) / (params["p0"] + P_ATM_PA + his.static_rise[:, c])) ** (1 / 1.4)) for c in range(2)], axis=-1)
    np.testing.assert_allclose(stored, pushed, rtol=1e-10)


@pytest.mark.parametrize("source", ["roll_plane_his.toml", "layout_roll_plane_twin_accumulator.toml", "roll_plane_his_pipes.toml"])
def test_numpy_and_casadi_give_the_same_static_rise(source, rng):
    import casadi as ca

    p = laden_problem({"mass": 400.0, "x": 0.5, "y": -0.3, "z": 0.2}, ROOT / "problems" / source)
    x_sym = ca.MX.sym("x", len(p.variable_names))
    rise = p.hydraulic_system({n: x_sym[i] for i, n in enumerate(p.variable_names)}).static_rise
    fn = ca.Function("rise", [x_sym], [rise])
    x = random_designs(p, 4, rng, corners=False)
    numeric = p.hydraulic_system(p.his_parameters(x)).static_rise
    symbolic = np.array([np.asarray(fn(xi)).ravel() for xi in x])
    assert np.all(np.abs(numeric) > 1e3)  # a real rise, both circuits
    np.testing.assert_allclose(symbolic, numeric, rtol=1e-10)


def test_casadi_spectra_of_a_laden_car_equal_numpy(rng):
    from hisopt.evaluation.channels import DirectOutputs
    from hisopt.optim.gradient.casadi_model import CasadiModel

    p = laden_problem({"mass": 300.0, "x": 0.4, "y": 0.25, "z": 0.2})
    model, ev = CasadiModel(p, compile=False), p.evaluator()
    f = np.geomspace(0.5, 80.0, 40)
    fs = model.frequency_set(f, np.zeros_like(f))
    for x in random_designs(p, 2, rng, corners=False):
        mine = np.array(model.spectra(x, fs.params)).T
        ref = ev.spectra(f[None], DirectOutputs(p.model(x[None]), ev.outputs)(2 * np.pi * f[None]))[0]
        np.testing.assert_allclose(mine, ref, rtol=1e-8, atol=0)


# --- the laden HIS is stiffer ---------------------------------------------------------------------
def _hand_bounce_hz(v: VehicleParams, k_acc: float, d_a: float) -> float:
    """[Hz] Undamped bounce of the roll-plane car by hand, wheel masses left out.

    Each axle's two corners move together (a centred payload): strokes ``delta_f``,
    ``delta_r``; springs ``2 k_s`` per axle; both circuits take in ``-dA (delta_f + delta_r)``,
    so the accumulators store ``k_acc dA^2 (delta_f + delta_r)^2`` of energy; tyres ``2 k_t``
    per axle in series. Condensing the wheels and mapping the axles' body points to
    ``[z_s, theta]`` gives a 2-DOF pitch-plane problem.
    """
    k_strut = np.diag([2 * v.k_sf, 2 * v.k_sr]) + 2 * k_acc * d_a**2 * np.ones((2, 2))
    k_tyre = np.diag([2 * v.k_tf, 2 * v.k_tr])
    k_body = k_strut - k_strut @ np.linalg.solve(k_strut + k_tyre, k_strut)
    t = np.array([[1.0, -v.l_f], [1.0, v.l_r]])
    lam, vec = np.linalg.eig(np.linalg.solve(np.diag([v.m_s, v.I_y]), t.T @ k_body @ t))
    heave_share = v.m_s * vec[0] ** 2 / (v.m_s * vec[0] ** 2 + v.I_y * vec[1] ** 2)
    return float(np.sqrt(lam.real[np.argmax(heave_share)]) / (2 * np.pi))


def _bounce_rise(p: hisopt.Problem) -> tuple[float, float]:
    """The modal bounce frequency's relative rise, laden HIS against the same laden car with
    the HIS linearised at the precharge (only the mass added), and the hand estimate."""
    laden = p.model()
    mass_only = CoupledModel(laden.vehicle, HydraulicSystem(laden.his.network, laden.his.params))
    f_laden = modal_table(laden).set_index("mode").loc["bounce", "frequency_hz"]
    f_mass = modal_table(mass_only).set_index("mode").loc["bounce", "frequency_hz"]
    p_abs0 = 2.0e6 + P_ATM_PA
    k_acc0 = 1.4 * p_abs0 / 1.0e-3
    k_acc = k_acc0 * ((p_abs0 + laden.his.static_rise[0, 0]) / p_abs0) ** (1 + 1 / 1.4)  # gamma p_abs / V
    v = laden.vehicle
    return f_laden / f_mass - 1, _hand_bounce_hz(v, k_acc, 10e-4) / _hand_bounce_hz(v, k_acc0, 10e-4) - 1


def test_the_laden_his_raises_the_bounce_frequency_as_by_hand():
    """Undamped (``c_s = 0``, ``R_v = 0``): the modal rise equals the hand estimate within 1 %
    of itself (the wheels' masses, left out by hand, are 6 % of the body's)."""
    rise, estimate = _bounce_rise(laden_problem({"mass": 400.0}, Rv=0.0, vehicle={"c_sf": 0.0, "c_sr": 0.0}))
    assert rise == pytest.approx(estimate, rel=0.01)
    assert 0.005 < estimate < 0.05  # 400 kg on the default design: a 1.4 % stiffer bounce


def test_the_laden_his_raises_the_damped_bounce_frequency():
    """With the dampers the bounce mode is not proportionally damped, so its frequency moves
    more than the undamped one (1.9 % against 1.4 % here); the direction and the size stay
    those of the stiffening."""
    rise, estimate = _bounce_rise(laden_problem({"mass": 400.0}))
    assert 0.5 * estimate < rise < 2.0 * estimate


def test_payload_without_his_modes(problem):
    p = laden_problem({"mass": 200.0, "x": -0.8})
    car = p.model(his=False)
    assert car.his is None and car.vehicle.m_s == pytest.approx(1410.0, rel=1e-15)
    assert mass_matrix(car.vehicle)[0, 0] == pytest.approx(1410.0, rel=1e-15)
    modes = hisopt.modal_analysis(p, p.baseline, his=False)
    assert np.all(np.isfinite(modes["frequency_hz"]))


def test_time_domain_starts_at_the_laden_pressures_and_agrees_with_linear():
    """The nonlinear simulator's gas law runs about the laden point: at rest each accumulator
    holds ``p0 + dp``, and a small bump gives the linear (laden) model's response."""
    from hisopt.road import bump_profile
    from hisopt.simulation.timedomain import simulate

    p = laden_problem({"mass": 300.0, "x": 0.3, "y": 0.4})
    model = p.model()
    t = np.arange(0.0, 2.0, 1.0 / 200.0)
    road = bump_profile(t, 0.001, 1.0, 5.0, 2.6, ("fl", "rl"), t0_s=0.5)
    lin = simulate(model, t, road)
    nl = simulate(model, t, road, "nonlinear", tyre_liftoff=True)
    static = p.spec.his.p0 + model.his.static_rise[0]
    np.testing.assert_allclose(nl.accumulator_pressure_pa[0], static, rtol=1e-12)
    np.testing.assert_allclose(lin.accumulator_pressure_pa[0], static, rtol=1e-12)
    change = np.abs(lin.displacement).max()
    assert np.abs(nl.displacement - lin.displacement).max() < 0.01 * change


# --- the problem file -----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("table", "key", "expect"),
    [
        ("mass = -1.0", "payload.mass", "greater than or equal to 0"),
        ("mass = 100.0\nweight = 3.0", "payload.weight", "unknown key; expected one of mass, x, y, z, I_x, I_y"),
        ("mass = 3000.0\nx = 2.0", "payload.x", "outside the wheelbase"),  # on the body, but heavy at its front
        ("mass = 400.0\nx = 9.0", "payload.x", "outside the body"),  # hisopt.plausibility: 2.03 m ahead at most
        ("mass = 400.0\ny = -4.0", "payload.y", "outside the body"),
        ("mass = 100.0\nI_x = -2.0", "payload.I_x", "greater than or equal to 0"),
    ],
)
def test_bad_payload_is_one_line_exit_2(tmp_path, table, key, expect):
    path = tmp_path / "p.toml"
    path.write_text(DEFAULT_PROBLEM.read_text() + f"\n[payload]\n{table}\n")
    with pytest.raises(ConfigError) as err:
        hisopt.load_problem(path)
    assert key in str(err.value) and expect in str(err.value)
    out = run_cli("modes", str(path))
    assert out.code == 2 and len(out.error_lines) == 1, out.stderr
    assert key in out.stderr and expect in out.stderr and "Traceback" not in out.stderr


def test_cli_modes_and_evaluate_with_a_payload(tmp_path):
    path = tmp_path / "laden.toml"
    path.write_text(DEFAULT_PROBLEM.read_text() + "\n[payload]\nmass = 300.0\nx = 0.2\ny = 0.1\n")
    out = run_cli("modes", str(path))
    assert out.code == 0, out.stderr
    assert "bounce" in out.stdout
    out = run_cli("evaluate", str(path))
    assert out.code == 0, out.stderr
    assert "sigma_aw" in out.stdout and "0.5534" not in out.stdout  # not the unladen baseline
