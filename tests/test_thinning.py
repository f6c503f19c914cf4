"""The thinned front (issue 28, item 5): epsilon tolerances, their input, and the two
statements the thinned front must satisfy, checked by brute force against the definitions of
docs/model.md (never by calling the implementation's own predicates).

(a) no two thinned designs are within the tolerances of each other;
(b) every full-front design is within the tolerances of a thinned design (or dominated by one).
"""

from __future__ import annotations

import itertools
import json
import tomllib
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import hisopt
from hisopt.errors import ConfigError
from hisopt.io import read_csv
from hisopt.optim import thinning
from hisopt.optim.decision import asf_index, knee_index
from hisopt.optim.run import optimize, prepare_resume, resume
from hisopt.optim.thinning import resolve_epsilon, thin_front
from hisopt.problem import problem_from_dict
from hisopt.specification.tolerances import parse_tolerance
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM

SMALL = {"pop_size": 16, "generations": 6, "seed": 7}
OBJECTIVES = ("sigma_aw", "max_roll_psd", "max_stroke_psd", "max_tire_load_psd")


# --- the definitions, written out pair by pair (independent of hisopt.optim.thinning) ---------
def close(a: float, b: float, relative: bool, eps: float) -> bool:
    """One objective: |a - b| <= eps (absolute) or <= eps * min(|a|, |b|) (relative)."""
    return abs(a - b) <= (eps * min(abs(a), abs(b)) if relative else eps)


def within(a, b, relative, eps) -> bool:
    return all(close(float(x), float(y), r, e) for x, y, r, e in zip(a, b, relative, eps, strict=True))


def dominates(a, b) -> bool:
    return all(x <= y for x, y in zip(a, b, strict=True)) and any(x < y for x, y in zip(a, b, strict=True))


def eps_dominates(a, b, relative, eps) -> bool:
    """``a`` is worse than ``b`` by at most the tolerance in every objective."""
    return all(x <= y + (e * abs(y) if r else e) for x, y, r, e in zip(a, b, relative, eps, strict=True))


def brute_front(f: np.ndarray) -> list[int]:
    """Rows no other row dominates; of identical rows the first."""
    rows = []
    for i, a in enumerate(f):
        if any(dominates(b, a) for b in f) or any(np.array_equal(f[j], a) for j in range(i)):
            continue
        rows.append(i)
    return rows


# --- property tests ----------------------------------------------------------------------
def fronts():
    """Objective sets (n <= 40, k <= 4), tolerances per objective (absolute, relative or zero).

    Values on a coarse grid (multiples of 0.25 from 0.25 to 8) make ties and designs exactly
    on a tolerance's edge common; a second draw uses floats spread over six decades."""

    @st.composite
    def case(draw):
        k = draw(st.integers(1, 4))
        n = draw(st.integers(0, 40))
        grid = draw(st.booleans())
        value = st.integers(1, 32).map(lambda i: i * 0.25) if grid else st.floats(1e-3, 1e3, allow_nan=False)
        f = np.array(draw(st.lists(st.lists(value, min_size=k, max_size=k), min_size=n, max_size=n)), dtype=float).reshape(n, k)
        relative = np.array(draw(st.lists(st.booleans(), min_size=k, max_size=k)), dtype=bool)
        eps = np.array(draw(st.lists(st.sampled_from([0.0, 0.05, 0.25, 0.5, 1.0, 2.0]), min_size=k, max_size=k)), dtype=float)
        return f, relative, eps

    return case()


@settings(max_examples=400, derandomize=True, database=None, deadline=None, suppress_health_check=list(HealthCheck))
@given(fronts())
def test_thinned_front_is_a_packing_and_a_cover_of_the_full_front(case):
    f, relative, eps = case
    kept = thin_front(f, relative, eps)
    full = brute_front(f)
    assert set(kept.tolist()) <= set(full) and list(kept) == sorted(kept)
    # (a) no two thinned designs are within the tolerances of each other
    for i, j in itertools.combinations(kept, 2):
        assert not within(f[i], f[j], relative, eps), (f[i], f[j])
    # (b) every full-front design is within the tolerances of a thinned design (or dominated by one)
    for i in full:
        assert any(within(f[i], f[t], relative, eps) or dominates(f[t], f[i]) for t in kept), f[i]
    # every input design, dominated or not, is epsilon-dominated by a thinned one
    for row in f:
        assert any(eps_dominates(f[t], row, relative, eps) for t in kept)
    # a pure function: the same answer again, and from a copy; and the same with the candidates
    # tested in blocks of 3 (the block-to-block path of the rule, which n <= 40 never reaches at 256)
    assert np.array_equal(thin_front(f.copy(), relative.copy(), eps.copy()), kept)
    with mock.patch.object(thinning, "BLOCK", 3):
        assert np.array_equal(thin_front(f, relative, eps), kept)


@settings(max_examples=150, derandomize=True, database=None, deadline=None, suppress_health_check=list(HealthCheck))
@given(fronts())
def test_zero_tolerance_keeps_the_full_front(case):
    f, relative, _ = case
    assert thin_front(f, relative, np.zeros(f.shape[1])).tolist() == brute_front(f)


@settings(max_examples=150, derandomize=True, database=None, deadline=None, suppress_health_check=list(HealthCheck))
@given(fronts())
def test_the_default_asf_pick_is_kept_and_is_the_thinned_fronts_asf_pick(case):
    f, relative, eps = case
    full = brute_front(f)
    if not full:
        return
    front = f[full]  # the archive: non-dominated, in its order
    kept = thin_front(front, relative, eps)
    pick = asf_index(front)
    assert pick in kept
    assert kept[asf_index(front[kept])] == pick


# --- edge cases ----------------------------------------------------------------------------
def test_identical_designs_and_designs_on_the_tolerance_edge_are_one_design():
    # 1.0 and 1.5 with an absolute 0.5: |gap| = 0.5 <= 0.5, within (all values exact in binary)
    f = np.array([[1.0, 2.0], [1.5, 1.5], [1.0, 2.0]])
    assert len(thin_front(f, np.array([False, False]), np.array([0.5, 0.5]))) == 1
    # 2 and 3 with a relative 50 %: 3 - 2 = 1 <= 0.5 * 2, within; 2 and 3.5: not
    assert len(thin_front(np.array([[2.0, 3.0], [3.0, 2.0]]), np.array([True, True]), np.array([0.5, 0.5]))) == 1
    assert len(thin_front(np.array([[2.0, 3.5], [3.5, 2.0]]), np.array([True, True]), np.array([0.5, 0.5]))) == 2
    # a zero tolerance in one objective keeps designs apart that differ only there
    assert len(thin_front(np.array([[1.0, 2.0], [1.25, 1.0]]), np.array([False, False]), np.array([1.0, 0.0]))) == 2
    # the two identical rows: the first is the one kept
    assert thin_front(np.array([[1.0, 1.0], [1.0, 1.0]]), np.array([False, False]), np.array([0.1, 0.1])).tolist() == [0]


def test_empty_and_single_fronts():
    assert thin_front(np.empty((0, 3)), np.zeros(3, bool), np.ones(3)).tolist() == []
    assert thin_front(np.array([[1.0, 2.0, 3.0]]), np.zeros(3, bool), np.ones(3)).tolist() == [0]


# --- reading tolerances ----------------------------------------------------------------------
@pytest.mark.parametrize(
    "text,relative,value",
    [
        ("1 %", True, 0.01),
        ("2.5%", True, 0.025),
        ("1 percent", True, 0.01),
        ("0.01 m/s^2", False, 0.01),
        ("10 mm/s^2", False, 0.01),  # read in its unit
        ("0.01", False, 0.01),  # a bare number is SI
        (0.01, False, 0.01),
        (0, False, 0.0),
    ],
)
def test_a_tolerance_is_read_in_its_unit(text, relative, value):
    t = parse_tolerance(text, "m/s^2")
    assert t.relative is relative and t.value == pytest.approx(value, rel=1e-15)  # decimal scaling: one rounding


@pytest.mark.parametrize(
    "text,expect",
    [
        ("1 MPa", "is a pressure; expected an acceleration"),
        ("-1 %", "expected a finite tolerance >= 0"),
        ("-0.1", "expected a finite tolerance >= 0"),
        ("abc", "expected a number"),
        (True, "got true"),
        ("inf", "expected a finite tolerance"),
    ],
)
def test_a_bad_tolerance_is_one_clear_error(text, expect):
    with pytest.raises(ConfigError, match="optimizer.epsilon.sigma_aw") as info:
        parse_tolerance(text, "m/s^2", file="p.toml", key="optimizer.epsilon.sigma_aw")
    assert expect in str(info.value) and str(info.value).startswith("p.toml: optimizer.epsilon.sigma_aw: ")


def problem_with(epsilon: dict) -> hisopt.Problem:
    data = tomllib.loads(DEFAULT_PROBLEM.read_text(encoding="utf-8"))
    data["optimizer"]["epsilon"] = epsilon
    return problem_from_dict(data)


def test_the_option_overrides_the_file_per_objective():
    p = problem_with({"sigma_aw": "1 %", "max_roll_psd": "2e-6 rad^2/Hz"})
    eps = resolve_epsilon(p, ["sigma_aw=0.02 m/s^2", "max_stroke_psd=5 %"], option="--epsilon")
    assert eps is not None and eps.names == OBJECTIVES
    assert eps.relative.tolist() == [False, False, True, False]
    assert eps.value.tolist() == [0.02, 2e-6, 0.05, 0.0]
    assert resolve_epsilon(p, {"max_roll_psd": 0}).value.tolist() == [0.01, 0.0, 0.0, 0.0]  # type: ignore[union-attr]
    assert resolve_epsilon(p, "sigma_aw=1%,max_tire_load_psd=3 %").relative.tolist() == [True, False, False, True]  # type: ignore[union-attr]
    assert resolve_epsilon(hisopt.load_problem(DEFAULT_PROBLEM)) is None


def test_bad_tolerances_in_the_python_api_name_the_argument():
    p = hisopt.load_problem(DEFAULT_PROBLEM)
    with pytest.raises(ConfigError, match=r"^epsilon\.rms_roll: 'rms_roll' is not an objective"):
        resolve_epsilon(p, {"rms_roll": "1 %"})
    with pytest.raises(ConfigError, match=r"^epsilon sigma_aw=1 kg: .* is a mass; expected an acceleration"):
        resolve_epsilon(p, "sigma_aw=1 kg")


@pytest.mark.parametrize(
    "entry,key,expect",
    [
        ('{ sigma_aw = "1 kg" }', "optimizer.epsilon.sigma_aw", "is a mass; expected an acceleration"),
        ("{ sigma_aw = -0.1 }", "optimizer.epsilon.sigma_aw", "expected a finite tolerance >= 0"),
        ("{ sigma_aw = true }", "optimizer.epsilon.sigma_aw", "got true"),
        ('{ roll_gradient = "1 %" }', "optimizer.epsilon.roll_gradient", "is not an objective of this problem"),
        ('"1 %"', "optimizer.epsilon", "expected a table"),
    ],
)
def test_bad_tolerances_in_the_file_are_one_line(tmp_path, entry, key, expect):
    path = tmp_path / "bad.toml"
    path.write_text(DEFAULT_PROBLEM.read_text(encoding="utf-8").replace("seed = 1\n", f"seed = 1\nepsilon = {entry}\n", 1), encoding="utf-8")
    out = run_cli("optimize", path, "--out", tmp_path / "run", "--pop", "8", "--gens", "2")
    assert out.code == 2 and len(out.error_lines) == 1, out.stderr
    line = out.error_lines[0]
    assert line.startswith(f"error: {path}: {key}: ") and expect in line, line
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(
    "item,key,expect",
    [
        ("sigma_aw=1 kg", "--epsilon sigma_aw=1 kg", "is a mass"),
        ("rms_roll=1%", "--epsilon rms_roll=1%", "is not an objective"),
        ("sigma_aw", "--epsilon sigma_aw", "expected NAME=TOLERANCE"),
    ],
)
def test_a_bad_epsilon_option_is_one_line(tmp_path, item, key, expect):
    out = run_cli("optimize", DEFAULT_PROBLEM, "--out", tmp_path / "run", "--pop", "8", "--gens", "2", "--epsilon", item)
    assert out.code == 2 and len(out.error_lines) == 1, out.stderr
    assert out.error_lines[0].startswith(f"error: {key}: ") and expect in out.error_lines[0], out.error_lines
    assert not (tmp_path / "run").exists()


# --- a run with tolerances ---------------------------------------------------------------
EPSILON = {"sigma_aw": "2 %", "max_roll_psd": "5 %", "max_stroke_psd": "5 %", "max_tire_load_psd": "10 %"}


def test_a_run_keeps_its_full_front_and_writes_the_thinned_one(tmp_path):
    p = hisopt.load_problem(DEFAULT_PROBLEM)
    plain = optimize(p, out=tmp_path / "plain", **SMALL)
    res = optimize(p, out=tmp_path / "eps", epsilon=EPSILON, **SMALL)
    # the full front does not change, byte for byte
    assert (tmp_path / "plain" / "front.csv").read_bytes() == (tmp_path / "eps" / "front.csv").read_bytes()
    assert not (tmp_path / "plain" / "front_thinned.csv").exists()
    thinned = read_csv(tmp_path / "eps" / "front_thinned.csv")
    front = read_csv(tmp_path / "eps" / "front.csv")
    assert list(thinned.columns) == list(front.columns) and thinned.attrs["units"] == front.attrs["units"]
    assert 1 <= len(thinned) < len(front)  # these tolerances merge designs of a 96-evaluation front
    # the thinned rows are rows of front.csv, and satisfy (a) and (b) on the written values
    f, t = front[list(OBJECTIVES)].to_numpy(), thinned[list(OBJECTIVES)].to_numpy()
    assert all(any(np.array_equal(row, g) for g in f) for row in t)
    relative, eps = [True] * 4, [0.02, 0.05, 0.05, 0.10]
    for a, b in itertools.combinations(t, 2):
        assert not within(a, b, relative, eps)
    assert all(any(within(row, g, relative, eps) for g in t) for row in f)
    # run.json: the tolerances and both counts; the picks are members of the thinned front
    info = json.loads((tmp_path / "eps" / "run.json").read_text())
    assert info["settings"]["epsilon"]["sigma_aw"] == {"relative": 0.02, "text": "2 %"}
    assert info["result"]["front_size"] == len(front) and info["result"]["thinned_front_size"] == len(thinned)
    assert "thinned_front_size" not in json.loads((tmp_path / "plain" / "run.json").read_text())["result"]
    knee = res.thinned.iloc[knee_index(t)]  # type: ignore[union-attr]
    assert res.knee.equals(knee) and info["result"]["knee"]["sigma_aw"] == knee["sigma_aw"]
    assert any(np.array_equal(res.asf_pick()[list(OBJECTIVES)].to_numpy(dtype=float), row) for row in t)
    assert plain.thinned is None and plain.knee.equals(plain.front.iloc[knee_index(plain.objectives.to_numpy())])


def test_resume_keeps_the_tolerances(tmp_path):
    p = hisopt.load_problem(DEFAULT_PROBLEM)

    def stop(stats):
        if stats.generation == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        optimize(p, out=tmp_path / "cut", progress=stop, epsilon=EPSILON, **SMALL)
    assert prepare_resume(tmp_path / "cut").engine.epsilon is not None
    resumed = resume(tmp_path / "cut")
    whole = optimize(p, epsilon=EPSILON, **SMALL)
    assert resumed.thinned is not None and resumed.thinned.equals(whole.thinned)
    assert (tmp_path / "cut" / "front_thinned.csv").is_file()


def test_the_summary_says_both_counts(tmp_path):
    out = run_cli(
        "optimize",
        DEFAULT_PROBLEM,
        "--out",
        tmp_path / "run",
        "--pop",
        "16",
        "--gens",
        "3",
        "--epsilon",
        "sigma_aw=2%",
        "--epsilon",
        "max_roll_psd=5 %,max_stroke_psd=5 %",
    )
    assert out.code == 0, out.stderr
    info = json.loads((tmp_path / "run" / "run.json").read_text())
    full, thin = info["result"]["front_size"], info["result"]["thinned_front_size"]
    assert f"{full} designs" in out.stdout and f"{thin} designs (within sigma_aw 2%" in out.stdout
    assert "Knee and ASF pick of the thinned front" in out.stdout


def test_the_file_tolerances_are_used(tmp_path):
    text = DEFAULT_PROBLEM.read_text(encoding="utf-8").replace("seed = 1\n", 'seed = 1\nepsilon = { sigma_aw = "2 %", max_roll_psd = "5 %" }\n', 1)
    path = Path(tmp_path / "eps.toml")
    path.write_text(text, encoding="utf-8")
    res = optimize(path, out=tmp_path / "run", **SMALL)
    assert res.epsilon is not None and res.epsilon.value.tolist() == [0.02, 0.05, 0.0, 0.0]
    assert json.loads((tmp_path / "run" / "run.json").read_text())["settings"]["epsilon"]["max_roll_psd"]["text"] == "5 %"


def test_the_report_shows_the_thinned_front_and_both_counts(tmp_path):
    from hisopt.report.html import build_report

    optimize(DEFAULT_PROBLEM, out=tmp_path / "run", epsilon=EPSILON, **SMALL)
    info = json.loads((tmp_path / "run" / "run.json").read_text())
    full, thin = info["result"]["front_size"], info["result"]["thinned_front_size"]
    page = build_report(tmp_path / "run").read_text(encoding="utf-8")
    assert f"front of {full} designs, thinned to {thin} designs that differ by more than sigma_aw 2 %" in page
    assert "thinned_front_size" in page
    with pytest.raises(ConfigError, match=f"row index below {thin} \\(rows of front_thinned.csv\\)"):
        build_report(tmp_path / "run", design=str(thin))
