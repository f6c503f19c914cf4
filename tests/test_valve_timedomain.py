"""Physical damper valves in the nonlinear time domain (docs/model.md §3.10).

- the valve law's tangent (the Newton Jacobian) is its derivative;
- a simulated valve's drop is the law (hisopt.hydraulics.laws) at its simulated flow, and in
  linear mode the equivalent resistance the model was built with;
- a valve with only its bleed orifice runs the orifice element's path (same K) to rounding;
- the nonlinear model's Jacobian with damper valves matches finite differences.
"""

from __future__ import annotations

import numpy as np
import pytest

from hisopt.hydraulics.laws import damper_valve_pressure_drop, damper_valve_slope, orifice_coefficient
from hisopt.problem import Problem, load_problem
from hisopt.simulation.agreement import road_realisation
from hisopt.simulation.nonlinear_model import NonlinearModel
from tests.conftest import ROOT
from tests.test_timedomain import assert_jacobian_matches_finite_differences

VALVES = ROOT / "tests" / "data" / "valves_one_road.toml"  # the valves problem on its city road alone, as measured
CUSTOM = ROOT / "problems" / "layout_custom_roll_plane.toml"


@pytest.fixture(scope="module")
def valves() -> Problem:
    return load_problem(VALVES)


@pytest.fixture(scope="module")
def valve_run(valves):
    """The valves problem's baseline with its blow-offs cracking at 0.5 MPa (so they open) on
    2 s of its road (250 Hz: the drop check needs no finer)."""
    from hisopt.simulation.timedomain import simulate

    model = valves.model({"cracking_pressure": 0.5e6})
    t = np.arange(0.0, 2.0, 1.0 / 250.0)
    road = road_realisation(valves, t, 39, 0)
    return model, simulate(model, t, road, "nonlinear", interpolation="cubic", method="RK45", rtol=1e-4), simulate(model, t, road, interpolation="cubic")


@pytest.mark.parametrize("blowoff", [True, False])
def test_damper_valve_slope_is_the_derivative_of_the_law(blowoff):
    kq, cracking, r_b, r = 1.8e13, 1.5e6, 2e9, 3e7
    law = (cracking, r_b) if blowoff else (None, None)
    q_c = np.sqrt(cracking / kq)
    q = np.concatenate([np.linspace(-4, 4, 161) * q_c, [0.0]])
    q = q[np.abs(np.abs(q) - q_c) > 1e-3 * q_c]  # away from the kink at the crossover
    h = 1e-7 * q_c
    fd = (damper_valve_pressure_drop(q + h, kq, *law, r) - damper_valve_pressure_drop(q - h, kq, *law, r)) / (2 * h)
    # central differences of K q |q| are off by K h at q = 0 (its curvature jumps there)
    np.testing.assert_allclose(damper_valve_slope(q, kq, *law, r), fd, rtol=1e-6, atol=2.0 * kq * h)
    # past the crossover the blow-off's slope tends to R_b's side of the series pair, below the bleed's
    if blowoff:
        beyond = damper_valve_slope(4 * q_c, kq, cracking, r_b)
        assert beyond < 2 * kq * 4 * q_c and beyond < r_b


def test_simulated_valves_follow_the_law_and_linear_mode_the_equivalent_resistance(valve_run):
    model, nonlinear, linear = valve_run
    values = model.his.values
    valves = model.his.network.damper_valves()
    assert nonlinear.valve_flow_m3s.shape == (nonlinear.t_s.size, len(valves)) == linear.valve_flow_m3s.shape
    opened = False
    for j, (k, _, _) in enumerate(valves):
        r, kq, cracking, r_b = (np.asarray(v, dtype=float).item() for v in values.damper[k])
        q, drop = nonlinear.valve_flow_m3s[:, j], nonlinear.valve_drop_pa[:, j]
        law = damper_valve_pressure_drop(q, kq, cracking, r_b, r)
        np.testing.assert_allclose(drop, law, rtol=0, atol=1e-9 * np.abs(law).max())
        opened |= bool(np.any(np.abs(q) > np.sqrt(cracking / kq)))  # the blow-off's branch was exercised
        r_eq = np.asarray(values.resistance[k], dtype=float).item()
        assert np.abs(drop - r_eq * q).max() > 0.1 * np.abs(drop).max()  # the law is not the linear valve
        q_lin = linear.valve_flow_m3s[:, j]
        np.testing.assert_allclose(linear.valve_drop_pa[:, j], r_eq * q_lin, rtol=0, atol=1e-9 * np.abs(r_eq * q_lin).max())
    assert opened
    frame = nonlinear.to_frame()
    assert frame.attrs["units"]["valve_flow_0"] == "m^3/s" and frame.attrs["units"]["valve_drop_3"] == "Pa"
    assert nonlinear.valve_names == ("A:A.2b->A", "A:A.4b->A", "B:B.1b->B", "B:B.3b->B")


def _custom_problem(tmp_path, kind: str, keys: str) -> Problem:
    """The paper's custom roll-plane layout with each valve an element of type ``kind`` with
    the extra ``keys``, and no Rv variable."""
    text = CUSTOM.read_text(encoding="utf-8")
    for a, b, rv in (("A.2b", "A", "Rv"), ("A.4b", "A", "Rv_rear"), ("B.1b", "B", "Rv"), ("B.3b", "B", "Rv_rear")):
        old = f'{{ type = "valve", from = "{a}", to = "{b}", resistance = "{rv}" }}'
        assert old in text
        text = text.replace(old, f'{{ type = "{kind}", from = "{a}", to = "{b}", {keys} }}')
    text = "\n".join(line for line in text.splitlines() if not line.startswith("Rv = {"))
    path = tmp_path / f"{kind}.toml"
    path.write_text(text, encoding="utf-8")
    return load_problem(path)


def test_a_bleed_only_valve_runs_the_orifice_path(tmp_path):
    """Same K = rho / (2 C_d^2 A^2), same laminar part and RMS flow: the damper valve without a
    blow-off and the orifice element give the same simulation to rounding."""
    from hisopt.simulation.timedomain import simulate

    diameter, flow, r = 3e-3, 1e-4, 2e7
    damper = _custom_problem(tmp_path, "damper_valve", f"orifice_diameter = {diameter}, resistance = {r}, flow_rms = {flow}")
    kq = orifice_coefficient(diameter, 0.7, damper.spec.his.fluid.rho)
    orifice = _custom_problem(tmp_path, "orifice", f"kq = {kq!r}, resistance = {r}, flow_rms = {flow}")
    t = np.arange(0.0, 2.0, 1.0 / 250.0)
    road = road_realisation(damper, t, 39, 1)
    runs = [simulate(p.model(), t, road, "nonlinear", interpolation="cubic", method="RK45", rtol=1e-5) for p in (damper, orifice)]
    his = damper.model().his
    (k, _, _), *_ = his.network.damper_valves()
    assert his.values.damper[k][2] is None  # no blow-off
    for name in ("displacement", "acceleration", "accumulator_pressure_pa"):
        a, b = getattr(runs[0], name), getattr(runs[1], name)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * np.abs(b).max(), err_msg=name)
    # the law bites: the same road through linear valves at the equivalent resistance differs
    linear = simulate(orifice.model(), t, road, interpolation="cubic")
    assert np.abs(linear.displacement - runs[1].displacement).max() > 1e-3 * np.abs(runs[1].displacement).max()


def test_nonlinear_jacobian_with_damper_valves_matches_finite_differences(valves, rng):
    model = valves.model()
    net = NonlinearModel(model, valve_kq=0.0, tyre_liftoff=False)
    assert len(net.dampers) == 1 and net.dampers[0].positions.size == 4
    scale = np.r_[np.full(7, 0.01), np.full(7, 0.1), np.full(net.n_states - 14, 1e4)]
    y = rng.standard_normal(net.n_states) * scale
    y[14 + net.acc_state] = rng.uniform(-1e-5, 1e-5, net.acc_state.size)  # volumes [m^3]
    q = net.hydraulic_state(y[14:, None], y[7:14, None])[net.alg][net.dampers[0].positions, 0]
    q_c = np.sqrt(net.dampers[0].cracking[:, 0] / net.dampers[0].kq[:, 0])
    assert np.any(np.abs(q) > q_c) and np.all(np.abs(np.abs(q) - q_c) > 1e-3 * q_c)  # both branches, off the kink
    assert_jacobian_matches_finite_differences(net, y, np.array([0.01, -0.02, 0.0, 0.03]))
