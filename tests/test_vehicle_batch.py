"""A batch of cars (hisopt.vehicle.batch, docs/model.md §2.6).

Checks: one car's matrices are those of the paper's construction written out here
(``np.diag``, ``np.array`` of the entries, ``G^T K G`` as a sum over the corners, to the last
bit, and the product ``G^T K G`` within its rounding budget); a batch's row is its
car's matrix to the last bit, also ``D0(s)`` over frequencies; every row is symmetric and its
stiffness positive definite; a batch names the rule each bad row breaks.
"""

from __future__ import annotations

import numpy as np
import pytest

from hisopt.errors import ConfigError
from hisopt.vehicle import (
    VehicleParams,
    body_to_corners,
    damping_matrix,
    dynamic_stiffness_matrix,
    mass_matrix,
    road_damping_input,
    road_stiffness_input,
    stiffness_matrix,
    stroke_matrix,
)
from hisopt.vehicle.batch import VehicleBatch

MATRICES = (body_to_corners, stroke_matrix, mass_matrix, stiffness_matrix, damping_matrix, road_stiffness_input, road_damping_input)
VARIED = ("m_s", "I_x", "I_y", "m_uf", "m_ur", "k_sf", "k_sr", "c_sf", "c_sr", "k_tf", "k_tr", "c_tf", "c_tr", "t_f", "t_r", "l_f", "l_r", "y_cg")


def written_out(v: VehicleParams) -> dict[str, np.ndarray]:
    """The matrices as the paper's equations state them, one car."""
    t = np.array([[1.0, v.t_f - v.y_cg, -v.l_f], [1.0, -v.t_f - v.y_cg, -v.l_f], [1.0, v.t_r - v.y_cg, v.l_r], [1.0, -v.t_r - v.y_cg, v.l_r]])
    g = np.hstack([t, -np.eye(4)])

    def wheels(f: float, r: float) -> np.ndarray:
        return np.array([f, f, r, r])

    k, c = np.zeros((7, 7)), np.zeros((7, 7))
    for w, (ks, cs) in enumerate(zip(wheels(v.k_sf, v.k_sr), wheels(v.c_sf, v.c_sr), strict=True)):  # G^T diag(k) G, corner by corner
        k += ks * np.outer(g[w], g[w])
        c += cs * np.outer(g[w], g[w])
    k[3:, 3:] += np.diag(wheels(v.k_tf, v.k_tr))
    c[3:, 3:] += np.diag(wheels(v.c_tf, v.c_tr))
    bk, bc = np.zeros((7, 4)), np.zeros((7, 4))
    bk[3:], bc[3:] = np.diag(wheels(v.k_tf, v.k_tr)), np.diag(wheels(v.c_tf, v.c_tr))
    return {
        "body_to_corners": t,
        "stroke_matrix": g,
        "mass_matrix": np.diag(np.r_[v.m_s, v.I_x, v.I_y, wheels(v.m_uf, v.m_ur)]),
        "stiffness_matrix": k,
        "damping_matrix": c,
        "road_stiffness_input": bk,
        "road_damping_input": bc,
    }


def wheels4(front: float, rear: float) -> np.ndarray:
    return np.array([front, front, rear, rear])


@pytest.fixture(scope="module")
def cars() -> VehicleBatch:
    rng = np.random.default_rng(26)
    base = VehicleParams(c_tf=150.0, c_tr=120.0)
    values = {name: getattr(base, name) * rng.uniform(0.7, 1.3, 6) for name in VARIED if name != "y_cg"}
    values["y_cg"] = rng.uniform(-0.2, 0.2, 6)
    return VehicleBatch.of(base, values)


@pytest.mark.parametrize("car", [VehicleParams(), VehicleParams(y_cg=0.12, c_tf=150.0, c_tr=90.0, t_r=0.78, k_sr=21_000.0)])
def test_one_car_is_the_papers_construction_to_the_last_bit(car):
    expected = written_out(car)
    for build in MATRICES:
        got = build(car)
        assert got.shape == expected[build.__name__].shape
        np.testing.assert_array_equal(got, expected[build.__name__], err_msg=build.__name__)
    # the corner sum is G^T diag(k) G + diag(tyres) computed as products, within their rounding:
    # four terms and the tyre, each step within eps of its magnitude, so 5 eps of the magnitudes' sum
    g = expected["stroke_matrix"]
    for build, springs, tyres in (
        (stiffness_matrix, (car.k_sf, car.k_sr), (car.k_tf, car.k_tr)),
        (damping_matrix, (car.c_sf, car.c_sr), (car.c_tf, car.c_tr)),
    ):
        kw, tw = np.diag(wheels4(*springs)), np.zeros((7, 7))
        tw[3:, 3:] = np.diag(wheels4(*tyres))
        budget = 5 * np.finfo(float).eps * (np.abs(g.T) @ kw @ np.abs(g) + tw)
        assert (np.abs(build(car) - (g.T @ kw @ g + tw)) <= budget).all(), build.__name__
    s = 2j * np.pi * np.array([0.5, 3.0, 40.0])
    d0 = dynamic_stiffness_matrix(car, s)
    assert d0.shape == (3, 7, 7)
    m, c, k = expected["mass_matrix"], expected["damping_matrix"], expected["stiffness_matrix"]
    np.testing.assert_array_equal(d0, s[:, None, None] ** 2 * m + s[:, None, None] * c + k)


def test_a_batch_row_is_its_cars_matrix_to_the_last_bit(cars):
    assert cars.shape == (6,)
    for build in MATRICES:
        batch = build(cars)
        for i in range(6):
            np.testing.assert_array_equal(batch[i], build(cars.car(i)), err_msg=build.__name__)
    s = 2j * np.pi * np.linspace(0.5, 80.0, 5)[None, :] * np.linspace(1.0, 1.5, 6)[:, None]  # (6, 5): each car its own frequencies
    d0 = dynamic_stiffness_matrix(cars, s)
    assert d0.shape == (6, 5, 7, 7)
    for i in range(6):
        np.testing.assert_array_equal(d0[i], dynamic_stiffness_matrix(cars.car(i), s[i]))
    np.testing.assert_array_equal(cars.wheelbase, cars.l_f + cars.l_r)


def test_every_row_is_symmetric_and_grounded(cars):
    for build in (mass_matrix, stiffness_matrix, damping_matrix):
        a = build(cars)
        np.testing.assert_array_equal(a, np.swapaxes(a, -1, -2))
    assert (np.linalg.eigvalsh(stiffness_matrix(cars)).min(axis=-1) > 0).all()  # the tyres ground every mode
    # a rigid heave of body and wheels strokes no corner, in every car
    heave = np.array([1, 0, 0, 1, 1, 1, 1.0])
    assert np.abs(stroke_matrix(cars) @ heave).max() <= 1e-15


def test_a_batch_names_the_rule_each_bad_row_breaks():
    car = VehicleParams()
    batch = VehicleBatch.of(car, {"m_s": [1200.0, -3.0, np.nan, 1200.0, 1200.0], "k_sf": [1.0, 1.0, 1.0, -1.0, 0.0], "y_cg": [0, 0, 0, 0, 0.8]})
    assert list(batch.breaks()) == [
        "",
        "m_s = -3 breaks m_s > 0",
        "m_s = nan is not a finite number",
        "k_sf = -1 breaks k_sf >= 0",
        "y_cg = 0.8 m puts the CG outside the track (|y_cg| < 0.74 m)",
    ]
    assert batch.car(0).m_s == 1200.0
    with pytest.raises(ValueError, match="m_s"):
        batch.car(1)


def test_an_unknown_vehicle_parameter_is_named():
    with pytest.raises(ConfigError, match="unknown vehicle parameter 'mass'") as info:
        VehicleBatch.of(VehicleParams(), {"mass": [1.0]})
    assert info.value.key == "vehicle.mass"


@pytest.mark.parametrize("name", ["roll_plane_his", "roll_plane_his_pipes", "roll_plane_his_parts"])
def test_a_model_of_many_cars_is_each_cars_model(cars, name, rng):
    """CoupledModel with a batch of cars and a batch of HIS designs: each design's direct
    FRF and state-space FRF are those of its car alone, within the solve's rounding
    (10 cond(D) eps of the response, D the design's dynamic stiffness or sI - A)."""
    import hisopt
    from hisopt.coupled.model import CoupledModel
    from tests.conftest import DEFAULT_PROBLEM, random_designs

    problem = hisopt.load_problem(DEFAULT_PROBLEM.with_name(f"{name}.toml"))
    x = random_designs(problem, 6, rng, corners=False)
    his = problem.model(x).his
    many = CoupledModel(cars, his)
    s = 2j * np.pi * np.array([0.7, 1.9, 9.5, 30.0])
    sb = np.broadcast_to(s, (6, 4))
    h = many.frequency_response(sb)
    ss = many.state_space()
    h_ss = ss.frequency_response(sb)
    eps = np.finfo(float).eps
    for i in range(6):
        one = CoupledModel(cars.car(i), his.subset([i]))
        want = one.frequency_response(s)[0]
        cond = np.linalg.cond(one.dynamic_stiffness(s)[0])  # (F,)
        assert (np.abs(h[i] - want) <= 10 * cond[:, None, None] * eps * np.abs(want).max(axis=(-2, -1), keepdims=True)).all()
        one_ss = one.state_space()
        want_ss = one_ss.frequency_response(s)[0]
        n = one_ss.n_states
        cond_ss = np.linalg.cond(s[:, None, None] * np.eye(n) - one_ss.a[0])
        assert (np.abs(h_ss[i] - want_ss) <= 10 * cond_ss[:, None, None] * eps * np.abs(want_ss).max(axis=(-2, -1), keepdims=True)).all()
