"""The physics core (docs/model.md §11): every engine, built from the one core, agrees.

On a matrix of problems (no pipes, lumped pipes, distributed pipes, chamber compliance, band
and filter comfort, and every catalogue layout of docs/model.md §12.3, with and without pipes):

- numpy evaluator against the CasADi model on every objective (same nodes), within the rounding
  budget of their solves (tests/error_budget.py);
- state space against the direct solve of the network, within the rounding budget of the
  realisation and both solves;
- time-domain sine steady state against the FRF within 1e-6;
- the reference evaluator honours the comfort method;
- zero-resistance valves between oil volumes (chamber compliance with ``Rv = 0``) work, in
  any batch, and a design the realisation cannot take gives NaN, never a stopped batch.
Plus: no import cycles inside ``hisopt``.
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import hisopt
from hisopt.evaluation.channels import DirectOutputs
from hisopt.evaluation.evaluate import Evaluator, poles
from hisopt.evaluation.peaks import refine_maximum
from hisopt.evaluation.psd import comfort_gain_squared, reduce_metrics
from hisopt.evaluation.reference import grid_quantities
from hisopt.metrics import METRICS
from hisopt.optim.gradient.casadi_model import CasadiModel
from hisopt.problem import problem_from_dict
from hisopt.simulation.timedomain import simulate
from tests.conftest import DEFAULT_PROBLEM, ROOT, random_designs
from tests.error_budget import assert_discriminating, assert_frf_within, assert_within, solve_budget, state_space_budget, state_space_frf

PIPES = {"diameter": 0.012, "length_front": 1.5, "length_rear": 3.0}
TELLUS_0_100 = {"temperature_1": 273.15, "viscosity_1": 338e-6, "temperature_2": 373.15, "viscosity_2": 5.4e-6}
"""The default oil's data sheet at 0 and 100 C (docs/model.md §16): 5 C is then inside its data."""
VARIANTS = {
    "no_pipes": {},
    "band_comfort": {"comfort": {"method": "band"}},
    "lumped_pipes": {"his": {"pipes": PIPES}},
    "distributed_pipes": {"his": {"pipes": PIPES, "pipe_model": "distributed"}},
    "chamber": {"his": {"chamber_volume": 2e-4}},
    # every catalogue layout (docs/model.md §12.3), with its extra parameters as design variables
    "roll_plane_accumulator_valves": {"his": {"layout": "roll_plane_accumulator_valves"}, "variables": {"Rv_acc": {"lower": 1e6, "upper": 1e9}}},
    "roll_plane_twin_accumulator": {"his": {"layout": "roll_plane_twin_accumulator"},
                                    "variables": {"Rv_link": {"lower": 1e6, "upper": 5e9}, "V0_rear": {"lower": 2e-4, "upper": 1e-3}}},
    "pitch_plane": {"his": {"layout": "pitch_plane"}},
    "axle_roll": {"his": {"layout": "axle_roll"}},
    "side_front_rear": {"his": {"layout": "side_front_rear"}, "variables": {"Rv_link": {"lower": 1e6, "upper": 5e9}}},
    "pitch_plane_pipes_chamber": {"his": {"layout": "pitch_plane", "pipes": PIPES, "chamber_volume": 2e-4}},
    "twin_distributed_pipes": {"his": {"layout": "roll_plane_twin_accumulator", "pipes": PIPES, "pipe_model": "distributed"}},
    # a charged HIS (docs/model.md §16) at three temperatures: oil in the accumulators, the gas
    # and the oil's viscosity and volume at the temperature, laden in the cold
    "charged_cold": {"his": {"charge": {"gas_fraction": 0.6}, "chamber_volume": 2e-4, "oil": TELLUS_0_100},
                     "temperature": 278.15, "payload": {"mass": 300.0, "x": -0.4, "y": 0.2}},
    "charged_reference": {"his": {"charge": {"gas_fraction": 0.75}, "pipes": PIPES, "valve_laminar_fraction": 0.5}},
    "charged_hot": {"his": {"charge": {"gas_fraction": 0.7}, "chamber_volume": 2e-4, "valve_laminar_fraction": 0.3},
                    "temperature": 343.15},
}  # fmt: skip
LAYOUT_VARIANTS = [n for n, v in VARIANTS.items() if "layout" in v.get("his", {}) and "pipe_model" not in v["his"]]
ALL_QUANTITIES = ["sigma_aw", "max_roll_psd", "max_stroke_psd", "max_tire_load_psd", "rms_roll", "rms_stroke", "rms_tire_load", "roll_gradient"]


def variant(name: str) -> hisopt.Problem:
    data = json.loads(json.dumps(hisopt.load_problem(DEFAULT_PROBLEM).spec.model_dump(by_alias=True)))
    for table, values in VARIANTS[name].items():
        if isinstance(data.get(table), dict):
            data[table].update(values)
        else:  # a top-level value, or a table the default leaves out
            data[table] = values
    data["objectives"] = ALL_QUANTITIES
    return problem_from_dict(data, name)


@pytest.fixture(scope="module", params=list(VARIANTS))
def problem_variant(request) -> hisopt.Problem:
    return variant(request.param)


def designs(problem: hisopt.Problem, n: int = 3) -> np.ndarray:
    x = random_designs(problem, n, np.random.default_rng(11), corners=False)
    return np.vstack([x, problem.baseline])


def evaluator_nodes(problem: hisopt.Problem, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict[str, float]]:
    """The evaluator's nodes and weights at ``x``, plus the frequency of each continuous maximum."""
    ev = problem.evaluator()
    model = problem.model(x[None])
    frf = DirectOutputs(model, ev.outputs)
    f, w = ev.nodes(poles(model), model)
    f_search, _ = ev.nodes(poles(model))  # maxima are sought from the panels' nodes and peak samples
    psd = ev.spectra(f_search, frf(2 * np.pi * f_search))
    peaks = {}
    for name, j in ev.output_index.items():
        at = lambda pts, j=j: ev.spectra(pts, frf(2 * np.pi * pts, j))[..., 0]  # noqa: E731
        peaks[name] = float(refine_maximum(at, f_search, psd[..., j], ev.peak_steps)[0][0])  # as the evaluator searches
    f, inverse = np.unique(f[0], return_inverse=True)
    return f, np.bincount(inverse, weights=w[0], minlength=f.size), peaks


def numpy_on_nodes(problem: hisopt.Problem, x: np.ndarray, f: np.ndarray, w: np.ndarray) -> dict[str, float]:
    """Every quantity with the numpy core on fixed nodes (maxima over the nodes)."""
    ev = problem.evaluator()
    model = problem.model(x[None])
    psd = ev.spectra(f[None], DirectOutputs(model, ev.outputs)(2 * np.pi * f[None]))[0]
    spec = problem.spec

    def integral(output: str, weighting: str | None) -> float:
        gain = 1.0 if weighting is None else comfort_gain_squared(f, weighting, spec.comfort, ev.f_lo, ev.f_hi)
        return float(np.sum(w * gain * psd[:, ev.output_index[output]]))

    values = reduce_metrics(
        ev.metrics,
        spec.comfort,
        lambda n: ev.outputs[n].weighting,
        integral,
        lambda output: float(psd[:, ev.output_index[output]].max()),
        lambda name: float(hisopt.evaluation.evaluate.static_quantity(model, name, spec.handling.gravity_moment)[0]),
    )
    return {k: float(np.squeeze(v)) for k, v in values.items()}


def assert_engines_agree(problem: hisopt.Problem, x_all: np.ndarray, max_rel: float) -> None:
    """The CasADi model and the numpy core at the evaluator's nodes of each design of
    ``x_all``: every quantity within the budget of the two solves (tests/error_budget.py: the
    equilibrated network's and the dynamic stiffness's condition numbers); and the evaluator's
    own values: integrals on its nodes within 1e-6 (its frequency responses come from poles and
    residues, good to ~1e-7 with stiff chambers), maxima within ``max_rel`` (its peak search
    takes a fixed number of steps, peak_steps, not a tolerance, so where it stops below the
    nodes' largest value depends on the last bits of the responses)."""
    model = CasadiModel(problem, compile=False)
    evaluated = problem.evaluator()(x_all)
    for k, x in enumerate(x_all):
        f, w, peaks = evaluator_nodes(problem, x)
        f_all = np.unique(np.r_[f, list(peaks.values())])
        w_all = np.zeros(f_all.size)
        w_all[np.searchsorted(f_all, f)] = w
        q = np.array(model.function(model.frequency_set(f_all, w_all))(x)[0]).ravel()
        ref = numpy_on_nodes(problem, x, f_all, w_all)
        budget = solve_budget(problem.model(x[None]), f_all, backward=("componentwise", "normwise"))  # numpy, CasADi
        assert_discriminating(budget)
        for i, name in enumerate(model.names):
            assert_within(q[i : i + 1], np.array([ref[name]]), budget, name)
            rel = max_rel if METRICS[name].kind == "max" else 1e-6
            assert q[i] == pytest.approx(evaluated[name][k], rel=rel), (name, q[i], evaluated[name][k])


@pytest.mark.slow
def test_numpy_and_casadi_engines_agree_within_their_rounding(problem_variant):
    """Both engines solve the network and the car at the same nodes (:func:`assert_engines_agree`),
    which a 1e-6 error would exceed; the evaluator's maxima within its stated accuracy, 1e-3
    (docs/model.md §10.7: 2.9e-5 measured under OpenBLAS Prescott on the pitch-plane chamber variant)."""
    assert_engines_agree(problem_variant, designs(problem_variant), max_rel=1e-3)


@pytest.mark.parametrize("name", [n for n, v in VARIANTS.items() if v.get("his", {}).get("pipe_model") != "distributed"])
def test_state_space_equals_direct_solve_within_their_rounding(name):
    """The realised state space's FRF against the network's direct solve, within the budget of
    the realisation and both solves (tests/error_budget.py)."""
    problem = variant(name)
    x = designs(problem)
    x[0, problem.variable_names.index("Rv")] = 0.0  # a short (between oil volumes with chambers)
    model = problem.model(x)
    f = np.geomspace(0.3, 150.0, 90)
    direct = model.frequency_response(2j * np.pi * f)
    for rows, group in model.groups():
        budget = solve_budget(group, f, power=1) + state_space_budget(group, f)
        assert_discriminating(budget)
        assert_frf_within(state_space_frf(group.state_space(), f), direct[rows], budget, name)


def steady_amplitude(t: np.ndarray, y: np.ndarray, w: float, poles: np.ndarray) -> complex:
    """Sine amplitude ``c_sin + j c_cos`` of ``y(t)``, the free decay of every pole fitted out."""
    columns = [np.sin(w * t), np.cos(w * t)]
    t0 = t - t[0]
    for p in poles:
        if p.imag < 0 or -p.real * (t[-1] - t[0]) > 40:  # one of a pair, or decayed before the window
            continue
        decay = np.exp(p.real * t0)
        columns += [decay * np.cos(p.imag * t0), decay * np.sin(p.imag * t0)] if p.imag > 0 else [decay]
    coef, *_ = np.linalg.lstsq(np.stack(columns, axis=1), y, rcond=None)
    return coef[0] + 1j * coef[1]


@pytest.mark.slow
@pytest.mark.parametrize("name", ["no_pipes", "lumped_pipes", "chamber", "charged_cold", "charged_hot", *LAYOUT_VARIANTS])
def test_time_domain_sine_steady_state_equals_frf_within_1e6(name):
    problem = variant(name)
    model = problem.model()
    f_hz, amp = 2.3, 0.01
    t = np.arange(0.0, 6.0, 1.0 / 400.0)
    w = 2 * np.pi * f_hz
    road = np.zeros((t.size, 4))
    road[:, 0] = amp * np.sin(w * t)
    res = simulate(model, t, road, interpolation="cubic", rtol=1e-11)
    h = model.frequency_response(np.array([1j * w]))[0, 0]  # (7, 4)
    poles = np.linalg.eigvals(model.state_space().a[0])
    keep = t >= 1.0
    frame = res.to_frame()
    for j, dof in enumerate(("z_s", "phi", "theta", "z_u1")):
        measured = steady_amplitude(t[keep], frame[dof].to_numpy()[keep], w, poles)
        assert abs(measured - amp * h[j, 0]) <= 1e-6 * abs(amp * h[j, 0]), (dof, measured, amp * h[j, 0])


def test_reference_evaluator_honours_the_comfort_method():
    band, filt = variant("band_comfort"), variant("no_pipes")
    x = designs(band, 2)
    f = np.geomspace(0.5, 80.0, 40000)
    for problem in (band, filt):
        ref = grid_quantities(problem, x, f)["sigma_aw"]
        np.testing.assert_allclose(problem.evaluator()(x)["sigma_aw"], ref, rtol=2e-3)
    assert np.all(np.abs(grid_quantities(band, x, f)["sigma_aw"] / grid_quantities(filt, x, f)["sigma_aw"] - 1) > 1e-3)


def test_chamber_compliance_with_rv_zero_is_the_limit_of_small_rv():
    problem = variant("chamber")
    base = problem.baseline
    x = np.array([base, base, base, base])
    # a short; a valve adding 0.04 N s/m (R A_b^2) per strut; the baseline
    x[0, 3], x[1, 3], x[2, 3] = 0.0, 1e4, 8e5
    together = problem.evaluator()(x)
    assert together["valid"].all()
    alone = problem.evaluator()(x[:1])
    for name in problem.objective_names:
        assert together[name][0] == pytest.approx(alone[name][0], rel=1e-12)
    for name in ("sigma_aw", "rms_roll", "rms_stroke", "rms_tire_load"):  # R -> 0 is continuous
        assert together[name][0] == pytest.approx(together[name][1], rel=2e-5), name
    f = np.unique(np.r_[np.geomspace(0.5, 80.0, 20000), np.linspace(0.5, 80.0, 20000)])
    direct = grid_quantities(problem, x[:1], f)  # the network's MNA takes R = 0 as it is
    for name in ("sigma_aw", "rms_roll", "rms_stroke"):
        assert together[name][0] == pytest.approx(direct[name][0], rel=2e-3), name


def test_cli_evaluates_chamber_problem_with_rv_zero():
    done = subprocess.run(
        [sys.executable, "-m", "hisopt", "evaluate", str(ROOT / "problems" / "roll_plane_his_chamber.toml"), "--set", "Rv=0"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
    )
    assert done.returncode == 0, done.stderr
    assert "sigma_aw" in done.stdout


def test_a_design_the_model_cannot_take_is_nan_not_a_stopped_batch():
    problem = variant("chamber")
    x = np.vstack([problem.baseline, problem.baseline])
    x[1, 2] = 1.0  # lam = 1: infinite bore area
    q = Evaluator(problem)(x)
    assert q["valid"].tolist() == [True, False]
    assert np.isfinite(q["sigma_aw"][0]) and np.isnan(q["sigma_aw"][1])


def _module_imports(root: Path) -> dict[str, set[str]]:
    mods = {}
    for path in root.rglob("*.py"):
        name = ".".join(path.relative_to(root.parent).with_suffix("").parts).removesuffix(".__init__")
        mods[name] = path
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for mod, path in mods.items():
        package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text())):  # function-level imports included
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    parts = package.split(".")
                    base = ".".join(parts[: len(parts) - node.level + 1] + ([base] if base else []))
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in node.names]
            for target in targets:
                while target and target not in mods:
                    target = target.rpartition(".")[0]
                if target and target != mod and not mod.startswith(target + "."):
                    graph[mod].add(target)
    return graph


def test_no_import_cycles_inside_hisopt():
    graph = _module_imports(ROOT / "hisopt")
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    cycles = []

    def visit(v: str) -> None:  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    sys.setrecursionlimit(10_000)
    for v in graph:
        if v not in index:
            visit(v)
    assert not cycles, f"import cycles: {cycles}"
