"""Physical damper valves: the law, its statistical linearisation and the RMS-flow fixed point
(docs/model.md §3.3).

Independent references: the defining equations of the law, the closed form of the orifice's
expected slope, adaptive quadrature (scipy) of the blow-off's expected slope, a 1-DOF
mass-spring-valve system whose fixed point is solved by hand (orifice: a cube root) or by a
bracketing root finder (blow-off), and the evaluator's own measurement of the flows at the
solution.
"""

from __future__ import annotations

import math
import re
import runpy
import tomllib
from collections.abc import Callable

import numpy as np
import pytest
from scipy import integrate, optimize

import hisopt
from hisopt.evaluation.valve_flows import FLOW_TOLERANCE, log_fixed_point
from hisopt.evaluation.valve_states import valve_states
from hisopt.hydraulics import laws
from tests.conftest import ROOT

RHO = 872.0
VALVES = "tests/data/valves_one_road.toml"  # the valves problem on its city road alone


def _tangent(q: float, kq: float, pc: float, rb: float) -> float:
    """d(dp)/dq of the bleed || blow-off pair, by implicit differentiation of its defining
    equations (written here independently of laws.py)."""
    aq = abs(q)
    if kq * aq * aq <= pc:
        return 2.0 * kq * aq
    u = math.sqrt(laws.damper_valve_pressure_drop(aq, kq, pc, rb))  # |q| = u / sqrt(K) + (u^2 - pc) / rb
    return 2.0 * u / (1.0 / math.sqrt(kq) + 2.0 * u / rb)


@pytest.mark.parametrize("diameter", [1e-3, 3e-3, 6e-3])
@pytest.mark.parametrize("pc,rb", [(0.0, 1e9), (3e5, 1e8), (1.5e6, 2e9), (4e6, 1e10)])
def test_the_law_meets_its_defining_equations(diameter, pc, rb):
    kq = laws.orifice_coefficient(diameter, 0.7, RHO)
    area = math.pi * diameter**2 / 4
    assert kq == pytest.approx(RHO / (2 * 0.7**2 * area**2), rel=1e-15)
    q_c = math.sqrt(pc / kq)
    for q in np.r_[np.geomspace(1e-7, 1e-2, 41), q_c]:
        dp = laws.damper_valve_pressure_drop(q, kq, pc, rb)
        assert laws.damper_valve_pressure_drop(-q, kq, pc, rb) == -dp  # odd
        if q <= q_c:  # the bleed alone
            assert dp == pytest.approx(kq * q * q, rel=1e-12)
        else:  # bleed and blow-off share the drop; the drop is below the bleed's alone
            assert math.sqrt(dp / kq) + (dp - pc) / rb == pytest.approx(q, rel=1e-12)
            assert dp < kq * q * q
    laminar = laws.damper_valve_pressure_drop(2e-4, kq, pc, rb, r=3e8) - laws.damper_valve_pressure_drop(2e-4, kq, pc, rb)
    assert laminar == pytest.approx(3e8 * 2e-4, rel=1e-12)


def test_orifice_equivalent_resistance_is_the_closed_form():
    for kq in (1e12, 1.8e13, 3e14):
        for s in np.geomspace(1e-6, 1e-2, 9):
            closed = math.sqrt(8.0 / math.pi) * kq * s  # E[2 K |q|] for q ~ N(0, s^2)
            assert laws.damper_valve_equivalent_resistance(s, kq) == pytest.approx(closed, rel=1e-12)
            assert laws.orifice_equivalent_resistance(0.0, kq, s) == pytest.approx(closed, rel=1e-12)
            # a blow-off that never opens within 40 standard deviations: the bleed's share alone
            far = kq * (40.0 * s) ** 2
            assert laws.damper_valve_equivalent_resistance(s, kq, far, 1e9) == pytest.approx(closed, rel=1e-12)


@pytest.mark.parametrize("diameter", [1e-3, 2.5e-3, 6e-3])
@pytest.mark.parametrize("pc,rb", [(0.0, 1e8), (5e5, 1e9), (1.5e6, 2e9), (4e6, 1e10)])
def test_blowoff_equivalent_resistance_against_quadrature(diameter, pc, rb):
    """Against adaptive quadrature of E[d(dp)/dq] (the tangent, not the E[q dp] form the
    code sums). Budget: the 48-node Gauss-Legendre rule's truncation, below 1e-8 over this
    grid (scipy's own error is below 1e-12 here), so 2e-8."""
    kq = laws.orifice_coefficient(diameter, 0.7, RHO)
    q_c = math.sqrt(pc / kq)
    for s in np.geomspace(1e-6, 1e-2, 7):
        edges = sorted({0.0, min(q_c, 40 * s), 40 * s})
        slope = lambda q, s=s: _tangent(q, kq, pc, rb) * math.exp(-0.5 * (q / s) ** 2) / (s * math.sqrt(2 * math.pi))  # noqa: E731
        expected = 2 * sum(integrate.quad(slope, a, b, epsabs=0, epsrel=1e-13, limit=200)[0] for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a)
        assert laws.damper_valve_equivalent_resistance(s, kq, pc, rb) == pytest.approx(expected, rel=2e-8)


def _one_dof_flow(r_eq: np.ndarray, area: float, mass: float, s0: float) -> np.ndarray:
    """[m^3/s] RMS flow of a mass on a spring with a strut of piston ``area`` damped by a
    valve of resistance ``r_eq``, driven by a white force of two-sided PSD ``s0``:
    ``sigma_v^2 = pi s0 / (m c)`` with ``c = A^2 R`` (the spring drops out)."""
    return area * np.sqrt(math.pi * s0 / (mass * area * area * r_eq))


@pytest.mark.parametrize("pc", [None, 2e5, 1e6])
def test_fixed_point_on_a_one_dof_system(pc):
    kq, rb, area, mass, s0 = laws.orifice_coefficient(3e-3, 0.7, RHO), 2e9, 1e-3, 300.0, 5.0

    def response(rows, y):
        r = laws.damper_valve_equivalent_resistance(np.exp(y), kq, pc, None if pc is None else rb)
        return np.log(_one_dof_flow(r, area, mass, s0))

    y, ok, _, _ = log_fixed_point(response, np.full((1, 1), math.log(1e-4)), np.full((1, 1), -0.25))
    assert ok.all()
    if pc is None:  # by hand: s^2 = pi s0 / (m sqrt(8/pi) K s), a cube root
        expected = (math.pi * s0 / (mass * math.sqrt(8 / math.pi) * kq)) ** (1 / 3)
    else:
        expected = optimize.brentq(
            lambda s: s - _one_dof_flow(laws.damper_valve_equivalent_resistance(s, kq, pc, rb), area, mass, s0), 1e-7, 1e-1, xtol=1e-16, rtol=1e-14
        )
    assert math.exp(y[0, 0]) == pytest.approx(expected, rel=FLOW_TOLERANCE)


@pytest.fixture(scope="module")
def valves():
    return hisopt.load_problem(VALVES)


def test_batch_equals_design_by_design(valves):
    rng = np.random.default_rng(7)
    x = valves.lower + rng.random((5, len(valves.lower))) * (valves.upper - valves.lower)
    batch = valves.evaluate(x)
    for i in range(len(x)):
        one = valves.evaluate(x[i : i + 1])
        for name in valves.objective_names:
            # the same arithmetic per design (the start depends on the design alone) but for a
            # batch's mirror split, decided for the batch: the poles at rounding (1e-14), which the
            # fixed point carries through its secant steps and a PSD peak of damping ratio 0.05
            # amplifies by 1 / zeta^2 = 400: 1e-10 (1.1e-12 measured under another BLAS)
            assert one[name].iloc[0] == pytest.approx(batch[name].iloc[i], rel=1e-10)


def test_the_solved_flows_are_the_flows_the_road_drives(valves):
    """At the fixed point, each valve's equivalent resistance is the law's at the RMS flow the
    evaluator measures through it (measured afresh, at the final model)."""
    rng = np.random.default_rng(3)
    x = valves.lower + rng.random((4, len(valves.lower))) * (valves.upper - valves.lower)
    states = valve_states(valves, x)
    assert states.converged.all()
    his = valves.spec.his
    kq = laws.orifice_coefficient(x[:, 3], his.discharge_coefficient, his.fluid.rho)
    for j in range(states.flow_rms.shape[1]):
        r = laws.damper_valve_equivalent_resistance(states.flow_rms[:, j], kq, x[:, 4], his.blowoff_resistance)
        # budget: the fixed point's tolerance on the flow times the resistance's slope in the flow (<= 1)
        np.testing.assert_allclose(r, states.resistance[:, j], rtol=3 * FLOW_TOLERANCE)


def test_a_problem_without_damper_valves_takes_no_new_path():
    paper = hisopt.load_problem("problems/roll_plane_his.toml")
    evaluator = paper.evaluator()
    assert not paper.network().damper_valves()
    assert evaluator._flow_evaluator is None  # noqa: SLF001
    assert "valve_flow_0" not in evaluator.outputs


def test_the_papers_rv_moves_nothing_and_real_valves_move_everything():
    """README's figures ("Real damper valves"), from examples/rv_range.py: at the paper's
    baseline, Rv over its box moves no indicator by 1 %; over real valves' 1e8-1e10 it moves
    comfort, stroke and tyre load by multiples (README quotes them rounded to its digits)."""
    example = runpy.run_path(str(ROOT / "examples" / "rv_range.py"))
    moves = example["spreads"]()
    assert max(moves["paper box 0-1.6e6"].values()) == pytest.approx(0.0077, abs=5e-5)
    real = moves["real valves 1e8-1e10"]
    assert real["sigma_aw"] == pytest.approx(3.62, abs=5e-3)
    assert real["max_stroke_psd"] == pytest.approx(4.49, abs=5e-3)
    assert real["max_tire_load_psd"] == pytest.approx(48.38, abs=5e-3)


CHAMBERS = (("A", "2b", "4b", '1t = "A", 2b = "A.2b", 3t = "A", 4b = "A.4b"'), ("B", "1b", "3b", '1b = "B.1b", 2t = "B", 3b = "B.3b", 4t = "B"'))


def _custom(valve: Callable[[str, str], str], extra: Callable[[str], str] | None = None) -> hisopt.Problem:
    """The one-road valves problem with its layout written out: ``valve(a, b)`` the element
    table of a bottom chamber's valve from node ``a`` to node ``b``; ``extra(c)`` elements of
    circuit ``c`` listed first (on its node ``"<c>.x"``)."""
    text = (ROOT / VALVES).read_text(encoding="utf-8")
    text = re.sub(r"(?m)^(orifice_diameter|discharge_coefficient|cracking_pressure|blowoff_resistance) = .*\n", "", text)
    text = re.sub(r"(?m)^(orifice_diameter|cracking_pressure) = \{ lower.*\n", "", text)
    circuits = ""
    for c, f, r, chambers in CHAMBERS:
        nodes = ", ".join(f'"{n}"' for n in [c, f"{c}.{f}", f"{c}.{r}"] + ([f"{c}.x"] if extra else []))
        elements = [*([extra(c)] if extra else []), f'{{ type = "accumulator", node = "{c}" }}', valve(f"{c}.{f}", c), valve(f"{c}.{r}", c)]
        circuits += f'[[his.circuits]]\nname = "{c}"\nnodes = [{nodes}]\nchambers = {{ {chambers} }}\nelements = [\n' + ",\n".join(elements) + "\n]\n"
    text = text.replace("[his.charge]", 'layout = "custom"\n\n' + circuits + "\n[his.charge]", 1)
    return hisopt.problem_from_dict(tomllib.loads(text), "custom valves")


def test_an_orifice_without_flow_rms_is_solved_as_a_bleed_only_damper_valve():
    """An ``orifice`` element left without ``flow_rms`` is linearised at the RMS flow the road
    drives through it, like a damper valve of the same K without a blow-off (the same law, so
    the same objectives, to the fixed point's tolerance)."""
    kq = laws.orifice_coefficient(3e-3, 0.7, hisopt.load_problem(VALVES).spec.his.fluid.rho)  # the oil's density
    orifice = _custom(lambda a, b: f'{{ type = "orifice", from = "{a}", to = "{b}", kq = {kq!r} }}')
    valve = _custom(lambda a, b: f'{{ type = "damper_valve", from = "{a}", to = "{b}", orifice_diameter = "3 mm" }}')
    assert len(orifice.network().solved_valves()) == 4
    x = orifice.design_matrix([{}, {"p0": 3e6, "dA": 5e-4, "lam": 0.3}])
    got, want = orifice.evaluate(x, log=False), valve.evaluate(x, log=False)
    for name in orifice.objective_names:
        np.testing.assert_allclose(got[name].to_numpy(), want[name].to_numpy(), rtol=2 * FLOW_TOLERANCE)


def test_a_shorted_valve_before_the_damper_valves_leaves_their_flows_theirs():
    """A linear valve of R = 0 between two accumulators is contracted away, which shifts the
    later elements' indices: each damper valve still reads its own solved flow (its
    resistance is the law's at the flow measured through it)."""
    problem = _custom(
        lambda a, b: f'{{ type = "damper_valve", from = "{a}", to = "{b}", orifice_diameter = "{3 if a[-2] in "12" else 4} mm" }}',
        lambda c: f'{{ type = "accumulator", node = "{c}.x" }},\n{{ type = "valve", from = "{c}.x", to = "{c}", resistance = 0.0 }}',
    )
    ((_, model),) = problem.model(problem.baseline[None, :]).groups()
    assert model.his is not None and model.his.origin is not None  # contracted
    states = valve_states(problem, problem.baseline[None, :])
    his = problem.spec.his
    for j, diameter in enumerate((3e-3, 4e-3, 3e-3, 4e-3)):
        kq = laws.orifice_coefficient(diameter, 0.7, his.fluid.rho)
        r = laws.damper_valve_equivalent_resistance(states.flow_rms[0, j], kq)
        assert states.resistance[0, j] == pytest.approx(float(r), rel=3 * FLOW_TOLERANCE)
