"""Physical damper valves in CasADi (docs/model.md §3.3, §11).

- The laws :func:`~hisopt.hydraulics.laws.damper_valve_pressure_drop` and
  :func:`~hisopt.hydraulics.laws.damper_valve_equivalent_resistance` built on CasADi symbols
  (``SX`` and ``MX``, evaluated through a ``casadi.Function``) give numpy's numbers across the
  valves box, within a rounding budget: each side rounds every operation to half an ulp, the
  two sides differ in the order of the equivalent resistance's 48-node sum (numpy's dot
  product against CasADi's running sum) and possibly in ``exp``/``sqrt``'s last bit.
- CasADi's AD gradient of the equivalent resistance in ``(q_rms, d, p_c)`` against central
  finite differences of the numpy function, within their truncation and rounding.
- The CasADi model of a problem whose damper valves' RMS flow is given agrees with the numpy
  evaluator on every quantity within the rounding budget of their solves (as tests/test_core.py
  does for the other problems).
- With the RMS flows solved (the shipped valves problem), the SLP refinement works on the
  evaluator's fixed point, and the IPOPT one refuses in one line (exit 2, nothing written).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import hisopt
from hisopt.errors import RunError
from hisopt.hydraulics import laws
from hisopt.optim.gradient.casadi_model import CasadiModel
from hisopt.optim.gradient.refine import refine_front, refine_run
from hisopt.optim.run import optimize
from hisopt.optim.rundir import read_front
from hisopt.problem import problem_from_dict
from tests.cli_inprocess import run_cli
from tests.conftest import ROOT, random_designs
from tests.test_core import ALL_QUANTITIES, assert_engines_agree
from tests.test_refine import check_refined

EPS = np.finfo(float).eps
RHO = 850.0  # [kg/m^3] oil
N_POINTS = 3000
GAIN = 2.0 / math.sqrt(2.0 * math.pi)  # R_eq = r + GAIN (bleed + tail / s)
VALVES_PROBLEM = ROOT / "tests" / "data" / "valves_one_road.toml"  # the valves problem on its city road alone


def valve_box(n: int, seed: int, cracking_lower: float = 0.0) -> dict[str, np.ndarray]:
    """Random valves and flows across the box: orifice 1-6 mm, C_d 0.6-0.8, cracking
    ``cracking_lower``-4 MPa, R_b 1e8-1e10 and q_rms 1e-6-1e-2 m^3/s (log-uniform), laminar
    part 0-1e8 Pa s/m^3."""
    rng = np.random.default_rng(seed)
    return {
        "q_rms": 10.0 ** rng.uniform(-6.0, -2.0, n),
        "d": rng.uniform(1e-3, 6e-3, n),
        "cd": rng.uniform(0.6, 0.8, n),
        "p_c": rng.uniform(cracking_lower, 4e6, n),
        "r_b": 10.0 ** rng.uniform(8.0, 10.0, n),
        "r": rng.uniform(0.0, 1e8, n),
    }


def resistance(q_rms, d, cd, p_c, r_b, r):  # noqa: ANN001, ANN201  (floats, arrays or CasADi symbols alike)
    return laws.damper_valve_equivalent_resistance(q_rms, laws.orifice_coefficient(d, cd, RHO), p_c, r_b, r)


def casadi_resistance(kind, v: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:  # noqa: ANN001
    """R_eq and its AD gradient in (q_rms, d, p_c) at every point, through one mapped Function."""
    names = list(v)
    xs = {name: kind.sym(name) for name in names}
    out = resistance(**xs)
    grad = ca.gradient(out, ca.vertcat(xs["q_rms"], xs["d"], xs["p_c"]))
    fn = ca.Function("r_eq", list(xs.values()), [out, grad]).map(len(v["d"]))
    value, gradient = fn(*(v[name] for name in names))
    return np.array(value).ravel(), np.array(gradient)


def rounding_unit(v: dict[str, np.ndarray]) -> np.ndarray:
    """[Pa s m^-3] Budget of the rounding of either side's equivalent resistance.

    ``R_eq = r + GAIN (bleed + tail / s)``: the bleed's share ``K s (2 - (x_c^2 + 2)
    exp(-x_c^2 / 2))`` to 4 ulps of its two terms' magnitudes (it cancels for small ``x_c``,
    and the error of each term is relative to the term, not to the difference); the tail's 48
    positive terms to 4 ulps each plus 48 ulps for summing them in another order; the sum with
    ``r`` to 1 ulp of ``R_eq``.
    """
    r_eq = resistance(**v)
    kq = laws.orifice_coefficient(v["d"], v["cd"], RHO)
    s = v["q_rms"]
    x_c = np.sqrt(v["p_c"] / kq) / s
    decay = (x_c * x_c + 2.0) * np.exp(-0.5 * x_c * x_c)
    bleed_terms = kq * s * (2.0 + decay)
    tail = np.abs((r_eq - v["r"]) / GAIN - kq * s * (2.0 - decay))  # tail / s, from numpy's own value
    return EPS * (np.abs(r_eq) + GAIN * (4.0 * bleed_terms + (4.0 + laws.TAIL_NODES) * tail))


@pytest.mark.parametrize("kind", [ca.SX, ca.MX], ids=["SX", "MX"])
def test_equivalent_resistance_casadi_equals_numpy_within_rounding(kind):
    v = valve_box(N_POINTS, seed=1)
    numpy_value = resistance(**v)
    value, _ = casadi_resistance(kind, v)
    unit = rounding_unit(v)
    assert np.all(np.isfinite(value))
    assert np.all(np.abs(value - numpy_value) <= unit), np.max(np.abs(value - numpy_value) / unit)
    # the budget discriminates: a 1e-9 relative error anywhere would exceed it at most points
    assert np.median(unit / np.abs(numpy_value)) < 1e-12
    # and the box reaches both regimes: the blow-off closed (x_c >> 1) and open (x_c << 1)
    x_c = np.sqrt(v["p_c"] / laws.orifice_coefficient(v["d"], v["cd"], RHO)) / v["q_rms"]
    assert np.mean(x_c > 5.0) > 0.2 and np.mean(x_c < 0.5) > 0.2


@pytest.mark.parametrize("kind", [ca.SX, ca.MX], ids=["SX", "MX"])
def test_pressure_drop_casadi_equals_numpy_within_rounding(kind):
    """Over +-5 crossover flows: the drop to 8 ulps of its laminar and valve parts' magnitudes
    (the valve part: a handful of square roots, products and sums, each to half an ulp)."""
    v = valve_box(N_POINTS, seed=2)
    kq = laws.orifice_coefficient(v["d"], v["cd"], RHO)
    q_c = np.sqrt(v["p_c"] / kq)
    q = np.random.default_rng(3).uniform(-5.0, 5.0, N_POINTS) * np.maximum(q_c, 1e-5)
    expected = laws.damper_valve_pressure_drop(q, kq, v["p_c"], v["r_b"], v["r"])
    xs = [kind.sym(name) for name in ("q", "kq", "p_c", "r_b", "r")]
    fn = ca.Function("dp", xs, [laws.damper_valve_pressure_drop(*xs)]).map(N_POINTS)
    value = np.array(fn(q, kq, v["p_c"], v["r_b"], v["r"])).ravel()
    unit = 8.0 * EPS * (np.abs(v["r"] * q) + np.abs(expected - v["r"] * q))
    assert np.all(np.abs(value - expected) <= unit), np.max(np.abs(value - expected) / unit)
    # the blow-off is open at about 4/5 of the points (|q| > q_c)
    assert np.mean(np.abs(q) > q_c) > 0.5


def test_pressure_drop_at_zero_flow_is_zero_with_the_laminar_slope():
    """At ``q = 0`` the drop is 0 and its CasADi slope the laminar part ``r`` (the bleed's
    ``2 K |q|`` and the blow-off's share both vanish there), cracking or not."""
    q, kq, p_c, r_b, r = (ca.SX.sym(name) for name in ("q", "kq", "p_c", "r_b", "r"))
    dp = laws.damper_valve_pressure_drop(q, kq, p_c, r_b, r)
    fn = ca.Function("dp", [q, kq, p_c, r_b, r], [dp, ca.gradient(dp, q)])
    for cracking in (0.0, 1.5e6):
        value, slope = (float(a) for a in fn(0.0, 1e12, cracking, 2e9, 3e7))
        assert value == 0.0 and slope == 3e7
        assert laws.damper_valve_pressure_drop(0.0, 1e12, cracking, 2e9, 3e7) == 0.0


@pytest.mark.parametrize("kind", [ca.SX, ca.MX], ids=["SX", "MX"])
def test_equivalent_resistance_ad_gradient_equals_finite_differences(kind):
    """Central differences ``D(h)`` of the numpy function with relative steps ``h = 1e-4`` of
    each variable. Budget: the truncation ``c h^2`` estimated by Richardson from ``D(2h)``
    (``D(h) - R' ~ (D(2h) - D(h)) / 3``), doubled, plus numpy's rounding
    (:func:`rounding_unit`) divided by the step. Cracking pressures from 0.05 MPa: at 0 the
    crossover flow ``sqrt(p_c / K)`` has no finite derivative in ``p_c``."""
    v = valve_box(N_POINTS, seed=4, cracking_lower=5e4)
    _, gradient = casadi_resistance(kind, v)
    unit = rounding_unit(v)
    r_eq = resistance(**v)
    for row, name in enumerate(("q_rms", "d", "p_c")):

        def central(rel: float, name: str = name) -> tuple[np.ndarray, np.ndarray]:
            h = rel * v[name]
            up, down = dict(v), dict(v)
            up[name], down[name] = v[name] + h, v[name] - h
            return (resistance(**up) - resistance(**down)) / (2.0 * h), h

        fd, h = central(1e-4)
        fd_2h, _ = central(2e-4)
        budget = 2.0 * np.abs(fd_2h - fd) / 3.0 + unit / h
        error = np.abs(gradient[row] - fd)
        assert np.all(error <= budget), (name, np.max(error / budget))
        # discriminating: as a sensitivity (relative change of R_eq per relative change of the
        # variable, of order 1 where it moves R_eq), the budget is below 1e-6 everywhere
        sensitivity = budget * v[name] / np.abs(r_eq)
        assert np.all(sensitivity < 1e-6), (name, np.max(sensitivity))
        assert np.median(np.abs(gradient[row]) * v[name] / np.abs(r_eq)) > 1e-2


# --- the CasADi model with damper valves ------------------------------------------------------------
def valves_problem_with_given_flow(flow: float, every_quantity: bool = True) -> hisopt.Problem:
    """The shipped valves problem with every valve linearised at ``flow`` [m^3/s] (``[his]
    valve_flow_rms``), asking for every quantity (else for its own objectives)."""
    data = json.loads(json.dumps(hisopt.load_problem(VALVES_PROBLEM).spec.model_dump(by_alias=True)))
    data["his"]["valve_flow_rms"] = flow
    if every_quantity:
        data["objectives"] = ALL_QUANTITIES
    return problem_from_dict(data, "roll_plane_his_valves_given_flow")


@pytest.mark.parametrize("flow", [2e-6, 5e-5])
def test_casadi_model_with_given_valve_flow_agrees_with_numpy_within_their_rounding(flow):
    """As tests/test_core.py's engine matrix: the CasADi model and the numpy core at the
    evaluator's nodes, every quantity within the budget of the two solves; and the evaluator's
    own values within its pole-residue accuracy. At 2e-6 m^3/s every blow-off stays closed
    (``x_c = q_c / q_rms`` from 16 up); at 5e-5 the first design's (1.1 mm, 0.85 MPa) is
    open (``x_c`` about 0.6), the others closed (6 and 28)."""
    problem = valves_problem_with_given_flow(flow)
    x_all = np.vstack([random_designs(problem, 2, np.random.default_rng(11), corners=False), problem.baseline])
    # maxima: the evaluator's peak search stops 9.4e-5 below the top of the first design's
    # flat-topped tyre-load peak at 2e-6 m^3/s (at 4.5622 Hz; the top is at 4.5673 Hz, which one
    # of these nodes hits)
    assert_engines_agree(problem, x_all, max_rel=2e-4)


# --- refinement with solved valve flows --------------------------------------------------------------
@pytest.fixture(scope="module")
def valves_run(tmp_path_factory) -> tuple[hisopt.Problem, Path]:
    """A short run of the shipped valves problem (RMS flows solved with the response)."""
    problem = hisopt.load_problem(VALVES_PROBLEM)
    run_dir = tmp_path_factory.mktemp("valves") / "run"
    optimize(problem, out=run_dir, seed=3, pop_size=12, generations=3, algorithm="nsga2")
    return problem, run_dir


def test_slp_refines_the_valves_problem_on_its_solved_flows(valves_run):
    """SLP works on the evaluator, which solves the valves' RMS flows per design: every kept
    design, evaluated again (its flows solved anew, in another batch), shows the values written
    and weakly dominates its start (tests/test_refine.py's invariants)."""
    problem, run_dir = valves_run
    result = refine_run(run_dir, max_points=4)
    # another batch changes the poles at rounding (1e-14: a batch's mirror split is decided for
    # the batch); the valves' fixed point carries that through its secant steps, and a PSD peak
    # of damping ratio 0.05 amplifies a pole's move by 1 / zeta^2 = 400: 1e-10 (3e-11 measured)
    check_refined(problem, read_front(run_dir / "front.csv"), result, rtol=1e-10)
    assert result.points["accepted"].any()


def test_ipopt_refinement_refuses_solved_valve_flows_in_one_line(valves_run):
    """The CasADi model has no fixed point for the RMS flows: ``--method ipopt`` says so in one
    line naming the way out (``--method slp``), exit 2, and writes nothing."""
    problem, run_dir = valves_run
    with pytest.raises(RunError, match="--method slp"):
        CasadiModel(problem, compile=False)
    before = sorted(p.name for p in run_dir.iterdir())
    result = run_cli("refine", str(run_dir), "--method", "ipopt", "--max-points", "2")
    assert result.code == 2 and len(result.error_lines) == 1, result.stderr
    assert "damper valves" in result.stderr and "--method slp" in result.stderr and "valve_flow_rms" in result.stderr
    assert sorted(p.name for p in run_dir.iterdir()) == before


@pytest.mark.slow  # about 15 s: IPOPT on CasADi's virtual machine
def test_ipopt_refines_the_valves_problem_with_a_given_flow(monkeypatch):
    """With the flow given, the valves are resistances of the design variables like any other:
    IPOPT's refined designs, evaluated again, weakly dominate their starts."""
    monkeypatch.setenv("HISOPT_COMPILE", "0")  # CasADi's virtual machine: the same numbers, no C compiler run
    problem = valves_problem_with_given_flow(5e-5, every_quantity=False)
    run = optimize(problem, seed=3, pop_size=12, generations=3, algorithm="nsga2")
    result = refine_front(problem, run.front, max_points=3, method="ipopt")
    check_refined(problem, run.front, result)
    assert result.points["accepted"].any()
