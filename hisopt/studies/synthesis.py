"""Topology synthesis: every interconnection up to K parts, screened, the best optimised
(docs/model.md §20).

``hisopt synthesize PROBLEM --max-elements K --out DIR`` and :func:`run_synthesis`:

1. **Enumeration** (:mod:`hisopt.hydraulics.topology`): every distinct layout of at most K
   accumulators and valves, mirror-symmetric unless asked otherwise.
2. **Screening**: each candidate's mode-stiffness table (static stiffness and low-frequency
   damping per stroke pattern, as ``hisopt layouts``) at the problem's values. A layout's
   4 x 4 matrices are the sums of its circuits' (circuits share no oil), so each distinct
   circuit is solved once by the network code and the candidates' tables are sums over
   their circuits, vectorised over candidates. The problem's ``[synthesis] screen`` keeps
   those worth optimising.
3. **Optimisation** of the survivors with the layout study (:mod:`hisopt.studies.layout_study`):
   the same objectives, constraints, load cases and budget, comfort at equal handling refined
   with CasADi, gain over roll_plane and the spread across seeds; resumable and distributable
   on Dask as the study is. By default **successive halving** over every screened-in
   candidate (:mod:`hisopt.studies.halving`, :mod:`hisopt.studies.synthesis_halving`): a
   small budget for all, the best third of each rung to the next at three times the budget,
   the last rung at the full budget with every seed in ``DIR/study`` (earlier rungs in
   ``DIR/rung-<r>``). ``optimise=N`` instead keeps the old top-N mode: the first N of the
   screen's order (those that stiffen roll most selectively first, :func:`roll_selectivity`,
   then the fewest elements), each at the full budget, in ``DIR/study``.

Directory ``DIR``::

    synthesis.json    what was asked (problem SHA-256, K, chambers, symmetry, optimise or rungs)
    candidates.csv    every candidate: description, elements, stiffness table, status
                      (halving: screen_rank, rung reached, final_rank, gain_rung_<r>, hv_rung_<r>)
    layouts/<c>.toml  each optimised candidate as a problem file with its custom layout
    rung-<r>/         halving: the layout study of an early rung
    study/            the layout study at the full budget (the last rung) and roll_plane
                      (and conventional, the car with anti-roll bars sized at the limit:
                      gain_vs_conventional_pct)
    layouts.csv       the layouts at the full budget ranked by gain at equal handling
    halving.json      halving: the plan, Spearman of screen and final order, the top ten
    report.html       :mod:`hisopt.report.synthesis_report`

Re-running the same command on ``DIR`` resumes (the enumeration is deterministic and the
study resumes its runs); another problem or search in ``DIR`` is refused.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.arguments import integer, problem_argument
from hisopt.errors import ConfigError, RunError
from hisopt.hydraulics import topology
from hisopt.optim.rundir import SYNTHESIS_JSON
from hisopt.specification.config import SCREEN_UNITS
from hisopt.units import NO_UNIT, with_units

if TYPE_CHECKING:
    from hisopt.evaluation.parallel import Backend
    from hisopt.problem import Problem
    from hisopt.studies.layout_study import LayoutStudyResult

CANDIDATES_CSV, LAYOUTS_CSV, STUDY_DIR, LAYOUT_DIR, HALVING_JSON = "candidates.csv", "layouts.csv", "study", "layouts", "halving.json"
SYNTHESIS_FORMAT = "hisopt-synthesis/1"
MAX_CANDIDATES = 100_000
"""[-] Default limit of candidates: beyond it a search is refused before it starts."""
MAX_STRUCTURES = 100_000
"""[-] Circuit structures an enumeration may examine (about 20 s at :data:`STRUCTURE_RATE`):
a mirror-symmetric search stays far below it up to K = 14, an asymmetric one of all eight
chambers passes it at K = 5."""
STRUCTURE_RATE = 5_000.0
"""[1/s] Circuit structures examined per second on one core, about (benchmarks/bench_synthesis.py)."""
CANDIDATE_RATE = 3_000.0
"""[1/s] Candidates enumerated and screened per second on one core, about (benchmarks/bench_synthesis.py)."""

STATUS_OPTIMISED, STATUS_SCREENED_IN = "optimised", "screened in"


def synthesis_parameters() -> dict[str, float]:
    """[SI] Defaults of the valves a synthesised layout adds: the catalogue's (``Rv_acc`` of
    roll_plane_accumulator_valves, ``Rv_link`` of roll_plane_twin_accumulator)."""
    from hisopt.hydraulics.catalogue import catalogue

    entries = catalogue()
    return {
        topology.ACCUMULATOR_VALVE: entries["roll_plane_accumulator_valves"].parameters[topology.ACCUMULATOR_VALVE],
        topology.LINK_VALVE: entries["roll_plane_twin_accumulator"].parameters[topology.LINK_VALVE],
    }


def synthesis_bounds() -> dict[str, dict[str, Any]]:
    """[SI] Bounds of those valves when a layout study varies them (the same entries')."""
    from hisopt.hydraulics.catalogue import catalogue

    entries = catalogue()
    return {
        topology.ACCUMULATOR_VALVE: entries["roll_plane_accumulator_valves"].variables[topology.ACCUMULATOR_VALVE].model_dump(),
        topology.LINK_VALVE: entries["roll_plane_twin_accumulator"].variables[topology.LINK_VALVE].model_dump(),
    }


# --- screening -----------------------------------------------------------------------------------
def circuit_matrices(problem: Problem, graphs: Sequence[Any]) -> tuple[np.ndarray, np.ndarray]:
    """[N/m], [N s/m] Static stroke stiffness and low-frequency damping (4 x 4 each) that each
    one-circuit node graph adds at the problem's values (its pipes and chamber volumes) and
    temperature, linearised at the static operating point of the problem's own load case as
    its model is (:func:`hisopt.specification.design_space.at_operating_point`: a charged HIS
    at its static pressures, as ``hisopt layouts`` screens it): shapes ``(n, 4, 4)``.

    Each circuit is solved alone: exact for a charged HIS at its charge temperature without a
    payload (each circuit sits at its own charge pressure) and for the precharge; under a
    payload or away from the charge temperature the car's static displacement, which all
    circuits share, is the one circuit's."""
    from hisopt.hydraulics.catalogue import his_parameter_values, with_chamber_lines
    from hisopt.hydraulics.coupling import HydraulicSystem
    from hisopt.hydraulics.layout import Layout
    from hisopt.hydraulics.network import compile_network
    from hisopt.specification.design_space import at_operating_point

    his = problem.spec.his
    values = his_parameter_values(his.model_copy(update={"layout": "custom", "parameters": {}}), synthesis_parameters(), problem.spec.temperature)
    values |= damper_valve_resistances(problem)
    pipes, chamber = his.pipes is not None, his.chamber_volume > 0
    k = np.zeros((len(graphs), 4, 4))
    c = np.zeros((len(graphs), 4, 4))
    for i, graph in enumerate(graphs):
        layout = with_chamber_lines(Layout((topology.circuit_of_graph(graph, "A"),)), pipes, chamber)
        system = at_operating_point(problem.spec, HydraulicSystem(compile_network(layout, "lumped"), values))
        k[i] = np.asarray(system.static_stiffness(), dtype=float).reshape(4, 4)
        c[i] = np.asarray(system.low_frequency_damping(), dtype=float).reshape(4, 4)
    return k, c


def damper_valve_resistances(problem: Problem) -> dict[str, float]:
    """[Pa s m^-3] ``{"Rv": ..., "Rv_rear": ...}``: with ``[his] orifice_diameter`` (every
    candidate's ``Rv`` valves are physical damper valves), the mean equivalent resistance of
    the front and of the rear damper valves at the problem's baseline on its road (of its
    own layout, or of roll_plane's when its layout has no such valves), at which the
    screening holds them linear; {} without. A candidate's own flows would differ a little:
    the screening ranks, the layout study then solves each survivor's valves per design.

    Raises
    ------
    ModelError
        The valves' flows have no fixed point at the baseline.
    """
    from hisopt.errors import ModelError
    from hisopt.hydraulics.layout import DamperValve
    from hisopt.studies.layout_cases import REFERENCE_LAYOUT, catalogue_case
    from hisopt.studies.screening import baseline_valve_resistance

    if problem.spec.his.orifice_diameter is None:
        return {}
    axles = {"orifice_diameter": "Rv", "orifice_diameter_rear": "Rv_rear"}

    def reads(space: Problem) -> list[str]:
        return [axles.get(str(e.orifice_diameter), "") for _, e, _ in space.network().damper_valves() if isinstance(e, DamperValve)]

    space = problem if any(reads(problem)) else catalogue_case(problem, REFERENCE_LAYOUT).problem
    resistance = baseline_valve_resistance(space)
    if not np.all(np.isfinite(resistance)):
        raise ModelError("the damper valves' RMS flows have no fixed point at the baseline on this road, so the synthesis cannot screen their damping")
    axle = np.array(reads(space))
    return {name: float(np.mean(resistance[axle == name])) for name in axles.values() if np.any(axle == name)}


def candidate_tables(problem: Problem, enumeration: topology.Enumeration) -> dict[str, np.ndarray]:
    """The screening columns of every candidate (``k_bounce`` .. ``stiffness_coupling``),
    each ``(n_candidates,)``: its circuits' matrices summed, vectorised over candidates."""
    from hisopt.studies.screening import pattern_table

    used = sorted({i for cand in enumeration.candidates for i in cand.circuits})
    position = np.full(len(enumeration.circuits), -1)
    position[used] = np.arange(len(used))
    k_circuit, c_circuit = circuit_matrices(problem, [enumeration.circuits[i] for i in used])
    owner = np.repeat(np.arange(len(enumeration.candidates)), [len(cand.circuits) for cand in enumeration.candidates])
    member = position[np.concatenate([np.asarray(cand.circuits) for cand in enumeration.candidates])] if enumeration.candidates else np.zeros(0, int)
    k = np.zeros((len(enumeration.candidates), 4, 4))
    c = np.zeros_like(k)
    np.add.at(k, owner, k_circuit[member])
    np.add.at(c, owner, c_circuit[member])
    return pattern_table(k, c)


def screen_status(table: pd.DataFrame, screen: dict[str, dict[str, float]]) -> list[str]:
    """Per candidate ``"screened in"`` or why not (the first bound it breaks, in the
    quantity's engineering unit)."""
    from hisopt.units import format_quantity

    status = np.full(len(table), STATUS_SCREENED_IN, dtype=object)
    nothing = np.all(table[list(SCREEN_UNITS)[:8]].to_numpy() == 0.0, axis=1)  # exactly: no stiffness, no damping
    status[nothing] = "screened out: does nothing"
    for name, bounds in screen.items():
        values = table[name].to_numpy()
        for key, limit in bounds.items():
            broken = (values < limit) if key == "min" else (values > limit)
            fresh = broken & (status == STATUS_SCREENED_IN)
            sign = "<" if key == "min" else ">"
            for i in np.flatnonzero(fresh):
                status[i] = f"screened out: {name} {format_quantity(values[i], SCREEN_UNITS[name])} {sign} {key} {format_quantity(limit, SCREEN_UNITS[name])}"
    return list(status)


def catalogue_names(enumeration: topology.Enumeration) -> dict[int, str]:
    """Candidate index -> the catalogue layout it is (the same circuits up to node names)."""
    from hisopt.hydraulics.catalogue import catalogue

    index = {cand.circuits: i for i, cand in enumerate(enumeration.candidates)}
    out = {}
    for name, entry in catalogue().items():
        found = [enumeration.classes.find(g) for g in topology.layout_graphs(entry.layout(False, False))]
        if all(f is not None for f in found):
            key = tuple(sorted(int(f) for f in found if f is not None))
            if key in index:
                out[index[key]] = name
    return out


def screening_frame(problem: Problem, enumeration: topology.Enumeration) -> pd.DataFrame:
    """``candidates.csv`` before optimisation: ``candidate``, ``elements``, ``circuits``,
    ``catalogue`` (the catalogue layout it is, if any), ``description``, the stiffness table
    and ``status`` (module docstring)."""
    names = catalogue_names(enumeration)
    frame = pd.DataFrame(
        {
            "candidate": [candidate_name(i) for i in range(len(enumeration.candidates))],
            "elements": [c.elements for c in enumeration.candidates],
            "circuits": [len(c.circuits) for c in enumeration.candidates],
            "catalogue": [names.get(i, "") for i in range(len(enumeration.candidates))],
            "description": [damper_valve_words(problem, topology.describe(enumeration, c)) for c in enumeration.candidates],
            **candidate_tables(problem, enumeration),
        }
    )
    frame["roll_selectivity"] = roll_selectivity(frame)
    screen = problem.spec.synthesis.screen if problem.spec.synthesis is not None else {}
    frame["status"] = screen_status(frame, screen)
    units = {"candidate": NO_UNIT, "elements": NO_UNIT, "circuits": NO_UNIT, "catalogue": NO_UNIT, "description": NO_UNIT, "status": NO_UNIT}
    return with_units(frame, units | SCREEN_UNITS | {"roll_selectivity": NO_UNIT})


def damper_valve_words(problem: Problem, description: str) -> str:
    """A candidate's description (:func:`hisopt.hydraulics.topology.describe`) with its ``Rv``
    and ``Rv_rear`` valves named as the physical damper valves ``[his] orifice_diameter``
    makes them: ``2b~A:damper(3 mm, 1.5 MPa)``, orifice and cracking pressure (``damper(3 mm)``
    without a blow-off); unchanged without."""
    import re

    from hisopt.hydraulics.catalogue import his_parameter_values
    from hisopt.units import format_quantity

    his = problem.spec.his
    if his.orifice_diameter is None:
        return description
    values = his_parameter_values(his)

    def words(match: re.Match[str]) -> str:
        axle = match.group(1) or ""
        parts = [format_quantity(values[f"orifice_diameter{axle}"], "m")]
        if his.cracking_pressure is not None:
            parts.append(format_quantity(values[f"cracking_pressure{axle}"], "Pa"))
        return f":damper({', '.join(parts)})"

    return re.sub(r":Rv(_rear)?(?![A-Za-z0-9_])", words, description)


def candidate_name(index: int) -> str:
    """``c000123``: a candidate's name (its row in ``candidates.csv``)."""
    return f"c{index:06d}"


def roll_selectivity(table: pd.DataFrame) -> np.ndarray:
    """[-] ``k_roll / (k_bounce + k_pitch + k_warp)``: how much a layout stiffens roll alone
    (roll control without a harder ride; roll_plane about 9 at the paper's baseline)."""
    other = table[["k_bounce", "k_pitch", "k_warp"]].to_numpy().sum(axis=1)
    roll = table["k_roll"].to_numpy()
    return np.divide(roll, other, out=np.where(roll > 0, np.inf, 0.0), where=other > 0)


def pick_survivors(frame: pd.DataFrame, optimise: int) -> list[int]:
    """Rows to optimise: screened in, the most roll-selective first (:func:`roll_selectivity`),
    then the fewest elements."""
    survivors = frame[frame["status"] == STATUS_SCREENED_IN].copy()
    # six digits: equal selectivities (statically alike layouts) tie whatever the rounding
    survivors["rank_key"] = [float(f"{v:.6g}") for v in survivors["roll_selectivity"]]
    order = survivors.sort_values(["rank_key", "elements"], ascending=[False, True], kind="stable")
    return [int(i) for i in order.index[:optimise]]


# --- a candidate as a problem file --------------------------------------------------------------
def circuit_table(circuit: Any) -> dict[str, Any]:
    """A :class:`~hisopt.hydraulics.layout.Circuit` in the ``[[his.circuits]]`` syntax."""
    from hisopt.hydraulics.layout import Accumulator

    elements: list[dict[str, Any]] = []
    for e in circuit.elements:
        if isinstance(e, Accumulator):
            elements.append({"type": "accumulator", "node": e.node, "volume": e.volume, "precharge": e.precharge, "gamma": e.gamma})
        else:
            elements.append({"type": "valve", "from": e.a, "to": e.b, "resistance": e.resistance})
    return {"name": circuit.name, "nodes": list(circuit.nodes), "chambers": {p.label: p.node for p in circuit.ports}, "elements": elements}


def candidate_problem_data(problem: Problem, enumeration: topology.Enumeration, index: int) -> dict[str, Any]:
    """The problem file of candidate ``index``: the problem with the candidate's layout, its
    added valves' defaults in ``[his.parameters]`` and their bounds in ``[variables]``."""
    from hisopt.hydraulics.catalogue import used_parameters
    from hisopt.hydraulics.layout import with_damper_valves
    from hisopt.studies.design_sheet import without_none

    name = candidate_name(index)
    layout = topology.candidate_layout(enumeration, enumeration.candidates[index], name)
    data = without_none(problem.spec.model_dump(mode="json", by_alias=True))
    his = problem.spec.his
    read = layout  # as loaded (his_layout): with [his] orifice_diameter, its Rv valves read the damper valves' values
    if his.orifice_diameter is not None:
        read = with_damper_valves(layout, his.cracking_pressure is not None, his.valve_flow_rms is not None)
    used = used_parameters(read)
    extras = {k: v for k, v in synthesis_parameters().items() if k in used}
    data["his"] |= {"layout": "custom", "circuits": [circuit_table(c) for c in layout.circuits], "parameters": extras}
    variables = {**data.get("variables", {}), **{k: b for k, b in synthesis_bounds().items() if k in extras}}
    data["variables"] = {k: v for k, v in variables.items() if k in used}  # a variable the layout does not read is refused
    data["name"] = name
    data["description"] = f"hisopt synthesize candidate {name}: {topology.describe(enumeration, enumeration.candidates[index])}"
    data.pop("synthesis", None)
    return data


# --- the run -------------------------------------------------------------------------------------
@dataclass
class SynthesisResult:
    """What a synthesis found (module docstring).

    Attributes
    ----------
    candidates : pd.DataFrame
        ``candidates.csv``: every candidate, its stiffness table and status
    layouts : pd.DataFrame
        ``layouts.csv``: the optimised layouts (and roll_plane), best gain first
    study : LayoutStudyResult | None
        the layout study of the survivors (None: none survived)
    counts : pd.DataFrame
        candidates per element count: ``elements``, ``candidates``, ``screened_in``
    out : Path | None
        the directory written (None: nothing)
    halving : dict[str, Any] | None
        ``halving.json`` (:func:`hisopt.studies.synthesis_halving.halving_summary`: the
        plan, the Spearman correlations of the screen's order and the measured one, the
        top ten the old rule would have missed); None in the top-N mode
    """

    candidates: pd.DataFrame
    layouts: pd.DataFrame
    study: LayoutStudyResult | None
    counts: pd.DataFrame
    out: Path | None
    halving: dict[str, Any] | None = None


def check_search_arguments(max_elements: int, chambers: str, max_candidates: int) -> None:
    """The search's own arguments, refused in one line (no counting: instant, so the command
    calls it before it starts anything): ``--max-elements`` and ``--max-candidates`` whole
    numbers >= 1, ``--chambers`` a known set."""
    integer(max_elements, "--max-elements", minimum=1, what="element")
    integer(max_candidates, "--max-candidates", minimum=1, what="candidate")
    if chambers not in topology.CHAMBER_SETS:
        raise ConfigError(f"unknown chamber set {chambers!r}; expected one of {', '.join(topology.CHAMBER_SETS)}", key="--chambers")


def check_search(max_elements: int, chambers: str, symmetric: bool, max_candidates: int) -> int:
    """The number of candidates of a search, refused up front when too large.

    Raises
    ------
    ConfigError
        ``--max-elements`` below 1, unknown ``--chambers``, or a search beyond
        :data:`MAX_STRUCTURES` structures or ``max_candidates`` candidates (with the count
        and the time it would take).
    """
    check_search_arguments(max_elements, chambers, max_candidates)
    structures = topology.search_structure_count(max_elements, chambers, symmetric)
    if structures > MAX_STRUCTURES:
        raise ConfigError(
            f"K = {max_elements} would examine {structures:,} circuit structures (about {_duration(structures / STRUCTURE_RATE)} on one core); "
            f"the limit is {MAX_STRUCTURES:,}: choose a smaller K{'' if symmetric else ' or a mirror-symmetric search'}",
            key="--max-elements",
        )
    count = topology.candidate_count(max_elements, chambers, symmetric)
    if count > max_candidates:
        raise ConfigError(
            f"K = {max_elements} gives {count:,} candidates (about {_duration(count / CANDIDATE_RATE)} to enumerate and screen, before any optimisation); "
            f"the limit is {max_candidates:,} (--max-candidates): choose a smaller K or raise the limit",
            key="--max-elements",
        )
    return count


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def _record(problem: Problem, max_elements: int, chambers: str, symmetric: bool, mode: dict[str, Any]) -> dict[str, Any]:
    from hisopt.studies.layout_study import problem_digest

    return {
        "format": SYNTHESIS_FORMAT,
        "problem": {"name": problem.name, "sha256": problem_digest(problem)},
        "max_elements": max_elements,
        "chambers": chambers,
        "symmetric": symmetric,
    } | mode


def check_record(out: Path, record: dict[str, Any]) -> None:
    """Refuse ``out`` when it holds another synthesis.

    Raises
    ------
    RunError
        ``out/synthesis.json`` is unreadable or records another problem or search.
    """
    path = out / SYNTHESIS_JSON
    if not path.is_file():
        return
    try:
        stored = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise RunError(f"{path}: unreadable ({exc}); choose another --out") from None
    if stored != record:
        differ = [k for k in record if stored.get(k) != record[k]]
        raise RunError(f"{out} holds a synthesis with other {', '.join(differ)}; use the same command or another --out")


def counts_table(candidates: pd.DataFrame) -> pd.DataFrame:
    """Candidates and screened-in candidates per element count."""
    kept = ~candidates["status"].str.startswith("screened out")
    grouped = kept.groupby(candidates["elements"])
    frame = pd.DataFrame({"candidates": grouped.size(), "screened_in": grouped.sum()}).reset_index()
    return with_units(frame, {"elements": NO_UNIT, "candidates": NO_UNIT, "screened_in": NO_UNIT})


def run_synthesis(
    problem: Problem,
    max_elements: int,
    *,
    chambers: str = "all",
    symmetric: bool = True,
    seeds: str | Sequence[int] = (1, 2, 3),
    out: str | Path | None = None,
    pop_size: int | None = None,
    generations: int | None = None,
    optimise: int | None = None,
    rungs: int | None = None,
    first_generations: int | None = None,
    finalists: int | None = None,
    max_candidates: int = MAX_CANDIDATES,
    handling: str | None = None,
    backend: Backend | None = None,
    progress: Callable[[str], None] | None = None,
) -> SynthesisResult:
    """Enumerate, screen and optimise (module docstring).

    Parameters
    ----------
    problem : Problem
        the study problem (its ``[synthesis] screen``, objectives, constraints, load cases)
    max_elements : int
        [-] K: accumulators plus valves
    chambers : str, optional
        [-] ``all``, ``front`` (single-axle layouts) or ``rear``
    symmetric : bool, optional
        only mirror-symmetric layouts (default)
    seeds, pop_size, generations, handling, backend
        as :func:`hisopt.studies.layout_study.run_layout_study` (``generations``: the full
        budget, of the last rung)
    out : str | Path | None, optional
        directory (module docstring); None writes nothing but the optimised layouts'
        problem files, in a temporary folder (``layouts.csv``'s ``file`` column)
    optimise : int | None, optional
        [-] None (default): successive halving over every screened-in candidate; a number:
        the old top-N mode, at most this many survivors, the screen's first, each at the
        full budget (0: screening only)
    rungs : int | None, optional
        [-] successive halving's rungs (default :func:`hisopt.studies.halving.default_rungs`:
        as many as leave more than ten candidates for the last rung to choose its ten from)
    first_generations : int | None, optional
        [generations] the first rung's budget (default
        :func:`hisopt.studies.halving.default_first_generations`)
    finalists : int | None, optional
        [-] the least the last rung keeps, at the full budget with every seed (default
        :data:`hisopt.studies.halving.DEFAULT_FINALISTS`, ten)
    max_candidates : int, optional
        [-] refuse a search with more candidates
    progress : Callable[[str], None] | None, optional
        called with a line of news at each stage

    Raises
    ------
    ConfigError
        A bad K, chamber set, seeds or budget, a search beyond the limits, ``optimise``
        given with ``rungs`` or ``first_generations``, or a rung plan that leaves no candidate
        for the last rung or runs a rung below one generation (:func:`hisopt.studies.halving.halving_plan`);
        all before anything is written.
    RunError
        ``out`` holds another synthesis, a folder of another kind or files hisopt did not
        write (:func:`hisopt.folders.claim`).
    """
    from hisopt.folders import SYNTHESIS, check_claim, claim
    from hisopt.io import atomic_write_json, write_csv
    from hisopt.studies.layout_study import parse_seed_list, read_study_record, study_budget

    say = progress or (lambda _: None)
    problem_argument(problem)
    seed_list = parse_seed_list(seeds)
    budget = study_budget(problem, pop_size, generations)
    mode = check_mode(optimise, rungs, first_generations, budget["generations"], finalists)
    count = check_search(max_elements, chambers, symmetric, max_candidates)
    out_dir = None if out is None else Path(out)
    record = _record(problem, max_elements, chambers, symmetric, mode)
    if out_dir is not None:
        check_claim(out_dir, SYNTHESIS)  # a folder of another kind, or a user's, is refused
        check_record(out_dir, record)  # so is another synthesis
        read_study_record(out_dir / STUDY_DIR, problem, budget)
    # no news before the plan is checked: a refused plan is one line (its count needs the screen)
    enumeration = topology.enumerate_layouts(max_elements, chambers, symmetric)
    candidates = screening_frame(problem, enumeration)
    screen_order = pick_survivors(candidates, len(candidates))
    plan = None
    if optimise is None and screen_order:  # checked before anything is written
        from hisopt.studies.halving import DEFAULT_FINALISTS, DEFAULT_FIRST_GENERATIONS, default_first_generations, default_rungs, halving_plan

        full, top = budget["generations"], finalists or DEFAULT_FINALISTS
        r = rungs if rungs is not None else default_rungs(len(screen_order), full, first_generations or DEFAULT_FIRST_GENERATIONS, top)
        g = first_generations if first_generations is not None else default_first_generations(r, full)
        plan = halving_plan(len(screen_order), r, g, full, seed_list, top)
    if out_dir is not None:
        claim(out_dir, SYNTHESIS)
        atomic_write_json(out_dir / SYNTHESIS_JSON, record)
    say(f"enumerated and screened {count:,} candidates of at most {max_elements} elements: {len(screen_order):,} screened in")
    picked = screen_order if plan is not None else screen_order[: int(optimise or 0)]
    study, halving = None, None
    files: dict[str, Path] = {}
    if picked:
        files = _write_layout_files(problem, enumeration, picked, out_dir)
        in_count = len(screen_order)
        from hisopt.studies.layout_cases import CONVENTIONAL

        if plan is not None:
            from hisopt.studies import synthesis_halving as sh

            say(f"successive halving over {in_count:,} screened-in candidates: " + ", ".join(f"{g.candidates:,} x {g.generations} gen" for g in plan))
            run = sh.run_halving(problem, files, plan, out=out_dir, pop_size=pop_size, handling=handling, backend=backend, say=say, references=[CONVENTIONAL])
            study = run.studies[-1]
            names = [candidate_name(i) for i in screen_order]
            halving = sh.halving_summary(run, names, names[: sh.TOP])
            extra = sh.rung_columns(run, list(candidates["candidate"]), names)
            units = dict(candidates.attrs["units"]) | sh.rung_units(len(plan))
            candidates = with_units(pd.concat([candidates, extra], axis=1), units)
            files = {str(n): files[str(n)] for n in run.result.entrants[-1]}
            for i, reached in enumerate(candidates["rung"]):
                if reached:
                    candidates.loc[i, "status"] = STATUS_OPTIMISED if reached == len(plan) else f"stopped at rung {reached} of {len(plan)}"
        else:
            say(f"optimising {len(picked)} of {in_count} screened-in candidates and roll_plane")
            from hisopt.studies.layout_study import run_layout_study

            study = run_layout_study(
                problem,
                [*(str(p) for p in files.values()), CONVENTIONAL],  # the car with bars: gains against it too (a second, no runs)
                seeds,
                out=None if out_dir is None else out_dir / STUDY_DIR,
                pop_size=pop_size,
                generations=generations,
                handling=handling,
                backend=backend,
            )
            for i in picked:
                candidates.loc[i, "status"] = STATUS_OPTIMISED
    layouts = _layouts_table(candidates, study, files, out_dir)
    counts = counts_table(candidates)
    if out_dir is not None:
        write_csv(candidates, out_dir / CANDIDATES_CSV)
        write_csv(layouts, out_dir / LAYOUTS_CSV)
        if halving is not None:
            atomic_write_json(out_dir / HALVING_JSON, halving)
    return SynthesisResult(candidates, layouts, study, counts, out_dir, halving)


def check_mode(optimise: int | None, rungs: int | None, first_generations: int | None, full_generations: int, finalists: int | None = None) -> dict[str, Any]:
    """The optimisation mode as ``synthesis.json`` records it: ``{"optimise": N}`` (the top-N
    mode) or ``{"halving": {"rungs", "first_generations", "finalists"}}`` (as asked: None for
    a default).

    Raises
    ------
    ConfigError
        ``--optimise`` below 0 or given with ``--rungs``/``--first-gens``/``--finalists``; a
        bad rung, first budget (:func:`hisopt.studies.halving.check_halving_arguments`) or
        finalist count.
    """
    from hisopt.studies.halving import check_halving_arguments, default_first_generations

    if optimise is not None:
        integer(optimise, "--optimise", minimum=0, what="layouts to optimise")
        if rungs is not None or first_generations is not None or finalists is not None:
            raise ConfigError(
                "--optimise N selects the old top-N mode; --rungs, --first-gens and --finalists belong to successive halving (the default): "
                "give one or the other",
                key="--optimise",
            )
        return {"optimise": int(optimise)}
    if rungs is not None or first_generations is not None:  # the candidates' count is not needed for these
        checked = 1 if rungs is None else rungs
        first = default_first_generations(checked, full_generations) if first_generations is None else first_generations
        check_halving_arguments(checked, first, full_generations)
    if finalists is not None:
        integer(finalists, "--finalists", minimum=1, what="finalist")
    return {"halving": {"rungs": rungs, "first_generations": first_generations, "finalists": finalists}}


def _write_layout_files(problem: Problem, enumeration: topology.Enumeration, picked: list[int], out_dir: Path | None) -> dict[str, Path]:
    """Each picked candidate's problem file (a temporary folder when nothing is kept)."""
    import tempfile

    import tomli_w

    from hisopt.io import atomic_write_text

    folder = out_dir / LAYOUT_DIR if out_dir is not None else Path(tempfile.mkdtemp(prefix="hisopt-synthesis-"))
    folder.mkdir(parents=True, exist_ok=True)
    files = {}
    for i in picked:
        path = folder / f"{candidate_name(i)}.toml"
        atomic_write_text(path, tomli_w.dumps(candidate_problem_data(problem, enumeration, i)))
        files[candidate_name(i)] = path
    return files


def _shown_path(path: Path, out_dir: Path | None) -> str:
    """A layout file's path as ``layouts.csv`` shows it: within ``DIR`` when there is one."""
    return str(path.relative_to(out_dir)) if out_dir is not None else str(path)


def _layouts_table(candidates: pd.DataFrame, study: LayoutStudyResult | None, files: dict[str, Path], out_dir: Path | None) -> pd.DataFrame:
    """``layouts.csv``: the study's table with each candidate's description and problem file
    (relative to ``DIR``), best gain first (roll_plane, the reference, included)."""
    from hisopt.studies.layout_cases import CONVENTIONAL

    if study is None:
        return with_units(pd.DataFrame({"layout": [], "gain_vs_roll_plane_pct": []}), {"layout": NO_UNIT, "gain_vs_roll_plane_pct": "%"})
    table = study.table.copy()
    info = candidates.set_index("candidate")
    table.insert(1, "elements", [int(info.loc[n, "elements"]) if n in info.index else _catalogue_elements(n) for n in table["layout"]])  # conventional: 0
    table.insert(2, "catalogue", [info.loc[n, "catalogue"] if n in info.index else n for n in table["layout"]])
    table.insert(3, "file", [_shown_path(files[n], out_dir) if n in files else "" for n in table["layout"]])
    if "source" in table:
        table["source"] = ["synthesis" if n in files else source for n, source in zip(table["layout"], table["source"], strict=True)]
    references = {CONVENTIONAL: "car without circuits, anti-roll bars sized at the limit (reference)"}
    described = [info.loc[n, "description"] if n in info.index else references.get(n, "catalogue layout (reference)") for n in table["layout"]]
    table.insert(4, "description", described)
    table = table.sort_values("gain_vs_roll_plane_pct", ascending=False, na_position="last", kind="stable").reset_index(drop=True)
    units = dict(study.table.attrs["units"]) | {"elements": NO_UNIT, "catalogue": NO_UNIT, "file": NO_UNIT, "description": NO_UNIT}
    return with_units(table, units)


def _catalogue_elements(name: str) -> int:
    """[-] Accumulators plus valves of a catalogue layout (0 for the car without circuits)."""
    from hisopt.hydraulics.catalogue import catalogue
    from hisopt.studies.layout_cases import CONVENTIONAL

    if name == CONVENTIONAL:
        return 0

    return sum(topology.element_count(g) for g in topology.layout_graphs(catalogue()[name].layout(False, False)))
