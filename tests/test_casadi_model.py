"""The CasADi model against the numpy model and evaluator (both compiled from the one core).

Values: the CasADi graph and the numpy evaluator's machinery (``Evaluator.spectra`` of a
direct solve, quadrature sums, maxima over nodes) on the same frequency set, which is the
evaluator's own pole-aware node set at the design, so integrals equal the evaluator's
objectives. Gradients: CasADi's AD Jacobian against central differences of that numpy
computation (fixed nodes), within 1e-4 relative, on random designs.
"""

from __future__ import annotations

import numpy as np
import pytest

import hisopt
from hisopt.evaluation.channels import DirectOutputs
from hisopt.evaluation.symmetry import split, state_mirror
from hisopt.metrics import COMFORT_OUTPUTS
from hisopt.optim.gradient.casadi_model import CasadiModel, FrequencySet, SpectraCallback, compiled
from hisopt.standards import iso_2631_1_1997 as iso2631
from tests.conftest import ROOT, random_designs
from tests.error_budget import EPS, SAFETY, assert_discriminating, network_condition, pole_budget, solve_budget

BOTH = ("componentwise", "normwise")
"""The network solves' backward errors: numpy's, then CasADi's (tests/error_budget.py). At the
box's corners with ``Rv = 0`` the valve shorts two chambers and the port impedance is as
sensitive as 1e-6 to a normwise error in the network matrix: the budget there is that wide
(CasADi's solve is in fact far better), every other design's far below 1e-6."""


def assert_discriminating_unless_shorted(problem: hisopt.Problem, x: np.ndarray, budget: np.ndarray) -> None:
    """:func:`tests.error_budget.assert_discriminating` on the designs without a shorted valve."""
    open_valve = x[:, problem.variable_names.index("Rv")] > 0
    assert open_valve.sum() >= 5
    assert_discriminating(np.asarray(budget)[open_valve])


HANDLING = ROOT / "problems" / "roll_plane_his_handling.toml"


@pytest.fixture(scope="module")
def handling() -> hisopt.Problem:
    # constraints on roll_gradient (static), rms_tire_load and rms_stroke (integrals)
    return hisopt.load_problem(HANDLING)


@pytest.fixture(scope="module", params=["default", "handling"])
def setup(request, problem, handling):
    p = problem if request.param == "default" else handling
    return p, CasadiModel(p, compile=False)


def evaluator_nodes(problem: hisopt.Problem, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The evaluator's nodes and weights at design ``x`` (duplicates merged)."""
    ev = problem.evaluator()
    model = problem.model(x[None])
    f, w = ev.nodes(np.linalg.eigvals(model.state_space().a), model)
    f, inverse = np.unique(f[0], return_inverse=True)
    return f, np.bincount(inverse, weights=w[0], minlength=f.size)


def numpy_quantities(problem: hisopt.Problem, x: np.ndarray, f: np.ndarray, w: np.ndarray, at: dict[str, int] | None = None) -> dict[str, float]:
    """The evaluator's quantities with nodes ``f``, weights ``w`` fixed; maxima over the nodes.

    ``at`` fixes the node of a maximum (its derivative is that node's, where the maximum is
    unique), so central differences do not straddle a change of the maximising node.
    """
    from hisopt.evaluation.evaluate import roll_gradient

    ev = problem.evaluator()
    model = problem.model(x[None])
    psd = ev.spectra(f[None], DirectOutputs(model, ev.outputs)(2 * np.pi * f[None]))[0]
    comfort = problem.spec.comfort
    out = {}
    for m in ev.metrics:
        if m.kind == "comfort":
            total = 0.0
            for axis, name in COMFORT_OUTPUTS.items():
                gain = iso2631.weighting_gain_squared(f, ev.outputs[name].weighting)
                total += getattr(comfort, f"k_{axis}") ** 2 * np.sum(w * gain * psd[:, ev.output_index[name]])
            out[m.name] = np.sqrt(total)
        elif m.kind == "rms":
            out[m.name] = np.sqrt(np.sum(w * psd[:, ev.output_index[m.output]]))
        elif m.kind == "max":
            y = psd[:, ev.output_index[m.output]]
            out[m.name] = y.max() if at is None else y[at[m.name]]
            out[f"{m.name}_node"] = int(np.argmax(y))
        else:
            out[m.name] = roll_gradient(model, problem.spec.handling.gravity_moment)[0]
    return out


def test_his_matrices_equal_the_circuit_model(problem, rng):
    # the CasADi D(j omega) against the numpy nodal-analysis stroke impedance D(s)
    import casadi as ca

    model = CasadiModel(problem, compile=False)
    x_sym, w_sym = ca.SX.sym("x", model.n_var), ca.SX.sym("w")
    d = model.stroke_stiffness(x_sym, w_sym)
    fn = ca.Function("d", [x_sym, w_sym], [d.re, d.im])
    s = 2j * np.pi * np.array([0.7, 3.0, 25.0])
    x_all = random_designs(problem, 6, rng)
    budgets = []
    for x in x_all:
        m = problem.model(x[None])
        ref = m.his.stroke_impedance(s)[0]
        mine = np.array([np.array(fn(x, si.imag)[0]) + 1j * np.array(fn(x, si.imag)[1]) for si in s])
        # both network solves' rounding, relative to D's largest entry (tests/error_budget.py)
        budgets.append(SAFETY * EPS * sum(network_condition(m, s, kind) for kind in BOTH).max())
        np.testing.assert_allclose(mine, ref, rtol=0, atol=budgets[-1] * np.abs(ref).max())
    assert_discriminating_unless_shorted(problem, x_all, budgets)


def test_spectra_equal_the_numpy_model(setup, rng):
    problem, model = setup
    ev = problem.evaluator()
    x_all = random_designs(problem, 5, rng)
    budgets = []
    for x in x_all:
        f, w = evaluator_nodes(problem, x)
        fs = model.frequency_set(f, w)
        mine = np.array(model.spectra(x, fs.params)).T
        ref = ev.spectra(f[None], DirectOutputs(problem.model(x[None]), ev.outputs)(2 * np.pi * f[None]))[0]
        budgets.append(solve_budget(problem.model(x[None]), f, backward=BOTH)[0])  # tests/error_budget.py
        np.testing.assert_allclose(mine, ref, rtol=budgets[-1], atol=0)
    assert_discriminating_unless_shorted(problem, x_all, budgets)


def test_quantities_equal_the_evaluator_on_its_nodes(setup, rng):
    problem, model = setup
    x_all = random_designs(problem, 5, rng)
    full = problem.evaluator()(x_all)
    ss = problem.model(x_all).state_space()
    halves = [h.a for h in split(ss, state_mirror(problem.model(x_all), ss)).values()]
    poles = pole_budget(halves, problem.spec.band.f_min_hz, problem.spec.band.f_max_hz)  # the evaluator's FRFs
    budgets = []
    for k, x in enumerate(x_all):
        f, w = evaluator_nodes(problem, x)
        q = np.array(model.function(model.frequency_set(f, w))(x)[0]).ravel()
        ref = numpy_quantities(problem, x, f, w)
        budget = solve_budget(problem.model(x[None]), f, backward=BOTH)[0]  # tests/error_budget.py
        budgets.append(budget + poles[k])
        for i, name in enumerate(model.names):
            assert q[i] == pytest.approx(ref[name], rel=budget), name
            if name in ("sigma_aw", "rms_roll", "rms_stroke", "rms_tire_load", "roll_gradient"):
                # same nodes, same weights: the evaluator's own value, from poles and residues
                assert q[i] == pytest.approx(full[name][k], rel=budget + poles[k]), name
            else:
                # a maximum over nodes lies below the evaluator's continuous maximum
                assert q[i] <= full[name][k] * (1 + budget + poles[k])
    assert_discriminating_unless_shorted(problem, x_all, budgets)


def test_gradients_match_central_differences(setup, rng):
    problem, model = setup
    span = problem.upper - problem.lower
    for x in random_designs(problem, 4, rng, corners=False):
        f, w = evaluator_nodes(problem, x)
        q, jac = (np.array(v) for v in model.function(model.frequency_set(f, w))(x))
        at = {k.removesuffix("_node"): v for k, v in numpy_quantities(problem, x, f, w).items() if k.endswith("_node")}
        for j in range(model.n_var):
            h = 1e-5 * span[j]
            up = numpy_quantities(problem, x + h * np.eye(model.n_var)[j], f, w, at)
            down = numpy_quantities(problem, x - h * np.eye(model.n_var)[j], f, w, at)
            for i, name in enumerate(model.names):
                fd = (up[name] - down[name]) / (2 * h)
                scale = max(abs(jac[i, j]), abs(fd), 1e-8 * abs(q[i, 0]) / span[j])  # per unit of the variable
                assert abs(jac[i, j] - fd) <= 1e-4 * scale, (name, problem.variable_names[j], jac[i, j], fd)


def test_callback_jacobian_equals_the_graph_jacobian(problem, rng):
    import casadi as ca

    model = CasadiModel(problem, compile=False)
    x = random_designs(problem, 1, rng, corners=False)[0]
    f, w = evaluator_nodes(problem, x)
    fs = model.frequency_set(f, w)
    lower, span = problem.lower, problem.upper - problem.lower
    callback = SpectraCallback(model, fs, lower, span)
    u = ca.MX.sym("u", model.n_var)
    via_callback = ca.Function("a", [u], [ca.jacobian(ca.vec(callback(u)), u)])
    graph = model.spectra(ca.DM(lower) + ca.DM(span) * u, fs.params)
    via_graph = ca.Function("b", [u], [ca.jacobian(ca.vec(graph), u)])
    u0 = (x - lower) / span
    a, b = np.array(via_callback(u0)), np.array(via_graph(u0))
    # two AD orders (forward inside each node; through K_his, C_his in the graph): equal to
    # rounding relative to each derivative's scale
    assert np.all(np.abs(a - b) <= 1e-9 * (np.abs(b) + np.abs(b).max(axis=0)))


def test_callback_values_equal_the_graph_and_compiled_buffers_the_virtual_machine(problem, rng, tmp_path, monkeypatch):
    # the callback reads CasADi's column-major buffers in place: a layout slip would permute
    # outputs, nodes or variables, which these comparisons see at once
    import casadi as ca

    monkeypatch.setenv("HISOPT_CACHE_DIR", str(tmp_path))
    lower, span = problem.lower, problem.upper - problem.lower
    plain, fast = CasadiModel(problem, compile=False), CasadiModel(problem, compile=True)
    for x in random_designs(problem, 3, rng, corners=False):
        fs = plain.frequency_set(*evaluator_nodes(problem, x))
        u0 = (x - lower) / span
        graph = np.array(plain.spectra(ca.DM(x), fs.params))
        vm, compiled_cb = SpectraCallback(plain, fs, lower, span), SpectraCallback(fast, fs, lower, span)
        value, jac = vm.evaluate(u0, jacobian=True)
        # the same node function mapped the same way: the same operations, bit for bit
        np.testing.assert_array_equal(vm.evaluate(u0 + 0.0, jacobian=False)[0], graph)
        np.testing.assert_array_equal(value, graph)
        u = ca.MX.sym("u", plain.n_var)
        psd = plain.spectra(ca.DM(lower) + ca.DM(span) * u, fs.params)
        graph_jac = np.array(ca.Function("j", [u], [ca.jacobian(ca.vec(psd), u)])(u0))
        # two AD orders (forward inside each node; through the graph's scaling): equal to rounding
        assert np.all(np.abs(jac - graph_jac) <= 1e-9 * (np.abs(graph_jac) + np.abs(graph_jac).max(axis=0)))
        # compiled C: the same operations in the same order (no fast-math), rounding aside
        c_value, c_jac = compiled_cb.evaluate(u0, jacobian=True)
        np.testing.assert_allclose(c_value, value, rtol=1e-13, atol=0)
        np.testing.assert_allclose(c_jac, jac, rtol=1e-12, atol=1e-12 * np.abs(jac).max())


def test_compiled_function_gives_the_same_numbers(problem, tmp_path, monkeypatch):
    monkeypatch.setenv("HISOPT_CACHE_DIR", str(tmp_path))
    model = CasadiModel(problem, compile=False)
    fn = model.node_function(jacobian=True)
    fast = compiled(fn)
    fs: FrequencySet = model.frequency_set(np.array([0.5, 1.3, 2.7, 11.0, 80.0]))
    x = problem.baseline
    for k in range(fs.size):
        for a, b in zip(fn(x, fs.params[:, k]), fast(x, fs.params[:, k]), strict=True):
            np.testing.assert_allclose(np.array(b), np.array(a), rtol=1e-13, atol=0)


@pytest.mark.parametrize("gravity", [False, True])
def test_roll_gradient_equals_numpy_in_both_conventions(handling, rng, gravity):
    # issue 40: [handling] gravity_moment (the body's weight moment m_s g h_0s phi) read alike by
    # the CasADi model and the numpy evaluator; one static 7 x 7 solve each, by CasADi and by
    # LAPACK: the rounding of a well-conditioned solve
    import casadi as ca

    from hisopt.evaluation.evaluate import roll_gradient
    from hisopt.problem import problem_from_dict

    data = handling.spec.model_dump(by_alias=True)
    data["handling"]["gravity_moment"] = gravity
    p = problem_from_dict(data, f"gravity {gravity}")
    sym = ca.MX.sym("x", len(p.variable_names))
    fn = ca.Function("rg", [sym], [CasadiModel(p, compile=False).roll_gradient(sym)])
    x_all = random_designs(p, 4, rng)
    numpy_values = p.evaluator()(x_all)["roll_gradient"]
    other = roll_gradient(p.model(x_all), not gravity)
    for k, x in enumerate(x_all):
        assert float(fn(x)) == pytest.approx(numpy_values[k], rel=1e-12)
        # the other convention: phi_g = phi / (1 - phi) [rad/g] (Sherman-Morrison on the roll entry)
        with_g, without = (numpy_values[k], other[k]) if gravity else (other[k], numpy_values[k])
        assert with_g == pytest.approx(without / (1 - without), rel=1e-12) and with_g > without * 1.005
