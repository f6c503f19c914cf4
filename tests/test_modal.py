"""Modal analysis: paper Table 1 and the Section IV modal trends."""

import numpy as np
import pandas as pd
import pytest

import hisopt
from hisopt.modal import MODE_NAMES, modal_table
from hisopt.model import CoupledModel
from hisopt.vehicle import VehicleParams


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
