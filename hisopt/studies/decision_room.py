"""What the decision room holds (docs/model.md §19): the designs of a run or a layout study,
every quantity of each, the parts they make, their spectra and step response, and the
problem file each one hands over.

The page itself (:mod:`hisopt.report.decision_page`) draws, filters and navigates these in
the browser; this module computes them once, with the evaluator (every quantity is the
evaluator's own, so a design exported from the page and evaluated again gives the same
numbers).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from hisopt.errors import RunError
from hisopt.evaluation.channels import DirectOutputs
from hisopt.evaluation.evaluate import Evaluator
from hisopt.evaluation.transient import step_responses
from hisopt.hydraulics import laws
from hisopt.optim.archive import non_dominated_mask
from hisopt.studies.build_verdicts import run_verdicts
from hisopt.studies.buildability import BINDING_RULE, BUILD_MARGIN, BUILDABLE
from hisopt.studies.verified import front_verdicts
from hisopt.units import psd_unit

if TYPE_CHECKING:
    from hisopt.problem import Problem
    from hisopt.studies.layout_study import LayoutStudyResult

MAX_ROWS = 20_000
"""[-] Designs a page holds at most: the front always, then the latest other evaluations."""
SPECTRUM_OUTPUTS = ("acc_z", "roll")
"""The spectra drawn for a design: CG vertical acceleration (comfort) and roll angle (handling)."""
SPECTRUM_SAMPLES = 48
"""[-] Log-spaced frequencies of each spectrum over the problem's [band]."""
STEP_SAMPLES = 64
"""[-] Times of the step response."""
STEP_DURATION_S = 3.0
"""[s] The step response is drawn from the step to this time (the roll modes near 1 to 2 Hz
have settled by then for every damping the paper's box allows)."""
CHUNK = 2000
"""[-] Designs per batch of curves (bounds the memory of the direct solves)."""
CURVE_METHODS = ("modal", "direct")
"""How :func:`design_curves` computes the spectra: the evaluator's channels, or direct solves."""

GROUPS = ("variable", "objective", "constraint", "load case", "part", "valve", "build")
"""The kinds of a room's quantity columns, in the page's order (:class:`Room`)."""
VERIFIED = "verified"
"""The column of each front design's verdict in the time domain (``hisopt verify``; ``""``: not verified)."""
KINDS = ("front", "refined", "evaluated")
"""Where a row comes from: ``front.csv``, a refined front (``front_refined.csv``, ``front_refined_ipopt.csv``) or ``evaluations.parquet``."""


@dataclass(frozen=True)
class Source:
    """One problem's designs in the room: a run's, or one layout's in a layout study.

    ``x`` [SI] ``(n, n_var)``; ``kind`` per row one of :data:`KINDS`; ``row`` the row in that
    file (from 0; for an evaluation its number).
    """

    name: str
    problem: Problem
    x: np.ndarray
    kind: np.ndarray
    row: np.ndarray
    location: str = ""


@dataclass(frozen=True)
class Curves:
    """Spectra and step responses of designs: ``spectra`` ``(n, F, len(outputs))`` [output
    unit^2/Hz] at ``f_hz`` ``(F,)``, ``step`` ``(n, P)`` [rad] roll angle after a lateral step
    of ``step_g`` [g] at ``t_s`` ``(P,)``; NaN where a design has none (unstable)."""

    f_hz: np.ndarray
    t_s: np.ndarray
    spectra: np.ndarray
    step: np.ndarray
    outputs: tuple[str, ...]
    units: dict[str, str]
    step_g: float


@dataclass(frozen=True)
class Room:
    """The designs of the room, one row each.

    ``table`` columns: ``source`` (its name), ``source_index`` (its place in ``sources``: a
    layout's seeds share a name), ``kind``, ``row``, the variables, objectives, constraints,
    load-case quantities, parts and damper valves' equivalent resistances
    (:func:`valve_columns`), the buildability verdict (``build_margin``, ``buildable`` and
    ``binding_rule``, :mod:`hisopt.studies.build_verdicts`: every rule, constrained or not),
    ``verified`` (a front design's verdict in the time domain from ``RUN_DIR/verify-N``,
    :mod:`hisopt.studies.verified`; ``""`` where not verified), ``feasible`` and ``front``
    (non-dominated among the feasible rows); ``groups`` says which
    of those each quantity column is (``variable``, ``objective``, ``constraint``, ``load
    case``, ``part``, ``valve``, ``build``) and ``units`` its SI unit.
    ``bounds`` per source the box of each variable; ``curves`` per row and ``baseline`` per
    source (its problem's baseline design); ``templates`` per source the problem file with
    ``{{name}}`` in place of each variable's value.
    """

    sources: list[Source]
    table: pd.DataFrame
    groups: dict[str, str]
    units: dict[str, str]
    objectives: list[str]
    bounds: dict[str, dict[str, tuple[float, float]]]
    curves: Curves
    baseline: dict[str, Curves]
    templates: dict[str, str]


# --- where the designs come from ---------------------------------------------------------------
def run_sources(run_dir: str | Path, max_rows: int = MAX_ROWS) -> list[Source]:
    """The designs of a run: its front, its refined front if any, then its other valid
    evaluations, latest first, up to ``max_rows`` in all (the front always whole)."""
    from hisopt.io import read_csv
    from hisopt.optim import rundir

    run_dir = Path(run_dir)
    record = rundir.run_record(run_dir)
    problem = rundir.load_run_problem(run_dir, record["problem"], check_original=False)
    names = list(problem.variable_names)
    parts = [(read_csv(run_dir / rundir.FRONT_CSV), "front")]
    parts += [(read_csv(path), "refined") for path in rundir.refined_fronts(run_dir)]  # each method's
    x = [frame[names].to_numpy(dtype=float) for frame, _ in parts]
    kind = [np.full(len(frame), k) for frame, k in parts]
    row = [np.arange(len(frame)) for frame, _ in parts]
    room = max(max_rows - sum(map(len, x)), 0)
    path = run_dir / rundir.EVALUATIONS
    if room and path.is_file():
        evaluated = pd.read_parquet(path)
        evaluated = evaluated[evaluated["valid"].to_numpy(dtype=bool)].sort_values("evaluation", ascending=False)
        seen = {tuple(v) for v in np.vstack(x)}  # a design once: the front's copy, else its latest evaluation
        keep: list[int] = []
        for i, v in enumerate(evaluated[names].to_numpy(dtype=float)):
            if len(keep) == room:
                break
            if tuple(v) not in seen:
                seen.add(tuple(v))
                keep.append(i)
        chosen = evaluated.iloc[keep].sort_values("evaluation")
        x.append(chosen[names].to_numpy(dtype=float))
        kind.append(np.full(len(chosen), "evaluated"))
        row.append(chosen["evaluation"].to_numpy(dtype=int))
    return [Source(problem.name, problem, np.vstack(x), np.concatenate(kind), np.concatenate(row), str(run_dir))]


def layout_sources(result: LayoutStudyResult, max_rows: int = MAX_ROWS) -> list[Source]:
    """The designs of a layout study: every layout's front in every seed (``<layout>/seed-<n>/
    front.csv``), one source each; when they hold more than ``max_rows`` designs, every k-th
    row of each (the same k for all, in file order)."""
    from hisopt.io import read_csv
    from hisopt.optim import rundir

    if result.out is None:
        raise RunError("the layout study has no directory to read its fronts from; pass out= to hisopt.compare_layouts")
    found = []
    for case in result.cases:
        seeds = sorted(int(s) for s in result.runs.loc[result.runs["layout"] == case.name, "seed"])
        for seed in seeds:
            folder = result.out / case.name / f"seed-{seed}"
            path = folder / rundir.FRONT_CSV
            if path.is_file():
                found.append((case, folder, read_csv(path)[list(case.problem.variable_names)].to_numpy(dtype=float)))
    stride = max(1, -(-sum(len(x) for _, _, x in found) // max_rows))
    return [
        Source(case.name, case.problem, x[::stride], np.full(len(x[::stride]), "front"), np.arange(len(x))[::stride], str(folder))
        for case, folder, x in found
        if len(x)
    ]


# --- what each design is -----------------------------------------------------------------------
def design_curves(problem: Problem, x: np.ndarray, f_hz: np.ndarray | None = None, method: str = "modal") -> Curves:
    """:class:`Curves` of designs ``x`` [SI] ``(n, n_var)`` of ``problem`` (with HIS) at
    frequencies ``f_hz`` [Hz] (default :data:`SPECTRUM_SAMPLES` log-spaced over its [band]).

    ``method``: ``"modal"`` the spectra from the channels the evaluator integrates
    (:meth:`hisopt.evaluation.evaluate.Evaluator.output_spectra`: poles and residues, the direct
    solve for a design whose form is not trusted and for distributed pipes) and the step
    response from the antisymmetric half of a model that is its own mirror image; ``"direct"``
    every design's spectra by direct solve of its dynamic stiffness and its step response from
    the full state space (the reference: the build before, several times slower). The step
    response is the pole-residue form's either way (:func:`hisopt.evaluation.transient.step_responses`).
    """
    if method not in CURVE_METHODS:
        raise ValueError(f"method must be one of {', '.join(CURVE_METHODS)}, got {method!r}")
    band = problem.spec.band
    f = np.geomspace(band.f_min_hz, band.f_max_hz, SPECTRUM_SAMPLES) if f_hz is None else np.asarray(f_hz, dtype=float)
    t = np.linspace(0.0, STEP_DURATION_S, STEP_SAMPLES)
    ev = Evaluator(problem)
    chosen = {name: ev.all_outputs[name] for name in SPECTRUM_OUTPUTS}
    step_g, gravity = problem.spec.handling.step_g, problem.spec.handling.gravity_moment
    spectra = np.full((len(x), f.size, len(SPECTRUM_OUTPUTS)), np.nan)
    step = np.full((len(x), t.size), np.nan)
    for start in range(0, len(x), CHUNK):
        part = slice(start, start + CHUNK)
        model = problem.model(x[part])
        grid = np.broadcast_to(f, (len(x[part]), f.size))
        if method == "direct":
            with np.errstate(all="ignore"):
                spectra[part] = ev.spectra(grid, DirectOutputs(model, chosen)(2 * np.pi * f[None, :]))
            step[part] = step_responses(model, model.car, t, step_g, gravity, halves=False)
            continue
        for rows, group in model.groups():  # one state space each (the valves a design shorts), realised once for both
            with np.errstate(all="ignore"):
                spectra[start + rows] = ev.output_spectra(group, SPECTRUM_OUTPUTS, grid[rows])
            step[start + rows] = step_responses(group, group.car, t, step_g, gravity)
    units = {name: psd_unit(chosen[name].unit) for name in SPECTRUM_OUTPUTS}
    return Curves(f, t, spectra, step, SPECTRUM_OUTPUTS, units, step_g)


def part_columns(problem: Problem, x: np.ndarray) -> dict[str, np.ndarray]:
    """[m] The cylinder bore and piston rod each design makes, per axle (``front bore``,
    ``front rod``; the rear's only where they differ from the front's): the listed sizes of a
    problem posed in parts, else those its ``dA`` and ``lam`` make
    (:func:`hisopt.hydraulics.laws.bore_and_rod`)."""
    his = problem.model(x).his
    assert his is not None  # a model with HIS
    params = his.params
    out: dict[str, np.ndarray] = {}
    for axle, suffix in (("front", ""), ("rear", "_rear")):
        if params.get(f"bore{suffix}") is not None:
            bore, rod = (np.broadcast_to(np.asarray(params[f"{p}{suffix}"], dtype=float), (len(x),)) for p in ("bore", "rod"))
        else:
            bore, rod = laws.bore_and_rod(np.asarray(params[f"dA{suffix}"], dtype=float), np.asarray(params[f"lam{suffix}"], dtype=float))
        out[f"{axle} bore"], out[f"{axle} rod"] = np.broadcast_to(bore, (len(x),)).copy(), np.broadcast_to(rod, (len(x),)).copy()
    if np.array_equal(out["rear bore"], out["front bore"]) and np.array_equal(out["rear rod"], out["front rod"]):
        del out["rear bore"], out["rear rod"]
    return out


def valve_columns(problem: Problem, x: np.ndarray) -> dict[str, np.ndarray]:
    """[Pa s m^-3] The equivalent resistance of each physical damper valve of designs ``x``
    [SI] ``(n, n_var)`` in each load case (:mod:`hisopt.studies.damper_valves`): ``"<valve>
    resistance"``, with ``@<scenario>`` in a problem with scenarios; NaN where the valves' RMS
    flows have no fixed point. None for a problem without damper valves. Above
    :data:`~hisopt.evaluation.valve_states.VALIDATED_RESISTANCE` a valve is outside the
    linearisation's validated range (the page marks it)."""
    from hisopt.studies import damper_valves

    if not damper_valves.has_damper_valves(problem):
        return {}
    out: dict[str, np.ndarray] = {}
    for case in damper_valves.load_case_valves(problem, x):
        at = f"@{case.name}" if problem.scenario_names else ""
        for j, label in enumerate(case.states.labels):
            out[f"{label} resistance{at}"] = case.states.resistance[:, j]
    return out


def problem_template(problem: Problem) -> str:
    """The problem file (TOML) of ``problem`` with ``{{name}}`` where each design variable's
    value goes: a design's values put in give the file ``hisopt evaluate`` reproduces it from
    (as :func:`hisopt.studies.design_sheet.write_problem` writes one)."""
    import tomli_w

    from hisopt.hydraulics.catalogue import layout_defaults
    from hisopt.specification.design_space import his_value_path
    from hisopt.studies.design_sheet import without_none

    data = without_none(problem.spec.model_dump(mode="json", by_alias=True))
    extra = layout_defaults(problem.spec.his)
    sentinels = {}
    for i, name in enumerate(problem.variable_names):
        path = his_value_path(data, extra, name)
        assert path is not None  # a variable is a [his] parameter (checked when the file was read)
        place = data
        for part in path[:-1]:
            place = place.setdefault(part, {})
        sentinels[name] = float(f"9.{i:03d}87654321e299")
        place[path[-1]] = sentinels[name]
    text = tomli_w.dumps(data)
    for name, value in sentinels.items():
        assert text.count(repr(value)) == 1, name
        text = text.replace(repr(value), "{{" + name + "}}")
    return text


# --- the room ------------------------------------------------------------------------------------
def decision_room_data(sources: Sequence[Source], method: str = "modal") -> Room:
    """Every quantity, part and curve of the designs of ``sources`` (:class:`Room`);
    ``method`` how the spectra are computed (:func:`design_curves`)."""
    if len(sources) > 255:
        raise ValueError(f"a room holds at most 255 sources (layouts times seeds), got {len(sources)}")
    frames: list[pd.DataFrame] = []
    curves: list[Curves] = []
    baseline: dict[str, Curves] = {}
    templates: dict[str, str] = {}
    bounds: dict[str, dict[str, tuple[float, float]]] = {}
    band = sources[0].problem.spec.band
    f_hz = np.geomspace(band.f_min_hz, band.f_max_hz, SPECTRUM_SAMPLES)  # one grid for all: the first source's band
    groups: dict[str, str] = {}
    units: dict[str, str] = {}
    objectives = list(sources[0].problem.objective_names)
    for source in sources:
        p = source.problem
        if list(p.objective_names) != objectives:
            raise ValueError(f"{source.name}: objectives {list(p.objective_names)} differ from {objectives}; a room compares designs in one set")
        q = p.evaluate(source.x, log=False)
        found = dict(q.attrs.get("units", {}))
        variables = {v: source.x[:, k] for k, v in enumerate(p.variable_names)}
        parts = {name: v for name, v in part_columns(p, source.x).items() if not any(np.array_equal(v, x) for x in variables.values())}  # not a variable again
        valves = valve_columns(p, source.x)
        kinds = [
            ("variable", list(p.variable_names)),
            ("objective", objectives),
            ("constraint", [c.name for c in p.spec.constraints if c.name in q.columns]),
            ("load case", [c for c in p.scenario_columns if c not in objectives]),
            ("part", list(parts)),
            ("valve", list(valves)),
        ]
        verdicts = run_verdicts(source.location or None, p, source.x)  # a run's front: as stored when it finished
        build = {BUILD_MARGIN: verdicts[BUILD_MARGIN].to_numpy(dtype=float)}
        kinds.append(("build", list(build)))
        own = {"part": (parts, "m"), "valve": (valves, "Pa s m^-3"), "build": (build, "-")}  # the columns not of the evaluator
        frame = pd.DataFrame({"source": source.name, "source_index": len(frames), "kind": source.kind, "row": source.row})
        for group, columns in kinds:
            for c in columns:
                groups.setdefault(c, group)
                units.setdefault(c, own[group][1] if group in own else found.get(c, ""))
                frame[c] = own[group][0][c] if group in own else q[c].to_numpy(dtype=float)
        frame[BUILDABLE] = verdicts[BUILDABLE].to_numpy(dtype=bool)
        frame[BINDING_RULE] = verdicts[BINDING_RULE].to_numpy(dtype=str)
        frame[VERIFIED] = front_verdicts(source.location or None, list(p.variable_names), source.x, source.kind, source.row)
        frame["feasible"] = q["feasible"].to_numpy(dtype=bool)
        frames.append(frame)
        curves.append(design_curves(p, source.x, f_hz, method))
        baseline[source.name] = design_curves(p, p.baseline[None, :], f_hz, method)
        templates[source.name] = problem_template(p)
        bounds[source.name] = {v: (float(lo), float(hi)) for v, lo, hi in zip(p.variable_names, p.lower, p.upper, strict=True)}
    table = pd.concat(frames, ignore_index=True)
    table["front"] = _front(table, objectives)
    first = curves[0]
    merged = Curves(
        first.f_hz, first.t_s, np.concatenate([c.spectra for c in curves]), np.concatenate([c.step for c in curves]), first.outputs, first.units, first.step_g
    )
    ordered = sorted(groups, key=lambda c: GROUPS.index(groups[c]))
    return Room(list(sources), table, {c: groups[c] for c in ordered}, {c: units[c] for c in ordered}, objectives, bounds, merged, baseline, templates)


def _front(table: pd.DataFrame, objectives: list[str]) -> np.ndarray:
    """[-] Rows non-dominated among the feasible rows with finite objectives."""
    f = table[objectives].to_numpy(dtype=float)
    usable = table["feasible"].to_numpy(dtype=bool) & np.all(np.isfinite(f), axis=1)
    out = np.zeros(len(table), dtype=bool)
    rows = np.flatnonzero(usable)
    out[rows[non_dominated_mask(f[rows])]] = True
    return out
