"""Modal analysis: paper Table 1 and the Section IV modal trends."""

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

import hisopt
from hisopt.coupled.modal import MODE_ALIASES, MODE_NAMES, canonical_mode_name, modal_table
from hisopt.coupled.model import CoupledModel
from hisopt.vehicle import VehicleParams
from tests.conftest import random_designs


def freq(problem, mode, **design):
    table = hisopt.modal_analysis(problem, design)
    return float(table.set_index("mode").loc[mode, "frequency_hz"])


def test_table_columns_and_names(problem):
    table = hisopt.modal_analysis(problem, problem.baseline)
    assert list(table["mode"]) == list(MODE_NAMES)
    for col in ("frequency_hz", "damping_ratio", "motion", "shape_z_s", "shape_phi", "shape_z_u4"):
        assert col in table
    shapes = table.filter(like="shape_").to_numpy()
    np.testing.assert_allclose(np.abs(shapes).max(axis=1), 1.0)
    assert (table["damping_ratio"] > 0).all()
    by_mode = table.set_index("mode")
    assert by_mode.loc["roll", "motion"] == "body roll"
    assert by_mode.loc["bounce", "dominant"] == "z_s"
    assert by_mode.loc["rear_axle_tramp", "motion"] == "tramp: front 50 %, rear 50 %, axles opposed"
    assert ((table["motion_share"] > 0) & (table["motion_share"] <= 1)).all()


def test_aliases_name_the_same_modes():
    assert MODE_ALIASES == {
        "wheel_hop_fl": "front_axle_hop",
        "wheel_hop_fr": "front_axle_tramp",
        "wheel_hop_rl": "rear_axle_hop",
        "wheel_hop_rr": "rear_axle_tramp",
    }
    assert [canonical_mode_name(n) for n in MODE_NAMES] == list(MODE_NAMES)
    assert canonical_mode_name("wheel_hop_rr") == "rear_axle_tramp"
    with pytest.raises(ValueError, match="front_axle_hop.*wheel_hop_fl"):
        canonical_mode_name("wheel_hop")


# --- names from shapes: the same physical mode keeps its name -----------------------------------
def wheel_warp(v: VehicleParams, rv: float = 0.0, area_b: float = 0.0) -> tuple[float, float]:
    """[Hz], [-] Closed form of the wheel warp (FL, RR up; FR, RL down) of a car with identical
    wheel stations front and rear: the body and a roll-plane HIS's accumulators see no net
    force or flow, so each wheel is a mass on spring plus tyre, damped by its damper and its
    bottom-chamber valve (``R_v A_b^2``, docs/model.md §3.7)."""
    k, m = v.k_sf + v.k_tf, v.m_uf
    return np.sqrt(k / m) / (2 * np.pi), (v.c_sf + rv * area_b**2) / (2 * np.sqrt(k * m))


def test_rear_axle_tramp_is_the_wheel_warp_for_every_design(problem, rng):
    # the issue-12 swap: the unchanged 11.08 Hz warp mode was wheel_hop_fr at some designs and
    # wheel_hop_rr at others; by shape it is always rear_axle_tramp, with or without HIS
    v = problem.spec.vehicle
    ref = modal_table(CoupledModel(v)).set_index("mode")
    f, zeta = wheel_warp(v)
    assert ref.loc["rear_axle_tramp", "frequency_hz"] == pytest.approx(f, rel=1e-9)
    assert ref.loc["rear_axle_tramp", "damping_ratio"] == pytest.approx(zeta, rel=1e-9)
    for x in random_designs(problem, 30, rng):
        _, d_a, lam, rv = x
        table = hisopt.modal_analysis(problem, x).set_index("mode")
        f, zeta = wheel_warp(v, rv, d_a / (1 - lam))
        warp = table.loc["rear_axle_tramp"]
        assert warp["frequency_hz"] == pytest.approx(f, rel=1e-9), x
        assert warp["damping_ratio"] == pytest.approx(zeta, rel=1e-9), x
        shape = warp[["shape_z_u1", "shape_z_u2", "shape_z_u3", "shape_z_u4"]].to_numpy(float)
        np.testing.assert_allclose(shape * shape[0], [1, -1, -1, 1], atol=1e-9)
        # its partner: both axles tramp equally, in the same sense (the roll-coupled one)
        partner = table.loc["front_axle_tramp", ["shape_z_u1", "shape_z_u2", "shape_z_u3", "shape_z_u4"]].to_numpy(float)
        np.testing.assert_allclose(partner * partner[0], [1, -1, 1, -1], atol=1e-9)


def mass_weighted_shapes(table: pd.DataFrame, vehicle: VehicleParams) -> pd.DataFrame:
    m = np.sqrt([vehicle.m_s, vehicle.I_x, vehicle.I_y, vehicle.m_uf, vehicle.m_uf, vehicle.m_ur, vehicle.m_ur])
    shapes = table.set_index("mode").filter(like="shape_") * m
    return shapes.div(np.linalg.norm(shapes.to_numpy(), axis=1), axis=0)


def test_wheel_modes_keep_their_names_with_and_without_his(problem, rng):
    # each wheel mode's shape with HIS is closest (largest MAC) to the reference mode of the same name
    v = problem.spec.vehicle
    wheels = [n for n in MODE_NAMES if "axle" in n]
    ref = mass_weighted_shapes(hisopt.modal_analysis(problem, his=False), v).loc[wheels]
    for x in random_designs(problem, 20, rng):
        his = mass_weighted_shapes(hisopt.modal_analysis(problem, x), v).loc[wheels]
        mac = (ref.to_numpy() @ his.to_numpy().T) ** 2
        assert np.array_equal(np.argmax(mac, axis=1), np.arange(len(wheels))), (x, mac.round(2))


def test_front_and_rear_wheel_modes_of_a_car_with_different_axles(problem):
    # heavier rear wheels on softer tyres: each wheel mode belongs mostly to one axle, and the
    # names say which, without and with a HIS
    v = VehicleParams(m_ur=70.0, k_tr=150_000.0)
    for table in (modal_table(CoupledModel(v)), modal_table(replace(problem.model(), vehicle=v))):
        t = table.set_index("mode")
        front = t.loc[["front_axle_hop", "front_axle_tramp"]]
        rear = t.loc[["rear_axle_hop", "rear_axle_tramp"]]
        assert (front[["shape_z_u1", "shape_z_u2"]].abs().min(axis=1) > 0.9).all()
        assert (rear[["shape_z_u3", "shape_z_u4"]].abs().min(axis=1) > 0.9).all()
        assert (front[["shape_z_u3", "shape_z_u4"]].abs().max(axis=1) < 0.5).all()
        assert (rear[["shape_z_u1", "shape_z_u2"]].abs().max(axis=1) < 0.5).all()


def test_design_as_dict_or_sequence(problem):
    a = hisopt.modal_analysis(problem, {"p0": 3e6})
    b = hisopt.modal_analysis(problem, [3e6, 10e-4, 0.5, 8e5])
    pd.testing.assert_frame_equal(a, b)


def test_reference_vehicle_closed_form_roll():
    """Undamped car without HIS: roll on springs in series with tyres, sqrt(k_roll / I_x)."""
    v = VehicleParams(c_sf=0.0, c_sr=0.0)
    ref = modal_table(CoupledModel(v)).set_index("mode")
    k_s_roll = 2 * v.k_sf * v.t_f**2 + 2 * v.k_sr * v.t_r**2
    k_t_roll = 2 * v.k_tf * v.t_f**2 + 2 * v.k_tr * v.t_r**2
    series = k_s_roll * k_t_roll / (k_s_roll + k_t_roll)
    assert ref.loc["roll", "frequency_hz"] == pytest.approx(np.sqrt(series / v.I_x) / (2 * np.pi), rel=0.02)


def test_his_stiffens_roll_far_more_than_bounce_and_pitch(problem):
    ref = hisopt.modal_analysis(problem, his=False).set_index("mode")["frequency_hz"]
    his = hisopt.modal_analysis(problem).set_index("mode")["frequency_hz"]
    rise = his / ref - 1
    assert rise["roll"] > 0.5
    assert rise["roll"] > 2.5 * rise["bounce"]
    assert abs(rise["pitch"]) < 0.1


@pytest.mark.parametrize("var,lo,hi", [("p0", 0.5e6, 4e6), ("dA", 2e-4, 25e-4), ("lam", 0.1, 0.8)])
def test_roll_frequency_rises(problem, var, lo, hi):
    values = np.linspace(lo, hi, 6)
    f = [freq(problem, "roll", **{var: x}) for x in values]
    assert np.all(np.diff(f) > 0), f


@pytest.mark.parametrize("var,lo,hi", [("p0", 0.5e6, 4e6), ("dA", 2e-4, 25e-4)])
def test_bounce_frequency_rises(problem, var, lo, hi):
    values = np.linspace(lo, hi, 6)
    f = [freq(problem, "bounce", **{var: x}) for x in values]
    assert np.all(np.diff(f) > 0), f


def test_bounce_frequency_independent_of_lam(problem):
    f = [freq(problem, "bounce", lam=x) for x in np.linspace(0.1, 0.8, 8)]
    assert np.ptp(f) / np.mean(f) < 0.01, f


@pytest.mark.parametrize("var,lo,hi", [("p0", 1e6, 4e6), ("lam", 0.1, 0.8)])
def test_pitch_frequency_flat(problem, var, lo, hi):
    f = [freq(problem, "pitch", **{var: x}) for x in np.linspace(lo, hi, 7)]
    assert np.ptp(f) / np.mean(f) < 0.05, f


def test_distributed_pipes_refine_lumped_body_modes(problem):
    pipes = {"diameter": 0.01, "length_front": 1.0, "length_rear": 2.5}
    lumped = hisopt.modal_analysis(problem.with_values(pipes=pipes)).set_index("mode")
    dist = hisopt.modal_analysis(problem.with_values(pipes=pipes, pipe_model="distributed")).set_index("mode")
    for mode in ("bounce", "roll", "pitch"):
        assert dist.loc[mode, "frequency_hz"] == pytest.approx(lumped.loc[mode, "frequency_hz"], rel=0.01)


def test_a_root_newton_lands_on_exactly_does_not_fail_the_batch():
    """refine_roots' step needs tr(K^-1 dK/ds); where K is singular to working precision
    (Newton landed on a root exactly: seen with pipes of 1e-10 m) the step is 0 for that
    root only, not a LinAlgError that made the repair flag a whole batch of 256 designs."""
    from hisopt.coupled.roots import _log_det_slope

    rng = np.random.default_rng(3)
    k = rng.standard_normal((3, 7, 7)) + 1j * rng.standard_normal((3, 7, 7))
    dk = rng.standard_normal((3, 7, 7)) + 0j
    k[1, :, 0] = 0.0  # exactly singular
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.solve(k, dk)
    slope = _log_det_slope(k, dk)
    assert np.isinf(slope[1]) and -1.0 / slope[1] == 0.0
    for i in (0, 2):
        assert slope[i] == pytest.approx(np.trace(np.linalg.inv(k[i]) @ dk[i]), rel=1e-12)
