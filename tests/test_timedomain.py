"""Time-domain simulation: invariants, and cross-checks against the frequency-domain model.

- a sine input reaches the steady state ``H(j w) U`` of :meth:`CoupledModel.frequency_response`;
- the RMS responses to an ISO 8608 class C road match the PSD integrals (paper Eq. 24);
- the nonlinear model (gas law, orifices, tyre lift-off) equals the linear one for small
  inputs and hardens, as a gas spring must, for large ones.
"""

from __future__ import annotations

import math

import numpy as np
import plotly.graph_objects as go
import pytest
from scipy.fft import next_fast_len

from hisopt.coupled.model import CoupledModel
from hisopt.errors import ConfigError
from hisopt.hydraulics.laws import gas_compliance, gas_pressure_rise, gas_volume
from hisopt.hydraulics.laws import valve_pressure_drop as orifice_pressure_drop
from hisopt.road import bump_profile, random_profile, step_profile
from hisopt.simulation.nonlinear_model import NonlinearModel
from hisopt.simulation.timedomain import RoadInput, simulate
from hisopt.standards.iso_8608_2016 import class_gd_n0, temporal_psd
from hisopt.vehicle import stroke_matrix

P_ABS0 = 2.0e6 + 101_325.0


# --- kernels -------------------------------------------------------------------------------


def test_gas_law_round_trip_and_linear_limit():
    dv = np.linspace(-0.5e-3, 0.9e-3, 41)
    p = gas_pressure_rise(dv, 1e-3, P_ABS0, 1.4)
    np.testing.assert_allclose(gas_volume(p, 1e-3, P_ABS0, 1.4), dv, rtol=1e-12, atol=1e-18)
    # Tangent compliance is the derivative of the volume law; at 0 it is V0 / (gamma p_abs0).
    h = 1.0
    fd = (gas_volume(p + h, 1e-3, P_ABS0, 1.4) - gas_volume(p - h, 1e-3, P_ABS0, 1.4)) / (2 * h)
    np.testing.assert_allclose(gas_compliance(p, 1e-3, P_ABS0, 1.4), fd, rtol=1e-6)
    assert gas_compliance(0.0, 1e-3, P_ABS0, 1.4) == pytest.approx(1e-3 / (1.4 * P_ABS0), rel=1e-14)
    # Hardening: compressing by dV raises the pressure more than expanding by dV lowers it.
    assert gas_pressure_rise(2e-4, 1e-3, P_ABS0, 1.4) > -gas_pressure_rise(-2e-4, 1e-3, P_ABS0, 1.4)
    # A gauge precharge of 0 (atmospheric gas) is valid.
    assert np.isfinite(gas_pressure_rise(1e-4, 1e-3, 101_325.0, 1.4))


def test_orifice_law_is_odd_and_adds_the_quadratic_term():
    q = np.array([-2e-4, -1e-5, 0.0, 1e-5, 2e-4])
    dp = orifice_pressure_drop(q, 8e5, 1e13)
    np.testing.assert_allclose(dp, -dp[::-1])
    assert dp[-1] == pytest.approx(8e5 * 2e-4 + 1e13 * 4e-8)


@pytest.mark.parametrize("interpolation", ["pchip", "cubic", "linear"])
def test_road_input_interpolates_samples_and_its_rate(interpolation):
    t = np.linspace(0.0, 1.0, 41)
    z = np.stack([np.sin(3 * t), t**2, np.cos(2 * t), 0.5 * t], axis=1)
    road = RoadInput(t, z, interpolation)
    for i in (0, 7, 40):
        np.testing.assert_allclose(road.value(t[i]), z[i], atol=1e-15)
    tt, h = 0.4321, 1e-6
    np.testing.assert_allclose(road.rate(tt), (road.value(tt + h) - road.value(tt - h)) / (2 * h), rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(road.value(-1.0), z[0])
    np.testing.assert_allclose(road.value(2.0), z[-1])


def test_pchip_keeps_a_step_monotone_where_a_cubic_spline_rings():
    t = np.arange(0.0, 0.2, 0.005)
    z = step_profile(t, -0.05, 0.1)
    fine = np.linspace(0.0, 0.195, 2000)
    pchip_road, cubic_road = RoadInput(t, z, "pchip"), RoadInput(t, z, "cubic")
    pchip = np.array([pchip_road.value(x)[0] for x in fine])
    cubic = np.array([cubic_road.value(x)[0] for x in fine])
    assert np.all(np.diff(pchip) <= 1e-15) and pchip.min() >= -0.05 - 1e-15 and pchip.max() <= 1e-15
    assert cubic.max() > 1e-4  # the C2 spline pre-rings before the drop


# --- linear model against the frequency domain ------------------------------------------------


@pytest.mark.parametrize("f_hz", [1.5, 9.0])
def test_sine_steady_state_equals_frequency_response(problem, f_hz):
    """FL driven by a sine and RR by a cosine: amplitude and phase of several outputs."""
    model = problem.model()
    fs, duration, amp = 400.0, 10.0, 0.01
    t = np.arange(0.0, duration, 1.0 / fs)
    w = 2 * np.pi * f_hz
    road = np.zeros((t.size, 4))
    road[:, 0] = amp * np.sin(w * t)
    road[:, 3] = 0.5 * amp * np.cos(w * t)
    res = simulate(model, t, road, interpolation="cubic", rtol=1e-9)
    # Complex input amplitudes with u(t) = Im(U exp(j w t)); the last 2 s are steady.
    u = np.array([amp, 0.0, 0.0, 0.5j * amp])
    h = model.frequency_response(np.array([1j * w]))[0, 0]  # (7, 4)
    x_pred = h @ u
    predictions = {
        "z_s": x_pred[0],
        "phi": x_pred[1],
        "theta": x_pred[2],
        "z_u1": x_pred[3],
        "stroke_fl": stroke_matrix(model.vehicle)[0] @ x_pred,
        "ddz_s": -(w**2) * x_pred[0],
    }
    frame = res.to_frame()
    keep = t >= duration - 2.0
    basis = np.stack([np.sin(w * t[keep]), np.cos(w * t[keep])], axis=1)
    for name, pred in predictions.items():
        (c_sin, c_cos), *_ = np.linalg.lstsq(basis, frame[name].to_numpy()[keep], rcond=None)
        measured = c_sin + 1j * c_cos
        assert abs(measured - pred) <= 1e-5 * abs(pred), (name, measured, pred)


def test_random_road_rms_matches_frequency_domain(problem):
    """ISO 8608 class C at 10 m/s: time-domain RMS within 5 % of the PSD integrals.

    ``random_profile`` superposes lines ``f_k = k / T`` (T the FFT period), each carrying the
    PSD of the cell ``f_k +- 1/(2T)``; the record length is chosen so T = 40 s exactly, and the
    frequency-domain integral covers the same cells. Left-right cross terms of one realisation
    have a random sign per line (a few % at this length); they cancel exactly in the mean of a
    run and its mirror image (right track negated, an equally likely class C road), so the
    comparison is not left to the luck of one seed.
    """
    model = problem.model()
    v = model.vehicle
    speed, dt, f_min, f_max = 10.0, 0.01, 0.5, 20.0
    tau = v.wheelbase / speed
    n_period = 4000
    assert next_fast_len(n_period, real=True) == n_period
    t = np.arange(n_period - math.ceil(tau / dt)) * dt  # random_profile's period: n_t + tau/dt
    df = 1.0 / (n_period * dt)

    f = np.linspace(f_min - df / 2, f_max + df / 2, 40001)
    s = 2j * np.pi * f
    hx = model.frequency_response(s)[0]  # (F, 7, 4)
    delay = np.exp(-s * tau)
    g = temporal_psd(f, class_gd_n0("C"), speed)
    frf = {"ddz_s": s[:, None] ** 2 * hx[:, 0], "phi": hx[:, 1], "stroke_fl": stroke_matrix(v)[0] @ hx}
    rms_fd = {k: np.sqrt(np.trapezoid(g * (np.abs(h[:, 0] + h[:, 2] * delay) ** 2 + np.abs(h[:, 1] + h[:, 3] * delay) ** 2), f)) for k, h in frf.items()}

    z = random_profile(t, "C", speed, v.wheelbase, np.random.default_rng(7), f_min, f_max)
    keep = t >= 3.0  # the car starts at rest on a road that does not: let the transient pass
    mean_square = dict.fromkeys(rms_fd, 0.0)
    for mirror in (1.0, -1.0):
        res = simulate(model, t, z * np.array([1.0, mirror, 1.0, mirror]), interpolation="cubic", method="DOP853", rtol=1e-6)
        frame = res.to_frame()
        for k in rms_fd:
            mean_square[k] += 0.5 * np.mean(frame[k].to_numpy()[keep] ** 2)
    for k, target in rms_fd.items():
        assert np.sqrt(mean_square[k]) == pytest.approx(target, rel=0.05), k


# --- nonlinear model ---------------------------------------------------------------------------


def _left_bump(height_m: float, duration_s: float = 3.0) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(0.0, duration_s, 1.0 / 200.0)
    return t, bump_profile(t, height_m, 1.0, 5.0, 2.6, ("fl", "rl"), t0_s=0.5)


def _relative_difference(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def test_small_amplitude_nonlinear_equals_linear(problem):
    model = problem.model()
    t, road = _left_bump(0.001)
    lin = simulate(model, t, road)
    nl = simulate(model, t, road, "nonlinear", tyre_liftoff=True)
    for name in ("displacement", "acceleration", "stroke_m", "tyre_force_n"):
        assert _relative_difference(getattr(nl, name), getattr(lin, name)) < 0.01, name
    p0 = problem.spec.his.p0
    assert _relative_difference(nl.accumulator_pressure_pa - p0, lin.accumulator_pressure_pa - p0) < 0.01
    assert _relative_difference(nl.accumulator_volume_m3, lin.accumulator_volume_m3) < 0.01


def test_small_amplitude_nonlinear_equals_linear_with_oil_compliance(problem):
    """Chamber compliance puts oil at the accumulator nodes (the node law is then inverted
    by Newton's method) and makes the network stiff (LSODA switches to BDF)."""
    model = problem.with_values(chamber_volume=2e-4).model()
    t, road = _left_bump(0.001, duration_s=1.5)
    lin = simulate(model, t, road)
    nl = simulate(model, t, road, "nonlinear")
    assert _relative_difference(nl.displacement, lin.displacement) < 0.01
    p0 = problem.spec.his.p0
    assert _relative_difference(nl.accumulator_pressure_pa - p0, lin.accumulator_pressure_pa - p0) < 0.01


def test_gas_spring_hardens_at_large_amplitude(problem):
    """A 60 mm kerb under the left wheels pushes ~20 % of a roll accumulator's gas volume:
    the gas law's pressure rise then exceeds the linear (tangent) prediction by far."""
    model = problem.model()
    t = np.arange(0.0, 3.0, 1.0 / 200.0)
    road = step_profile(t, 0.06, 0.5, ("fl", "rl"), rise_time_s=0.05)
    lin = simulate(model, t, road)
    nl = simulate(model, t, road, "nonlinear")
    his = problem.spec.his
    rise_lin = (lin.accumulator_pressure_pa - his.p0).max(axis=0)
    rise_nl = (nl.accumulator_pressure_pa - his.p0).max(axis=0)
    k = int(np.argmax(rise_lin))
    assert nl.accumulator_volume_m3[:, k].max() > 0.15 * his.V0
    assert rise_nl[k] > 1.15 * rise_lin[k]
    # The reported pressure is the gas law of the reported stored volume.
    np.testing.assert_allclose(
        nl.accumulator_pressure_pa[:, k] - his.p0,
        gas_pressure_rise(nl.accumulator_volume_m3[:, k], his.V0, his.p0 + 101_325.0, his.gamma),
        rtol=1e-9,
        atol=1e-3,
    )


@pytest.mark.parametrize("chamber_volume", [0.0, 2e-4])
def test_nonlinear_jacobian_matches_finite_differences(problem, rng, chamber_volume):
    model = problem.with_values(chamber_volume=chamber_volume).model()
    net = NonlinearModel(model, valve_kq=1e13, tyre_liftoff=True)
    scale = np.r_[np.full(7, 0.01), np.full(7, 0.1), np.full(net.n_states - 14, 1e4)]
    y = rng.standard_normal(net.n_states) * scale
    y[14 + net.acc_state] = rng.uniform(-1e-4, 1e-4, net.acc_state.size)  # volumes [m^3]
    assert_jacobian_matches_finite_differences(net, y, np.array([0.01, -0.02, 0.0, 0.03]))


def assert_jacobian_matches_finite_differences(net: NonlinearModel, y: np.ndarray, u: np.ndarray) -> None:
    """``net``'s analytic Jacobian at state ``y`` and road input ``u`` (still) against central
    differences of its derivative, steps of 1e-7 of each state (their truncation and rounding
    errors both near 1e-7 relative; 1e-5 allowed)."""
    du = np.zeros(4)
    jac = net.jacobian(y, u, du)

    def f(yy: np.ndarray) -> np.ndarray:
        return net.derivative(yy[:, None], u[:, None], du[:, None])[0][:, 0]

    steps = 1e-7 * np.maximum(np.abs(y), 1e-9)
    fd = np.stack([(f(y + e) - f(y - e)) / (2 * e[i]) for i, e in enumerate(np.diag(steps))], axis=1)
    np.testing.assert_allclose(jac, fd, rtol=1e-5, atol=1e-6 * np.abs(jac).max())


def test_quadratic_valves_satisfy_their_law(problem, rng):
    """The algebraic network solved by Newton satisfies ``dp = R_v q + K_q q |q|`` exactly."""
    model = problem.model()
    kq = 3e12
    net = NonlinearModel(model, valve_kq=kq, tyre_liftoff=False)
    w = rng.uniform(-1e-5, 1e-5, (net.dyn.size, 5))
    vel = rng.standard_normal((7, 5)) * 0.2
    h = net.hydraulic_state(w, vel)
    lin = net.a_aa @ h[net.alg] + net.a_ad @ h[net.dyn] + net.cp_alg @ vel  # R_v part only
    quad = net.kq_alg[:, None] * h[net.alg] * np.abs(h[net.alg])
    np.testing.assert_allclose(lin, quad, rtol=1e-9, atol=1e-6)
    assert np.abs(quad).max() > 1e3  # the quadratic term matters at these flows [Pa]
    with pytest.raises(ConfigError, match="nonlinear"):
        simulate(model, *_left_bump(0.001), valve_kq=kq)


def test_tyre_liftoff_caps_the_tyre_force(problem):
    """A 50 mm drop unloads the dropped tyres beyond their static load: the linear tyre pulls,
    the lift-off tyre lets go (dynamic load never exceeds the static one)."""
    model = problem.model()
    t = np.arange(0.0, 1.5, 1.0 / 200.0)
    road = step_profile(t, -0.05, 0.5, ("fl", "rl"))
    front, rear = model.vehicle.static_wheel_loads()
    static = np.array([front, front, rear, rear])
    lin = simulate(model, t, road)
    nl = simulate(model, t, road, "nonlinear", tyre_liftoff=True)
    assert np.any(lin.tyre_force_n > 1.5 * static)
    assert np.all(nl.tyre_force_n <= static * (1 + 1e-9))
    assert np.any(nl.tyre_force_n >= static * (1 - 1e-9))  # the wheel did leave the road


def test_reference_car_without_his(problem):
    model = CoupledModel(problem.spec.vehicle, None)
    t, road = _left_bump(0.001, duration_s=2.0)
    lin = simulate(model, t, road)
    nl = simulate(model, t, road, "nonlinear")
    assert lin.accumulator_names == () and lin.accumulator_pressure_pa.shape == (t.size, 0)
    np.testing.assert_allclose(nl.displacement, lin.displacement, rtol=0, atol=1e-6 * np.abs(lin.displacement).max())


# --- result object and errors ------------------------------------------------------------------


def test_result_frame_and_plots(problem):
    t, road = _left_bump(0.01, duration_s=1.0)
    res = simulate(problem.model(), t, road)
    frame = res.to_frame()
    for col in ("time", "road_fl", "z_s", "dphi", "ddtheta", "a_body_rr", "stroke_fl", "tyre_force_rl", "p_acc_A", "dv_acc_B"):
        assert col in frame.columns
    assert len(frame) == t.size
    np.testing.assert_allclose(frame["a_body_fl"], res.acceleration[:, :3] @ res.corners[0])
    assert frame.attrs["units"]["ddtheta"] == "rad/s^2" and frame.attrs["units"]["p_acc_A"] == "Pa"
    import plotly.io as pio

    default = pio.templates.default
    fig = res.plot_signals(("phi", "p_acc_A"))
    assert isinstance(fig, go.Figure) and len(fig.data) == 2
    assert fig.layout.yaxis.title.text == "phi [rad]" and fig.layout.yaxis2.title.text == "p_acc_A [Pa]"
    assert len(res.plot_pressures().data) == 2
    assert pio.templates.default == default  # the template goes to each figure, not plotly's default
    with pytest.raises(ConfigError, match="unknown signal"):
        res.plot_signals(("nope",))


def test_bad_inputs_raise_config_errors(problem):
    t, road = _left_bump(0.01, duration_s=1.0)
    model = problem.model()
    with pytest.raises(ConfigError, match="shape"):
        simulate(model, t, road[:, :3])
    with pytest.raises(ConfigError, match="increasing"):
        simulate(model, t[::-1], road)
    with pytest.raises(ConfigError, match="one design"):
        simulate(problem.model({"p0": [1e6, 2e6]}), t, road)
    with pytest.raises(ConfigError, match="interpolation"):
        simulate(model, t, road, interpolation="spline")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="mode"):
        simulate(model, t, road, "quadratic")  # type: ignore[arg-type]
