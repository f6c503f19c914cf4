"""The buildability rules (docs/model.md §21), each by hand from its equation.

Independent references: the chambers' pressures of the state space against the direct solve
of the network; the road's swing against the RMS of the direct solve's PSD on a fine grid; the
cornering swing against the body's roll-moment balance; the static pressures of a charged HIS
at its charge temperature in closed form (``(p0 + p_atm) / phi``); the cylinders' geometry,
Euler's load, the hoses' velocity and Reynolds number by hand; numpy against CasADi.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from hisopt.constants import G_MPS2, P_ATM_PA
from hisopt.coupled import buildability as b
from hisopt.coupled.response import port_pressure_outputs, stroke_rate_outputs
from hisopt.evaluation.channels import DirectOutputs
from hisopt.problem import problem_from_dict
from hisopt.vehicle import stroke_matrix
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT, random_designs
from tests.error_budget import EPS, SAFETY
from tests.test_accumulator_swing import assert_hydraulic_rows_equal_the_direct_solve, charged, single_case

PARTS = ROOT / "problems" / "roll_plane_his_parts.toml"
LIMITS = b.BuildLimits()


def fine_rms(problem, model, outputs) -> np.ndarray:
    """[unit] Band RMS of ``outputs`` by the direct solve's PSD on 40,001 log-spaced points
    (trapezoid: within 1e-5 of these smooth integrands), ``(n, len(outputs))``."""
    ev = problem.evaluator()
    f = np.geomspace(ev.f_lo, ev.f_hi, 40001)
    n = model.his.batch_shape[0]
    psd = ev.spectra(np.broadcast_to(f, (n, f.size)), DirectOutputs(model, outputs)(2 * np.pi * f[None]))
    return np.sqrt(np.trapezoid(psd, f, axis=1))


def road_swing_by_hand(problem, model) -> b.RoadSwing:
    net = model.his.network
    n_acc, n_valves, n_ports = len(net.accumulators()), len(net.flow_valves()), len(net.ports)
    ports = port_pressure_outputs(n_acc, n_valves, n_ports)
    from hisopt.coupled.response import accumulator_outputs

    volumes = accumulator_outputs(n_acc)
    rates = stroke_rate_outputs(problem.vehicle)
    rms = fine_rms(problem, model, ports | volumes | rates)
    return b.RoadSwing(rms[:, :n_ports], rms[:, n_ports : n_ports + n_acc], rms[:, n_ports + n_acc :])


# --- the chambers' pressures -------------------------------------------------------------------
@pytest.mark.parametrize(
    "data",
    [
        pytest.param(charged(), id="charged"),
        pytest.param(charged("roll_plane_twin_accumulator"), id="twin-accumulators"),
        pytest.param(charged("roll_plane_accumulator_valves"), id="accumulator-valves"),
    ],
)
def test_state_space_chamber_pressures_equal_the_direct_solve(data, rng):
    """Poles and residues of the realisation's port-node pressures against the network solved
    at each frequency, within the rounding of both paths (the budgets of
    tests/test_accumulator_swing.py's oil volumes: the same rows of ``M^-1 P``)."""
    problem = problem_from_dict(data, warn_implausible=False)
    x = random_designs(problem, 12, rng)  # the corners short the valves (Rv = 0): merged nodes
    for _, model in problem.model(x).groups():
        net = model.his.network
        assert_hydraulic_rows_equal_the_direct_solve(model, port_pressure_outputs(len(net.accumulators()), len(net.flow_valves()), len(net.ports)))


def test_a_chamber_behind_its_valve_is_its_accumulator_plus_the_valves_drop():
    """The paper's layout: a chamber sits at its circuit's accumulator node, or behind one
    valve whose drop ``R q`` carries the port's flow ``q = s (N G X)``, at any frequency."""
    problem = problem_from_dict(charged(), warn_implausible=False)
    model = problem.model(problem.baseline[None])
    net = model.his.network
    s = 2j * np.pi * np.geomspace(0.1, 80, 7)
    h_x = model.frequency_response(s)
    hyd = model.hydraulic_response(s, h_x)[0]  # (F, n_acc + n_valves + n_ports, 4)
    n_acc, n_valves = len(net.accumulators()), len(net.flow_valves())
    node_pressure = hyd[:, :n_acc] / model.his.accumulator_compliances()[0][None, :, None]
    flows = s[:, None, None] * (np.asarray(model.his.incidence)[0] @ stroke_matrix(problem.vehicle) @ h_x[0])  # (F, ports, 4)
    valve_at = {rows[0]: model.his.values.resistance[k] for k, _, rows in net.valves()}
    for port, (row, c) in enumerate(zip(net.port_rows, net.port_circuit, strict=True)):
        expected = node_pressure[:, int(c)] + valve_at.get(int(row), 0.0) * flows[:, port]
        scale = np.abs(expected).max()
        # one network solve each (its condition near 1) and a product: a few eps of the scale
        assert np.abs(hyd[:, n_acc + n_valves + port] - expected).max() <= SAFETY * 64 * EPS * scale


# --- the rules by hand -------------------------------------------------------------------------
def test_the_envelope_baselines_rear_struts_push_112_percent_of_their_load():
    """At the charge temperature, unladen, each circuit sits at its charge pressure
    ``(p0 + p_atm) / phi``; both chambers of a strut at it push ``(p - p_atm) dA``."""
    problem = problem_from_dict(charged(), warn_implausible=False)
    v = problem.vehicle
    x = problem.design_matrix([problem.baseline, problem.baseline * np.array([0.25, 1, 1, 1])])  # p0 2 MPa and 0.5 MPa
    p = (x[:, 0] + P_ATM_PA) / 0.7
    force = (p - P_ATM_PA) * x[:, 1]
    rear = 0.5 * v.m_s * G_MPS2 * v.l_f / (v.l_f + v.l_r)
    rule = b.static_rules(problem.model(x), LIMITS)["strut_load_usage"]
    np.testing.assert_allclose(rule.value, force / rear, rtol=1e-9)
    assert rule.value[0] == pytest.approx(1.1245, abs=5e-5)  # the 112 %
    assert rule.usage[0] > 1 > rule.usage[1]  # the baseline fails, a 0.5 MPa precharge passes


def test_the_cylinder_rules_by_hand():
    problem = problem_from_dict(charged(), warn_implausible=False)
    x = problem.design_matrix([[2e6, 10e-4, 0.5, 8e5], [2e6, 10e-4, 0.1, 8e5], [2e6, 10e-4, 0.35, 8e5]])
    rules = b.static_rules(problem.model(x), LIMITS)
    rod = math.sqrt(4 * 10e-4 / math.pi)
    bore = rod / np.sqrt(1 - x[:, 2])
    np.testing.assert_allclose(rules["area_ratio_usage"].value, 1 / x[:, 2], rtol=1e-12)
    np.testing.assert_allclose(rules["annulus_wall_usage"].value, (bore - rod) / 2, rtol=1e-12)
    np.testing.assert_allclose(rules["annulus_wall_usage"].usage, 2 - (bore - rod) / 2 / 3.5e-3, rtol=1e-12)
    assert list(rules["area_ratio_usage"].usage <= 1) == [True, False, False]  # ratio 2 holds, 10 and 2.9 do not
    assert list(rules["annulus_wall_usage"].usage <= 1) == [True, False, True]  # a 0.97 mm wall fails


def test_the_cornering_swing_balances_the_roll_moment(rng):
    """The body's roll equation at the cornering point: the springs' and the fluid's moments
    carry the lateral force's ``m_s a_y h_0s`` plus the weight's ``m_s g h_0s phi`` (the
    gravity moment, with the default ``[handling]``); the fluid's from ``f = -N^T dp``."""
    problem = problem_from_dict(charged(), warn_implausible=False)
    x = random_designs(problem, 6, rng, corners=False)
    model = problem.model(x)
    v = problem.vehicle
    dp = b.cornering_swing(model, 1.0, True)  # magnitudes, at 1 g
    k = model.stiffness()
    k[:, 1, 1] -= v.m_s * G_MPS2 * v.h_0s
    load = np.zeros((len(x), 7, 1))
    load[:, 1, 0] = v.m_s * G_MPS2 * v.h_0s
    motion = np.linalg.solve(k, load)[..., 0]
    delta = np.einsum("ij,nj->ni", stroke_matrix(v), motion)
    n = np.asarray(model.his.incidence)
    net = model.his.network
    signed = np.stack([np.einsum("nw,nw->n", n[:, net.port_circuit == c].sum(axis=1), delta) for c in range(2)], axis=1)
    from hisopt.hydraulics.network import total_compliance

    compliance = np.stack([total_compliance(net, model.his.values, c) for c in range(2)], axis=1)
    np.testing.assert_allclose(dp, np.abs(signed / compliance), rtol=1e-12)
    fluid = -np.einsum("npw,np->nw", n, (signed / compliance)[:, net.port_circuit])
    springs = -np.array([v.k_sf, v.k_sf, v.k_sr, v.k_sr]) * delta
    lever = np.array([v.t_f, -v.t_f, v.t_r, -v.t_r])  # positive roll lifts the left
    moment = np.einsum("nw,w->n", springs + fluid, lever)
    np.testing.assert_allclose(moment, -v.m_s * G_MPS2 * v.h_0s * (1 + motion[:, 1]), rtol=1e-9)


def test_the_pressure_rules_by_hand(rng):
    """Static pressure, three road sigmas of the direct solve's PSD and the cornering swing,
    against the floors and ratings of docs/model.md §21.2."""
    problem = problem_from_dict(charged(), warn_implausible=False)
    x = random_designs(problem, 6, rng, corners=False)
    x[0] = problem.baseline
    model = problem.model(x)
    swing = road_swing_by_hand(problem, model)
    his = model.his
    static = b.circuit_pressures(his)
    corner = b.cornering_swing(model, LIMITS.cornering_g, True)
    port_low = static[:, his.network.port_circuit] - 3 * swing.port_pressure - corner[:, his.network.port_circuit]
    acc_low = static - 3 * swing.oil_volume / his.accumulator_compliances() - corner  # one accumulator per circuit, in circuit order
    precharge = (x[:, [0]] + P_ATM_PA) * his.params.get("gas_temperature_ratio", 1.0)
    usage_low = np.maximum(np.max(2 - port_low / P_ATM_PA, axis=1), np.max(2 - acc_low / np.maximum(P_ATM_PA, 1.1 * precharge), axis=1))
    high = np.concatenate(
        [static[:, his.network.port_circuit] + 3 * swing.port_pressure, static + 3 * swing.oil_volume / his.accumulator_compliances()], axis=1
    )
    high = high + np.concatenate([corner[:, his.network.port_circuit], corner], axis=1) - P_ATM_PA
    ceiling = np.concatenate([np.full((len(x), 8), 16e6), np.broadcast_to(8.0 * (precharge - P_ATM_PA), (len(x), 2))], axis=1)
    got = b.pressure_rules(model, LIMITS, b.RoadSwing(*_evaluator_swing(problem, x)), _rating)
    # the evaluator's quadrature holds each integral to 1e-4 (its sigmas to 1e-4, against the
    # fine grid's 1e-5): a usage moves by at most 3 sigma 2e-4 over the limit it is judged by
    sigma = np.concatenate([swing.port_pressure, swing.oil_volume / his.accumulator_compliances()], axis=1).max(axis=1)
    budget = 3 * sigma * 2e-4 / P_ATM_PA
    assert np.all(np.abs(got["pressure_floor_usage"].usage - usage_low) <= budget)
    assert np.all(np.abs(got["pressure_ceiling_usage"].usage - np.max(high / ceiling, axis=1)) <= budget)
    assert got["pressure_floor_usage"].usage[0] == pytest.approx(1.0005, abs=1e-4)  # the baseline: at 1.1 x its precharge (0.05 % below)
    floor = got["pressure_floor_usage"].usage
    assert (floor < 1).any() and (floor > 1).any(), floor  # designs on both sides of the floor
    assert np.all(got["pressure_ceiling_usage"].usage < 1)  # far below 16 MPa and the accumulators' ratings
    rated_low = b.pressure_rules(model, b.BuildLimits(cylinder_pressure=1e6), b.RoadSwing(*_evaluator_swing(problem, x)), _rating)
    assert np.all(rated_low["pressure_ceiling_usage"].usage >= np.max(high[:, :8], axis=1) / 1e6 - budget)  # 1 MPa cylinders: the chambers bind
    assert np.all(rated_low["pressure_ceiling_usage"].usage > 1)


def _rating(his):
    return b.accumulator_ceilings(his, his.params["pressure_rating"], np.inf)


def _evaluator_swing(problem, x):
    from hisopt.evaluation.build_rules import road_outputs
    from hisopt.evaluation.evaluate import Evaluator

    outputs = road_outputs(problem.network(), tuple(b.RULES))
    ev = Evaluator(problem, names=(), rms_outputs=outputs)
    rms = ev.output_rms(problem.model(x), outputs)
    net = problem.network()
    n_ports, n_acc = len(net.ports), len(net.accumulators())
    return rms[:, :n_ports], rms[:, n_ports : n_ports + n_acc], rms[:, n_ports + n_acc :]


def test_the_rod_buckles_by_euler_by_hand(rng):
    """The peak compressive force (bottom chamber high, top low) against ``pi^2 E I / L^2 / S``;
    a thin rod at a high precharge fails on a long free length, the baseline's holds."""
    problem = problem_from_dict(charged(), warn_implausible=False)
    x = problem.design_matrix([problem.baseline, [4e6, 1e-4, 0.8, 8e5]])  # 35.7 mm and 11.3 mm rods
    model = problem.model(x)
    swing = road_swing_by_hand(problem, model)
    ext = b.pressure_extremes(model, LIMITS, swing)
    top, bottom = (np.asarray(a) for a in model.his.areas)
    ports = model.his.network.ports
    force = np.zeros((2, 4))
    for i, port in enumerate(ports):
        if port.chamber == "bottom":
            force[:, port.wheel] += bottom[:, port.wheel] * (ext.port_high[:, i] - P_ATM_PA)
        else:
            force[:, port.wheel] -= top[:, port.wheel] * (np.maximum(ext.port_low[:, i], 0.0) - P_ATM_PA)
    rod = np.sqrt(4 * x[:, 1] / math.pi)
    allowed = math.pi**2 * 210e9 * (math.pi * rod**4 / 64) / 0.3**2 / 3.5
    rule = b.buckling_rule(model, LIMITS, swing)
    np.testing.assert_allclose(rule.usage, force.max(axis=1) / allowed, rtol=1e-9)
    assert rule.usage[0] < 0.05 and rule.usage[1] < 1
    longer = b.buckling_rule(model, b.BuildLimits(rod_length=0.9), swing)  # Euler: the load falls as 1 / L^2
    np.testing.assert_allclose(longer.usage, 9 * rule.usage, rtol=1e-12)
    assert longer.usage[1] > 1  # the thin rod buckles at 0.9 m


def test_the_hoses_velocity_and_reynolds_number_by_hand():
    """The parts problem's hoses: three RMS chamber flows (area times the stroke rate's RMS by
    the direct solve on a fine grid) over the bore's area; ``rho v d / mu`` of the case's oil."""
    problem = problem_from_dict(single_case(PARTS), warn_implausible=False)
    model = problem.model(problem.baseline[None])
    swing = road_swing_by_hand(problem, model)
    his = model.his
    d = float(np.ravel(his.params["pipe_diameter"])[0]) if "pipe_diameter" in his.params else 12.7e-3
    top, bottom = (np.asarray(a)[0] for a in his.areas)
    area = {"top": top, "bottom": bottom}
    velocity = max(3 * area[p.chamber][p.wheel] * swing.stroke_rate[0, p.wheel] / (math.pi * d**2 / 4) for p in his.network.ports)
    rules = b.hose_rules(his, LIMITS, swing)
    assert rules["hose_velocity_usage"].value[0] == pytest.approx(velocity, rel=1e-12)
    rho, mu = float(np.ravel(his.params["rho"])[0]), float(np.ravel(his.params["mu"])[0])
    assert rules["hose_reynolds_usage"].value[0] == pytest.approx(rho * velocity * d / mu, rel=1e-12)
    assert rules["hose_velocity_usage"].usage[0] == pytest.approx(velocity / 6.0, rel=1e-12)
    assert rules["hose_velocity_usage"].usage[0] > 1 > rules["hose_reynolds_usage"].usage[0]  # a -8 hose: 7 m/s, laminar
    wide = problem.model(problem.design_matrix([np.where(np.array(problem.variable_names) == "pipe_diameter", 19e-3, problem.baseline)]))
    held = b.hose_rules(wide.his, LIMITS, road_swing_by_hand(problem, wide))
    assert held["hose_velocity_usage"].usage[0] < 1  # a -12 hose holds


def test_a_layout_without_hoses_has_nothing_to_check():
    problem = problem_from_dict(charged(), warn_implausible=False)
    model = problem.model(problem.baseline[None])
    swing = road_swing_by_hand(problem, model)
    rules = b.hose_rules(model.his, LIMITS, swing)
    assert rules["hose_velocity_usage"].usage[0] == 0.0 and np.isnan(rules["hose_velocity_usage"].limit[0])


def test_the_static_rules_numpy_against_casadi(rng):
    """The same expressions (backend helpers) on a numpy batch and on CasADi symbols: equal
    to the rounding of a few products and one division."""
    ca = pytest.importorskip("casadi")
    for data in (charged(), tomllib.loads(DEFAULT_PROBLEM.read_text())):
        problem = problem_from_dict(data, warn_implausible=False)
        x = random_designs(problem, 5, rng, corners=False)
        numeric = b.static_rules(problem.model(x), LIMITS)
        sym = ca.MX.sym("x", len(problem.variable_names))
        params = {name: sym[i] for i, name in enumerate(problem.variable_names)}
        from hisopt.coupled.model import CoupledModel

        symbolic = CoupledModel(problem.vehicle, problem.hydraulic_system(params))
        for name, (elements, limit) in b.static_rule_elements(symbolic, LIMITS).items():
            f = ca.Function("f", [sym], [b.symbolic_usage(name, elements, limit)])
            got = np.array([float(f(row)) for row in x])
            np.testing.assert_allclose(got, numeric[name].usage, rtol=64 * EPS, atol=64 * EPS)


@pytest.mark.parametrize(
    "line, message",
    [
        ('cornering = "2 g"', "build.cornering: 2 g is beyond"),
        ("buckling_safety = 0.5", "build.buckling_safety: expected greater than or equal to 1"),
        ('hose_velocity = "6 m"', 'build.hose_velocity: "6 m" is a length; expected a speed'),
        ('annulus_wall = "-1 mm"', "build.annulus_wall: expected greater than 0"),
        ("sigma = 3", "build.sigma: unknown key"),
    ],
)
def test_a_bad_build_setting_is_one_line_naming_the_key(tmp_path, line, message):
    path = tmp_path / "bad.toml"
    path.write_text(DEFAULT_PROBLEM.read_text() + f"\n[build]\n{line}\n")
    result = run_cli("evaluate", str(path))
    assert result.code == 2 and len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert message in result.stderr, result.stderr


def test_a_rule_is_judged_in_every_load_case_and_its_worst_constrained(tmp_path):
    """The envelope problem constrained on the struts' share: the plain column is the worst
    case's; the winter city's share below the city's (the gas contracts in the cold), and
    at 60 C unladen the issue's 127 % of the rear corner's load."""
    data = tomllib.loads((ROOT / "problems" / "roll_plane_his_envelope.toml").read_text())
    data["constraints"] = [{"name": "strut_load_usage", "limit": 1.0}]
    problem = problem_from_dict(data, warn_implausible=False)
    df = problem.evaluate(problem.baseline[None])
    cases = [f"strut_load_usage@{sc}" for sc in problem.scenario_names]
    assert df.loc[0, "strut_load_usage"] == pytest.approx(df.loc[0, cases].max(), rel=1e-12)
    assert df.loc[0, "strut_load_usage@winter_city"] < df.loc[0, "strut_load_usage@city"]
    assert not df.loc[0, "feasible"]
    hot = problem_from_dict(charged() | {"temperature": 333.15}, warn_implausible=False)
    assert b.static_rules(hot.model(hot.baseline[None]), LIMITS)["strut_load_usage"].value[0] == pytest.approx(1.27, abs=0.005)


def test_the_casadi_model_takes_the_static_rules_and_refuses_the_road_ones():
    pytest.importorskip("casadi")
    import casadi as ca

    from hisopt.errors import RunError
    from hisopt.optim.gradient.casadi_model import CasadiModel

    static = problem_from_dict(charged() | {"constraints": [{"name": "strut_load_usage", "limit": 1.0}]}, warn_implausible=False)
    model = CasadiModel(static, compile=False)
    x = ca.MX.sym("x", len(static.variable_names))
    f = ca.Function("f", [x], [model.build_rule(x, "strut_load_usage")])
    numeric = static.evaluator()(static.baseline[None])["strut_load_usage"][0]
    assert float(f(static.baseline)) == pytest.approx(numeric, rel=64 * EPS)
    road = problem_from_dict(charged() | {"constraints": [{"name": "pressure_floor_usage", "limit": 1.0}]}, warn_implausible=False)
    with pytest.raises(RunError, match="--method slp"):
        CasadiModel(road)


def test_a_rule_with_an_uncertain_road_roughness_is_refused(tmp_path):
    path = tmp_path / "uncertain.toml"
    text = (ROOT / "problems" / "roll_plane_his_uncertain.toml").read_text()
    text += (
        '\n[[constraints]]\nname = "strut_load_usage"\nlimit = 1.0\n\n[[uncertain]]\ninput = "road.class"\ndistribution = "uniform"\nlower = "B"\nupper = "C"\n'
    )
    path.write_text(text)
    result = run_cli("evaluate", str(path))
    assert result.code == 2 and len(result.stderr.strip().splitlines()) == 1
    assert "no factor of an uncertain road.class scales it" in result.stderr


def test_one_design_without_an_operating_point_does_not_blank_its_batch():
    """The flagship's cold corner: 19 mm hoses' oil contracts more than a 0.16 L accumulator
    holds, so that design has no operating point at -20 C; the valves' fixed point and the
    rules of the other designs of its batch are still evaluated (design by design when the
    batch's linear algebra refuses it)."""
    from hisopt.problem import load_problem
    from hisopt.studies.buildability import case_rules

    problem = load_problem(ROOT / "problems" / "his_buildable.toml", warn_implausible=False)
    winter = problem.scenario_space("winter_city")
    x = problem.design_matrix([[3e5, 0.032, 0.012, 0.16e-3, 6.3e-3, 1e-3, 1e5], [3e5, 0.032, 0.012, 0.16e-3, 19e-3, 1e-3, 1e5]])
    alone = winter.evaluator()(x[[0]])
    both = winter.evaluator()(x)
    assert list(both["valid"]) == [True, False]
    assert both["sigma_aw"][0] == pytest.approx(alone["sigma_aw"][0], rel=1e-9)
    rules = case_rules(winter, x)
    assert np.isfinite(rules["strut_load_usage"].usage[0]) and np.isnan(rules["strut_load_usage"].usage[1])


def test_the_wheel_rules_by_hand_a_cold_hose_locks_the_wheel():
    """The flagship's baseline: its wheels hop at 5-8 Hz and are damped in the city (both
    rules hold); at -20 C the oil in its 12.7 mm hoses is 7 times as viscous and the wheels
    are locked to the body, their modes above 200 Hz and barely damped (both fail). The usages
    from :func:`hisopt.coupled.modal.wheel_modes` by the rules' equations."""
    from hisopt.coupled.modal import wheel_modes
    from hisopt.problem import load_problem

    problem = load_problem(ROOT / "problems" / "his_buildable.toml", warn_implausible=False)
    x = problem.baseline[None]
    for case, holds in (("city", True), ("winter_city", False)):
        space = problem.scenario_space(case)
        from hisopt.studies.buildability import case_rules

        rules = case_rules(space, x)
        from hisopt.evaluation.valve_states import valve_states

        model = space.model(x, inputs=valve_states(space, x).inputs)
        f, zeta = wheel_modes(model)
        assert rules["wheel_hop_usage"].usage[0] == pytest.approx(f.max() / 30.0, rel=1e-9)
        assert rules["wheel_damping_usage"].usage[0] == pytest.approx(2 - zeta.min() / 0.1, rel=1e-9)
        assert (rules["wheel_hop_usage"].usage[0] <= 1) == holds and (rules["wheel_damping_usage"].usage[0] <= 1) == holds
