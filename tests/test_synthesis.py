"""Topology synthesis (docs/model.md §20): enumeration, screening, the run and its resume.

- every catalogue layout is among the candidates at its element count, recognised, with the
  stiffness table ``hisopt layouts`` gives it (up to the rounding of a sum over circuits);
- the candidate counts equal an independent brute force for small K: every labelled hub
  structure of the whole layout built directly (no circuits composed, no mirror map, no
  networkx), reduced by a canonical form written here (permutations of the nodes that hold
  no chamber);
- no two candidates are isomorphic (nor mirror images), and each passes the validation of a
  custom layout file;
- counts known up front (structures, candidates) equal what the enumeration does;
- bad input is one line and exit 2; a SIGKILLed synthesis resumes to identical files.
"""

from __future__ import annotations

import itertools
import shutil
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

from hisopt.hydraulics import topology
from hisopt.hydraulics.catalogue import CATALOGUE_NAMES, catalogue
from hisopt.optim import rundir
from hisopt.problem import load_problem
from hisopt.studies import synthesis
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT
from tests.sigkill import kill_at_generation

ROBUST_PROBLEM = ROOT / "problems" / "roll_plane_his_robust.toml"


@pytest.fixture(scope="module")
def full_car_10() -> topology.Enumeration:
    return topology.enumerate_layouts(10, "all", symmetric=True)


# --- the catalogue --------------------------------------------------------------------------------
def test_every_catalogue_layout_is_a_candidate_with_its_stiffness_table(full_car_10):
    from hisopt.hydraulics.roll_plane import RollPlaneHIS
    from hisopt.studies.screening import layout_his, layout_system, pattern_properties

    found = synthesis.catalogue_names(full_car_10)
    assert sorted(found.values()) == sorted(CATALOGUE_NAMES)
    by_name = {name: i for i, name in found.items()}
    problem = load_problem(DEFAULT_PROBLEM)
    his = problem.spec.his
    # the synthesis gives every accumulator V0: the twin-accumulator entry at V0 each compares
    his_equal = RollPlaneHIS.model_validate(his.model_dump() | {"parameters": {"V0_front": his.V0, "V0_rear": his.V0}})
    subset = topology.Enumeration(
        full_car_10.circuits, [full_car_10.candidates[by_name[n]] for n in CATALOGUE_NAMES], full_car_10.chambers, True, 10, full_car_10.classes
    )
    tables = synthesis.candidate_tables(problem, subset)
    for k, name in enumerate(CATALOGUE_NAMES):
        candidate = full_car_10.candidates[by_name[name]]
        expected_elements = sum(topology.element_count(g) for g in topology.layout_graphs(catalogue()[name].layout(False, False)))
        assert candidate.elements == expected_elements, name
        want = pattern_properties(layout_system(layout_his(his_equal, name)))
        # error budget: each entry is a sum over at most four circuits of the same per-circuit
        # solves the whole network does; rounding of that sum, ~10 eps of the table's scale
        for prefix in ("k_", "c_"):
            names = [q for q in want if q.startswith(prefix)]
            scale = max(abs(want[q]) for q in names)
            for q in names:
                assert tables[q][k] == pytest.approx(want[q], rel=0, abs=1e-12 * scale), (name, q)
        assert tables["stiffness_coupling"][k] == pytest.approx(want["stiffness_coupling"], abs=1e-12)


def test_a_charged_problem_screens_on_the_charged_stiffness_of_hisopt_layouts(full_car_10):
    # issue 40/42: a charged HIS ([his.charge]) is screened as `hisopt layouts` screens it, at
    # its static pressures: on the envelope problem (its own load case at the charge
    # temperature, unladen, so each circuit alone sits at its charge pressure, exactly as in
    # the whole layout) the candidates' rows equal mode_stiffness's, and roll_plane's k_roll
    # is the hand value of tests/test_layouts.py: phi^2 ~ 1/2 halves the compliance, so about
    # twice the uncharged 211.8 kN/m
    from hisopt.constants import P_ATM_PA
    from hisopt.plausibility import PlausibilityWarning
    from hisopt.studies.screening import mode_stiffness

    with pytest.warns(PlausibilityWarning):  # its -20 C case's extrapolated viscosity
        problem = load_problem(ROOT / "problems" / "roll_plane_his_envelope.toml")
    his = problem.spec.his
    names = ("roll_plane", "axle_roll")
    by_name = {name: i for i, name in synthesis.catalogue_names(full_car_10).items()}
    subset = topology.Enumeration(
        full_car_10.circuits, [full_car_10.candidates[by_name[n]] for n in names], full_car_10.chambers, True, 10, full_car_10.classes
    )
    tables = synthesis.candidate_tables(problem, subset)
    want = mode_stiffness(problem).set_index("layout")
    for k, name in enumerate(names):
        for q in ("k_bounce", "k_roll", "k_pitch", "k_warp", "c_bounce", "c_roll", "c_pitch", "c_warp"):
            # error budget: a sum over at most two circuits of the same per-circuit solves
            scale = float(np.max(np.abs(want.loc[name, [f"{q[:2]}{p}" for p in ("bounce", "roll", "pitch", "warp")]].to_numpy(float))))
            assert tables[q][k] == pytest.approx(float(want.loc[name, q]), rel=0, abs=1e-12 * scale), (name, q)
    compliance = his.charge.gas_fraction**2 * his.V0 / (his.gamma * (his.p0 + P_ATM_PA))
    a_b = his.dA / (1.0 - his.lam)
    assert tables["k_roll"][0] == pytest.approx(2 * (2 * (his.lam * a_b + a_b)) ** 2 / compliance, rel=1e-9)
    assert tables["k_roll"][0] == pytest.approx(432_273, rel=1e-5)


def test_catalogue_layouts_are_recognised_in_their_own_element_count_only():
    counts = {name: sum(topology.element_count(g) for g in topology.layout_graphs(e.layout(False, False))) for name, e in catalogue().items()}
    assert counts == {
        "roll_plane": 6,
        "roll_plane_accumulator_valves": 8,
        "roll_plane_twin_accumulator": 10,
        "pitch_plane": 6,
        "axle_roll": 8,
        "side_front_rear": 10,
    }
    smaller = topology.enumerate_layouts(7, "all", symmetric=True)
    assert sorted(synthesis.catalogue_names(smaller).values()) == ["pitch_plane", "roll_plane"]


# --- counts against a brute force ------------------------------------------------------------------
def _brute_force_graphs(chambers: tuple[str, ...], max_elements: int):
    """Every labelled layout of the hub rules, built whole: hubs 0..H-1, any links, each
    accumulator direct or behind a valve, each chamber vented or fed into a hub directly or
    through its valve; at most MAX_HUBS hubs per circuit."""
    for n in range(1, max_elements + 1):
        pairs = list(itertools.combinations(range(n), 2))
        for n_links in range(0, max_elements - n + 1):
            for links in itertools.combinations(pairs, n_links):
                hubs_graph = nx.Graph(links)
                hubs_graph.add_nodes_from(range(n))
                if any(len(c) > topology.MAX_HUBS for c in nx.connected_components(hubs_graph)):
                    continue
                for valved_acc in itertools.product((False, True), repeat=n):
                    spare = max_elements - n - n_links - sum(valved_acc)
                    if spare < 0:
                        continue
                    fates = [None] + [(h, v) for h in range(n) for v in (False, True)]
                    for choice in itertools.product(fates, repeat=len(chambers)):
                        if sum(1 for f in choice if f is not None and f[1]) > spare:
                            continue
                        graph = nx.Graph()
                        for h in range(n):
                            direct = frozenset(c for c, f in zip(chambers, choice, strict=True) if f is not None and f[0] == h and not f[1])
                            graph.add_node(h, chambers=direct, acc=not valved_acc[h])
                        graph.add_edges_from(links)
                        extra = n
                        for h in range(n):
                            if valved_acc[h]:
                                graph.add_node(extra, chambers=frozenset(), acc=True)
                                graph.add_edge(h, extra)
                                extra += 1
                        for c, f in zip(chambers, choice, strict=True):
                            if f is not None and f[1]:
                                graph.add_node(extra, chambers=frozenset((c,)), acc=False)
                                graph.add_edge(f[0], extra)
                                extra += 1
                        yield graph


def _canonical(graph: nx.Graph) -> tuple:
    """The least encoding over every numbering of the nodes without chambers (the others are
    named by their chambers, which no two nodes share)."""
    named = {v: ",".join(sorted(d["chambers"])) for v, d in graph.nodes(data=True) if d["chambers"]}
    anonymous = [v for v in graph.nodes if v not in named]
    best = None
    for order in itertools.permutations(range(len(anonymous))):
        name = dict(named) | {v: f"#{i}" for v, i in zip(anonymous, order, strict=True)}
        code = (tuple(sorted((name[v], graph.nodes[v]["acc"]) for v in graph.nodes)), tuple(sorted(tuple(sorted((name[a], name[b]))) for a, b in graph.edges)))
        best = code if best is None or code < best else best
    return best  # type: ignore[return-value]


def _brute_force_counts(chambers: tuple[str, ...], max_elements: int, symmetric: bool) -> dict[int, int]:
    seen: dict[tuple, int] = {}
    for graph in _brute_force_graphs(chambers, max_elements):
        if topology.redundant(graph):
            continue
        code, mirror = _canonical(graph), _canonical(topology.mirrored(graph))
        if symmetric and code != mirror:
            continue
        seen[min(code, mirror)] = topology.element_count(graph)
    counts: dict[int, int] = defaultdict(int)
    for elements in seen.values():
        counts[elements] += 1
    return dict(counts)


@pytest.mark.parametrize(("chambers", "max_elements", "symmetric"), [("front", 4, True), ("front", 4, False), ("all", 3, True)])
def test_candidate_counts_equal_a_brute_force(chambers, max_elements, symmetric):
    enumeration = topology.enumerate_layouts(max_elements, chambers, symmetric)
    got: dict[int, int] = defaultdict(int)
    for c in enumeration.candidates:
        got[c.elements] += 1
    assert dict(got) == _brute_force_counts(topology.CHAMBER_SETS[chambers], max_elements, symmetric)


def test_counts_known_up_front_equal_the_enumeration():
    for chambers, k, symmetric in (("front", 6, True), ("front", 5, False), ("all", 6, True)):
        labels = topology.CHAMBER_SETS[chambers]
        assert topology.candidate_count(k, chambers, symmetric) == len(topology.enumerate_layouts(k, chambers, symmetric).candidates)
        for sym, one_side in ((symmetric, False), (False, True)):
            assert topology.structure_count(labels, k, sym, one_side) == sum(1 for _ in topology.circuit_structures(labels, k, sym, one_side))


# --- distinct and valid ---------------------------------------------------------------------------
@pytest.mark.parametrize(("chambers", "max_elements", "symmetric"), [("front", 6, False), ("all", 6, True)])
def test_no_two_candidates_are_isomorphic_and_each_is_a_valid_layout_file(chambers, max_elements, symmetric):
    from hisopt.hydraulics.layout_file import CircuitSpec, check_circuits
    from hisopt.hydraulics.roll_plane import RollPlaneHIS
    from hisopt.studies.synthesis import circuit_table, synthesis_parameters

    enumeration = topology.enumerate_layouts(max_elements, chambers, symmetric)
    buckets: dict[tuple, list[nx.Graph]] = defaultdict(list)
    match = topology.node_match
    for candidate in enumeration.candidates:
        graph = enumeration.graph(candidate)
        assert not topology.redundant(graph)
        images = [graph] if symmetric else [graph, topology.mirrored(graph)]
        if symmetric:
            assert nx.is_isomorphic(graph, topology.mirrored(graph), node_match=match)
        for image in images:
            assert not any(nx.is_isomorphic(image, other, node_match=match) for other in buckets[topology.bucket_key(image)])
        buckets[topology.bucket_key(graph)].append(graph)
        layout = topology.candidate_layout(enumeration, candidate, "x")
        specs = [CircuitSpec.model_validate(circuit_table(c)) for c in layout.circuits]
        assert check_circuits(specs) is None
        his = RollPlaneHIS.model_validate(
            {
                "layout": "custom",
                "circuits": [s.model_dump(by_alias=True) for s in specs],
                "parameters": {k: v for k, v in synthesis_parameters().items() if k in layout.parameter_names()},
            }
        )
        assert his.circuits is not None


def test_a_candidate_problem_file_runs_as_a_custom_layout(tmp_path, full_car_10):
    import tomli_w

    problem = load_problem(DEFAULT_PROBLEM)
    index = next(i for i, c in enumerate(full_car_10.candidates) if c.elements == 10 and len(c.circuits) == 2)
    path = tmp_path / "c.toml"
    path.write_text(tomli_w.dumps(synthesis.candidate_problem_data(problem, full_car_10, index)))
    again = load_problem(path)
    assert again.spec.his.layout == "custom"
    values = again.evaluate(again.baseline[None, :], log=False)
    assert np.all(np.isfinite(values["sigma_aw"].to_numpy()))


# --- screening ---------------------------------------------------------------------------------------
def test_the_screen_keeps_what_meets_its_bounds():
    problem = load_problem(ROBUST_PROBLEM)
    enumeration = topology.enumerate_layouts(6, "all", symmetric=True)
    frame = synthesis.screening_frame(problem, enumeration)
    screen = problem.spec.synthesis.screen
    meets = (frame["k_roll"] >= screen["k_roll"]["min"]) & (frame["k_bounce"] <= screen["k_bounce"]["max"])
    assert ((frame["status"] == synthesis.STATUS_SCREENED_IN) == meets).all()
    assert meets.sum() > 0
    out = frame[~meets]
    assert out["status"].str.startswith("screened out: k_").all()
    assert frame.loc[frame["catalogue"] == "roll_plane", "status"].item() == synthesis.STATUS_SCREENED_IN


# --- bad input ---------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (("--max-elements", "0"), "--max-elements"),
        (("--max-elements", "4", "--chambers", "middle"), "unknown chamber set"),
        (("--max-elements", "6", "--max-candidates", "100"), "5,763 candidates"),
        (("--max-elements", "12", "--asymmetric"), "circuit structures"),
        (("--max-elements", "4", "--seeds", "x"), "--seeds"),
    ],
)
def test_bad_input_is_one_line_exit_2(tmp_path, args, needle):
    outcome = run_cli("synthesize", str(DEFAULT_PROBLEM), "--out", str(tmp_path / "s"), "--pop", "8", "--gens", "1", *args)
    assert outcome.code == 2 and len(outcome.error_lines) == 1, outcome.stderr
    assert needle in outcome.stderr and "Traceback" not in outcome.stderr
    assert not (tmp_path / "s" / "candidates.csv").exists()


def test_a_bad_screen_is_one_line_exit_2(tmp_path):
    for screen, needle in (('k_rol = { min = "40 kN/m" }', "unknown quantity 'k_rol'"), ('k_roll = { min = "40 kg" }', "k_roll.min")):
        problem = tmp_path / "p.toml"
        problem.write_text(DEFAULT_PROBLEM.read_text() + f"\n[synthesis]\nscreen = {{ {screen} }}\n")
        outcome = run_cli("synthesize", str(problem), "--max-elements", "2", "--out", str(tmp_path / "s"))
        assert outcome.code == 2 and len(outcome.error_lines) == 1, outcome.stderr
        assert needle in outcome.stderr and "synthesis.screen" in outcome.stderr


def test_run_commands_given_a_synthesis_say_what_it_is(tmp_path):
    (tmp_path / rundir.SYNTHESIS_JSON).write_text("{}")
    for command in ("report", "status"):
        outcome = run_cli(command, str(tmp_path))
        assert outcome.code == 2 and len(outcome.error_lines) == 1, outcome.stderr
        assert "a topology synthesis" in outcome.stderr and "/study" in outcome.stderr


# --- successive halving (docs/model.md §20.4) -------------------------------------------------------
HALVING_ARGS = ("--max-elements", "4", "--chambers", "front", "--seeds", "1-2", "--pop", "8", "--gens", "2")


@pytest.fixture(scope="module")
def screened_problem(tmp_path_factory) -> Path:
    """The paper's problem with the robust problem's screen: 4 of 54 front candidates kept at K = 4."""
    path = tmp_path_factory.mktemp("halving") / "problem.toml"
    path.write_text(DEFAULT_PROBLEM.read_text() + '\n[synthesis]\nscreen = { k_roll = { min = "50 kN/m" }, k_bounce = { max = "23.6 kN/m" } }\n')
    return path


@pytest.fixture(scope="module")
def halving_run(screened_problem, tmp_path_factory):
    out = tmp_path_factory.mktemp("halving") / "syn"
    # one finalist at least (the default ten would keep all four): the best third of rung 1 goes on
    outcome = run_cli("synthesize", str(screened_problem), "--out", str(out), *HALVING_ARGS, "--rungs", "2", "--first-gens", "1", "--finalists", "1")
    return outcome, out


def test_halving_runs_every_screened_in_candidate_and_the_best_half_at_full_budget(halving_run):
    import json

    from scipy.stats import spearmanr

    from hisopt.io import read_csv

    outcome, out = halving_run
    assert outcome.code == 0, outcome.stderr
    frame = read_csv(out / "candidates.csv")
    kept = frame[frame["screen_rank"].notna()].sort_values("screen_rank")
    assert len(kept) == 4 and (frame["status"] != synthesis.STATUS_SCREENED_IN).all()  # every screened-in candidate ran
    # rung 1: all four at 1 generation, one seed; rung 2: ceil(4 / 3) = 2 at the full 2 generations, seeds 1-2
    assert kept["rung"].tolist().count(2) == 2 and kept["rung"].tolist().count(1) == 2
    assert kept["gain_rung_1"].notna().all() and kept["gain_rung_2"].notna().sum() == 2
    # the two that went on are the two best of rung 1 (every one has a design at the limit here)
    best_two = kept.sort_values(["gain_rung_1", "screen_rank"], ascending=[False, True])["candidate"].head(2)
    assert set(best_two) == set(kept.loc[kept["rung"] == 2, "candidate"])
    assert set(read_csv(out / "layouts.csv")["layout"]) == set(best_two) | {"roll_plane", "conventional"}
    assert "conventional" not in set(read_csv(out / "rung-1" / "layouts.csv")["layout"])  # the last rung's reference only
    runs = read_csv(out / "rung-1" / "runs.csv")
    assert set(runs["seed"]) == {1} and len(runs) == 5
    assert set(read_csv(out / "study" / "runs.csv")["seed"]) == {1, 2}
    halving = json.loads((out / "halving.json").read_text())
    assert [(g["candidates"], g["generations"], g["seeds"]) for g in halving["plan"]] == [(4, 1, [1]), (2, 2, [1, 2])]
    # the Spearman figure of the first rung, recomputed from the CSV (ranks: 1 the best)
    want = spearmanr(kept["screen_rank"], -kept["gain_rung_1"]).statistic
    assert halving["spearman_first"]["rho"] == pytest.approx(want, abs=1e-12) and halving["spearman_first"]["candidates"] == 4
    assert halving["spearman_final"] == {"rho": None, "p_value": None, "candidates": 2}  # two candidates: undefined
    # the old rule optimised the screen's first ten: all four here, so it misses nothing
    assert halving["top_ten"] == frame.dropna(subset=["final_rank"]).sort_values("final_rank")["candidate"].tolist()
    assert halving["top_ten_missed_by_old_rule"] == []
    assert "Spearman rank correlation" in outcome.stdout and "rung 2: 2 x 2 generations x 2 seeds" in outcome.stdout
    assert "<h2>Successive halving</h2>" in (out / "report.html").read_text()


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (("--rungs", "4", "--first-gens", "1", "--gens", "100"), "--rungs 4 with 4 candidates"),  # 4 -> 2 -> 1: nothing for rung 4
        (("--rungs", "2", "--first-gens", "0"), "--first-gens: expected at least 1 generation"),
        (("--rungs", "2", "--first-gens", "2"), "rung 1 would run 2 generations"),  # the full budget is 2
        (("--optimise", "2", "--rungs", "2"), "--optimise"),
        (("--optimise", "2", "--finalists", "3"), "--optimise"),
        (("--finalists", "0"), "--finalists: expected at least 1 finalist"),
    ],
)
def test_bad_halving_input_is_one_line_exit_2_and_writes_nothing(screened_problem, tmp_path, args, needle):
    outcome = run_cli("synthesize", str(screened_problem), "--out", str(tmp_path / "s"), *HALVING_ARGS, *args)
    assert outcome.code == 2 and len(outcome.error_lines) == 1, outcome.stderr
    assert needle in outcome.stderr and "Traceback" not in outcome.stderr
    assert not (tmp_path / "s").exists()


# --- the run: resume after SIGKILL ---------------------------------------------------------------
CLI_ARGS = ("--max-elements", "4", "--chambers", "front", "--optimise", "2", "--seeds", "1-2", "--pop", "12", "--gens", "12")
FILES = ("candidates.csv", "layouts.csv", "synthesis.json", "layouts/c000006.toml")


def _cli(problem: Path, out: Path) -> list[str]:
    return [sys.executable, "-m", "hisopt", "synthesize", str(problem), "--out", str(out), *CLI_ARGS]


@pytest.mark.slow
def test_synthesis_resumes_after_sigkill_to_identical_files(tmp_path):
    problem = tmp_path / "problem.toml"
    shutil.copy(ROBUST_PROBLEM, problem)
    reference = subprocess.run(_cli(problem, tmp_path / "reference"), cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert reference.returncode == 0, reference.stderr
    assert (tmp_path / "reference" / "report.html").is_file()

    out = tmp_path / "killed"
    target = out / "study" / "c000006" / "seed-1"
    kill_at_generation(_cli(problem, out), target, 3, timeout=600)
    assert not (out / "layouts.csv").exists()
    again = subprocess.run(_cli(problem, out), cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert again.returncode == 0, again.stderr
    for name in FILES:
        assert (out / name).read_bytes() == (tmp_path / "reference" / name).read_bytes(), name
    for layout in ("roll_plane", "c000006"):
        for seed in (1, 2):
            run = Path("study") / layout / f"seed-{seed}" / rundir.FRONT_CSV
            assert (out / run).read_bytes() == (tmp_path / "reference" / run).read_bytes()

    # another search in the same directory: refused with one line, exit 2
    other = subprocess.run(
        [sys.executable, "-m", "hisopt", "synthesize", str(problem), "--out", str(out), "--max-elements", "5", "--chambers", "front", "--optimise", "2"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    lines = [line for line in other.stderr.splitlines() if line.strip()]
    assert other.returncode == 2 and len(lines) == 1 and "max_elements" in lines[0], other.stderr


@pytest.mark.slow
def test_halving_resumes_after_sigkill_in_its_last_rung_to_identical_files(tmp_path):
    problem = tmp_path / "problem.toml"
    problem.write_text(DEFAULT_PROBLEM.read_text() + '\n[synthesis]\nscreen = { k_roll = { min = "50 kN/m" }, k_bounce = { max = "23.6 kN/m" } }\n')
    args = (
        "--max-elements",
        "4",
        "--chambers",
        "front",
        "--seeds",
        "1-2",
        "--pop",
        "12",
        "--gens",
        "12",
        "--rungs",
        "2",
        "--first-gens",
        "4",
        "--finalists",
        "1",
    )

    def command(out: Path) -> list[str]:
        return [sys.executable, "-m", "hisopt", "synthesize", str(problem), "--out", str(out), *args]

    reference = subprocess.run(command(tmp_path / "reference"), cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert reference.returncode == 0, reference.stderr
    out = tmp_path / "killed"
    target = out / "study" / "roll_plane" / "seed-1"  # the last rung: rung 1 is finished by then
    kill_at_generation(command(out), target, 3, timeout=600)
    assert not (out / "halving.json").exists()
    again = subprocess.run(command(out), cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert again.returncode == 0, again.stderr
    for name in ("candidates.csv", "layouts.csv", "halving.json", "synthesis.json", "rung-1/layouts.csv", "study/layouts.csv", "study/runs.csv"):
        # the rungs' studies name each candidate's problem file by its path, in its own DIR
        assert (out / name).read_bytes().replace(b"/killed/", b"/reference/") == (tmp_path / "reference" / name).read_bytes(), name
