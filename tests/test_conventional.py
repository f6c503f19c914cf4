"""Anti-roll bars in the 7-DOF car and the ``conventional`` reference layout (docs/model.md §2.3, §15.6).

The reference is a car with anti-roll bars built here by hand: its matrices written out from
the half tracks and the bar rates (energy ``k (delta_L - delta_R)^2 / 2`` per axle), its
roll gradient in closed form (springs and bars in series with the tyres, docs/model.md §6.4)
and its frequency response solved from those matrices. Error budget: the hand matrices and
hisopt's are sums of the same few products in another order, so they agree to a few
rounding errors of their largest entry (rtol 1e-12); the closed-form roll gradient and the
solved one to the conditioning of the 7 x 7 solve (rtol 1e-9).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hisopt.constants import G_MPS2
from hisopt.coupled.model import CoupledModel
from hisopt.evaluation.evaluate import roll_gradient
from hisopt.problem import load_problem
from hisopt.vehicle import VehicleParams, damping_matrix, full_car, mass_matrix, stiffness_matrix
from tests.cli_inprocess import run_cli

K_F, K_R = 25_000.0, 10_000.0  # [N/m] bar rates at the wheel


def hand_matrices(v: VehicleParams, k_f: float, k_r: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """M, C, K and the road input [0; K_t] of the symmetric car (y_cg = 0), written out."""
    t_f, t_r, l_f, l_r = v.t_f, v.t_r, v.l_f, v.l_r
    g = np.array(
        [
            [1.0, t_f, -l_f, -1.0, 0.0, 0.0, 0.0],
            [1.0, -t_f, -l_f, 0.0, -1.0, 0.0, 0.0],
            [1.0, t_r, l_r, 0.0, 0.0, -1.0, 0.0],
            [1.0, -t_r, l_r, 0.0, 0.0, 0.0, -1.0],
        ]
    )
    bars = np.zeros((4, 4))
    bars[:2, :2] = k_f * np.array([[1.0, -1.0], [-1.0, 1.0]])  # k (delta_L - delta_R)^2 / 2 per axle
    bars[2:, 2:] = k_r * np.array([[1.0, -1.0], [-1.0, 1.0]])
    tyres = np.diag([v.k_tf, v.k_tf, v.k_tr, v.k_tr])
    k = g.T @ (np.diag([v.k_sf, v.k_sf, v.k_sr, v.k_sr]) + bars) @ g
    k[3:, 3:] += tyres
    c = g.T @ np.diag([v.c_sf, v.c_sf, v.c_sr, v.c_sr]) @ g
    m = np.diag([v.m_s, v.I_x, v.I_y, v.m_uf, v.m_uf, v.m_ur, v.m_ur])
    road = np.zeros((7, 4))
    road[3:, :] = tyres
    return m, c, k, road


def roll_stiffness(v: VehicleParams, k_f: float, k_r: float) -> float:
    """[N m/rad] Each axle's springs ``2 k_s t^2`` and bar ``4 k t^2`` (``delta_L - delta_R = 2 t phi``)
    in series with its tyres ``2 k_t t^2``; the two axles in parallel (the body is rigid)."""
    front = 1.0 / (1.0 / (2 * v.k_sf * v.t_f**2 + 4 * k_f * v.t_f**2) + 1.0 / (2 * v.k_tf * v.t_f**2))
    rear = 1.0 / (1.0 / (2 * v.k_sr * v.t_r**2 + 4 * k_r * v.t_r**2) + 1.0 / (2 * v.k_tr * v.t_r**2))
    return front + rear


@pytest.fixture(scope="module")
def car() -> VehicleParams:
    return VehicleParams(k_arb_f=K_F, k_arb_r=K_R)


def test_matrices_match_the_hand_built_car(car: VehicleParams) -> None:
    m, c, k, _ = hand_matrices(car, K_F, K_R)
    assert np.allclose(stiffness_matrix(car), k, rtol=0, atol=1e-12 * np.abs(k).max())
    assert np.array_equal(mass_matrix(car), m)
    assert np.allclose(damping_matrix(car), c, rtol=0, atol=1e-12 * np.abs(c).max())
    # the bar's roll stiffness 4 k t^2 per axle, and none in bounce or pitch
    bars = full_car.anti_roll_bars(car)
    assert bars[1, 1] == pytest.approx(4 * K_F * car.t_f**2 + 4 * K_R * car.t_r**2, rel=1e-14)
    assert np.all(bars[0, :] == 0) and np.all(bars[2, :] == 0)


def test_roll_gradient_and_roll_frequency_of_the_hand_built_car(car: VehicleParams) -> None:
    m, _, k, _ = hand_matrices(car, K_F, K_R)
    moment = car.m_s * car.h_0s  # [N m per m/s^2]: the lateral force's moment per unit acceleration
    hand = moment * G_MPS2 / (roll_stiffness(car, K_F, K_R) - moment * G_MPS2)  # [rad/g] with the gravity moment (docs/model.md §6.4)
    assert roll_gradient(CoupledModel(car, None), True).item() == pytest.approx(hand, rel=1e-9)
    # the roll mode: the undamped mode with the largest roll share
    lam, vec = np.linalg.eig(np.linalg.solve(m, k))
    mine = np.linalg.eig(np.linalg.solve(mass_matrix(car), stiffness_matrix(car)))
    roll = np.argmax(np.abs(vec[1]) / np.linalg.norm(vec, axis=0))
    roll_mine = np.argmax(np.abs(mine[1][1]) / np.linalg.norm(mine[1], axis=0))
    f_hand, f_mine = np.sqrt(lam[roll].real) / (2 * np.pi), np.sqrt(mine[0][roll_mine].real) / (2 * np.pi)
    assert f_mine == pytest.approx(f_hand, rel=1e-12)
    without = np.linalg.eig(np.linalg.solve(mass_matrix(VehicleParams()), stiffness_matrix(VehicleParams())))
    roll_without = np.argmax(np.abs(without[1][1]) / np.linalg.norm(without[1], axis=0))
    assert f_mine > np.sqrt(without[0][roll_without].real) / (2 * np.pi) + 0.3  # the bars stiffen roll: 1.57 Hz -> above 1.9 Hz


def test_frequency_response_of_the_hand_built_car(car: VehicleParams) -> None:
    """The FRF every PSD of the car is built on (``|H|^2`` times the road's PSD)."""
    m, c, k, road = hand_matrices(car, K_F, K_R)
    s = 2j * np.pi * np.array([0.5, 1.5, 4.0, 11.0])
    hand = np.stack([np.linalg.solve(x**2 * m + x * c + k, road) for x in s])
    mine = CoupledModel(car, None).frequency_response(s)
    assert np.allclose(mine, hand, rtol=1e-10, atol=1e-12 * np.abs(hand).max())


def test_default_bars_leave_every_result_unchanged(monkeypatch: pytest.MonkeyPatch) -> None:
    """Bars of rate 0 add exact zeros: the evaluator's results are those of the stiffness
    without the bar term (springs and tyres alone, as before the bars) to the last bit."""
    problem = load_problem("problems/roll_plane_his.toml")
    x = problem.baseline[None, :] * np.array([[1.0], [1.3]])
    with_bars = problem.evaluator()(x)
    monkeypatch.setattr(full_car, "anti_roll_bars", lambda vehicle: 0.0)
    fresh = load_problem("problems/roll_plane_his.toml")
    without = fresh.evaluator()(x)
    assert with_bars.keys() == without.keys()
    for name in with_bars:
        assert np.array_equal(with_bars[name], without[name], equal_nan=True), name


def test_bad_bar_rate_is_refused() -> None:
    with pytest.raises(ValueError, match="k_arb_f"):
        VehicleParams(k_arb_f=-1.0)


def test_conventional_is_sized_at_the_limit() -> None:
    from hisopt.studies.conventional import size_conventional

    problem = load_problem("problems/roll_plane_his.toml")
    limit = 0.03  # [rad/g]
    res = size_conventional(problem, "roll_gradient", limit)
    assert res.handling <= limit and np.isfinite(res.sigma_aw)
    # the hand formula at the bars found gives the handling reported (gravity_moment = false here)
    v = problem.vehicle
    assert res.handling == pytest.approx(v.m_s * v.h_0s * G_MPS2 / roll_stiffness(v, res.k_arb_f, res.k_arb_r), rel=1e-9)
    # the softest bars hold the limit: best comfort at equal handling lies on it (one grid step of the last zoom)
    assert res.handling == pytest.approx(limit, rel=2e-3)
    assert not size_conventional(problem, "roll_gradient", 1e-4).met


def test_compare_layouts_reports_the_gain_against_conventional(tmp_path) -> None:
    out = tmp_path / "study"
    args = ("--layouts", "conventional", "--seeds", "1", "--pop", "8", "--gens", "2", "--out", str(out))
    result = run_cli("compare-layouts", "problems/roll_plane_his.toml", *args)
    assert result.code == 0, result.stderr
    from hisopt.io import read_csv

    table = read_csv(out / "layouts.csv")
    assert list(table["layout"]) == ["roll_plane", "conventional"]
    row = table.set_index("layout")
    assert row.loc["conventional", "gain_vs_conventional_pct"] == 0.0
    expected = 100 * (1 - row.loc["roll_plane", "sigma_aw_at_limit"] / row.loc["conventional", "sigma_aw_at_limit"])
    assert row.loc["roll_plane", "gain_vs_conventional_pct"] == pytest.approx(expected, rel=1e-12)
    assert row.loc["conventional", "handling_at_best"] <= row.loc["conventional", "handling_limit"]
    assert "gain_vs_conventional_pct" in result.stdout
    before = (out / "report.html").read_bytes()
    again = run_cli("report", str(out))  # the study re-read from its files: conventional has no runs
    assert again.code == 0, again.stderr
    assert (out / "report.html").read_bytes() == before


def _with_bars(tmp_path: Path, lines: str) -> Path:
    text = Path("problems/roll_plane_his.toml").read_text(encoding="utf-8").replace("\n[vehicle]\n", f"\n[vehicle]\n{lines}\n", 1)
    path = tmp_path / "bars.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_bars_in_a_problem_file_reach_the_numpy_and_casadi_models(tmp_path) -> None:
    """``[vehicle] k_arb_f = "30 kN/m"`` is read in its unit, and the one stiffness matrix
    carries the bars into both engines: the CasADi model's roll gradient (not compiled) equals
    the numpy evaluator's to the rounding of the same 7 x 7 solve."""
    import casadi as ca

    from hisopt.optim.gradient.casadi_model import CasadiModel

    problem = load_problem(_with_bars(tmp_path, 'k_arb_f = "30 kN/m"\nk_arb_r = 12000.0'))
    assert (problem.vehicle.k_arb_f, problem.vehicle.k_arb_r) == (30_000.0, 12_000.0)
    x = problem.baseline
    numpy_value = roll_gradient(problem.model(x[None, :]), problem.spec.handling.gravity_moment).item()
    symbol = ca.MX.sym("x", len(x))
    casadi_value = float(ca.Function("rg", [symbol], [CasadiModel(problem, compile=False).roll_gradient(symbol)])(x))
    assert casadi_value == pytest.approx(numpy_value, rel=1e-10)
    plain = roll_gradient(load_problem("problems/roll_plane_his.toml").model(x[None, :]), False).item()
    assert numpy_value < plain  # the bars stiffen roll


def test_a_negative_bar_rate_is_one_line_and_exit_2(tmp_path) -> None:
    outcome = run_cli("modes", str(_with_bars(tmp_path, "k_arb_f = -5.0")))
    assert outcome.code == 2 and len(outcome.error_lines) == 1, outcome.stderr
    assert "vehicle.k_arb_f" in outcome.stderr and "greater than or equal to 0" in outcome.stderr
