"""Run directories: their layout, atomic writes, the checkpoint, the problem copy and the
resume rule. One module owns them; runs, refinement, studies and reports go through it.

Run directory files (all written atomically):

- ``run.json``: status, settings, versions, the problem file's SHA-256 and text, sessions
  with timings, and (when finished) a result summary;
- ``problem.toml`` (or ``problem.json`` for a problem not read unchanged from a file): the
  run's own copy of the problem;
- ``checkpoint.npz``: written every 10 s of wall time, at the end and on Ctrl-C/SIGTERM
  (:data:`hisopt.optim.run.CHECKPOINT_INTERVAL_S`);
- ``history/<first evaluation>.npz``: the evaluations, one append-only chunk per checkpoint
  (the evaluations since the previous one), named in the checkpoint;
- ``front.csv``: the archive's non-dominated feasible designs: variables, objectives,
  constraint quantities, physical units, shortest round-trip decimals and a units row
  (:func:`hisopt.io.write_csv`; read it back with :func:`hisopt.io.read_csv`);
- ``front_refined.csv`` and ``refine.json`` (``hisopt refine``, SLP), ``front_refined_ipopt.csv``
  and ``refine_ipopt.json`` (``--method ipopt``): each method its own files (:data:`REFINED_FILES`);
- ``front_thinned.csv`` (a run with epsilon tolerances only): the thinned front
  (:mod:`hisopt.optim.thinning`), ``front.csv``'s columns and format, a subset of its rows;
- ``evaluations.parquet``: every evaluated design
  with its generation, quantities, ``valid`` and ``feasible``;
- ``generations.csv``: per-generation statistics (evaluations, feasible share, front
  size, hypervolume).

Resume rule for the problem file: :func:`resume` loads the run's own copy. It refuses
(:class:`~hisopt.errors.RunError`) when the copy's SHA-256 differs from the one in
``run.json`` (the copy was edited) or when the original problem file recorded in
``run.json`` still exists and its SHA-256 differs (the problem changed since the run
started: resuming would mix two problems). A moved or deleted original is not an error.
Resume also refuses a checkpoint written by another pymoo version.

Run-directory input/output: atomic writes, the checkpoint format, problem copies.

Every file of a run directory is written atomically: the bytes go to a temporary file in
the same directory, which is flushed, ``fsync``-ed and moved over the target with
:func:`os.replace`. A reader (or a resumed run after ``SIGKILL``) therefore sees either the
previous complete file or the new complete file, never a torn one.

Checkpoint format 2 (``checkpoint.npz``, one file, rewritten at each checkpoint): plain
numpy arrays (no pickles, loaded with ``allow_pickle=False``) plus one JSON document in the
0-d string array ``meta``. The arrays hold the algorithm's population (``pop_X``, ``pop_F``,
``pop_G`` and the survival attributes ``pop_rank`` ...), the archive (``archive_x``,
``archive_q``, ``archive_ids``), the progress hypervolume's state (``progress_rho``) and
NSGA-III's normalisation state (``norm_*``); ``meta`` holds the generation counter, the
random generator states as plain integers and lists, the per-generation statistics, the
settings and ``history_chunks``: the chunk files (``history/<first evaluation>.npz``, each
``hist_x``, ``hist_q``, ``hist_valid``, ``hist_gen`` of the evaluations written since the
previous checkpoint) that together hold every evaluated design. A checkpoint's cost grows
with the archive and the population, not with the number of evaluations. Format 1 (every
evaluation inside ``checkpoint.npz``) is still read.
"""

from __future__ import annotations

import contextlib
import io
import json
import platform
import sys
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

import hisopt.interrupt as interrupt
from hisopt.errors import ConfigError, RunError
from hisopt.io import atomic_write_bytes, atomic_write_json, read_csv, sha256_bytes, write_csv
from hisopt.plausibility import with_bound_column, without_bound_column

if TYPE_CHECKING:
    from hisopt.optim.results import OptimizationResult
    from hisopt.problem import Problem

CHECKPOINT = "checkpoint.npz"
RUN_JSON = "run.json"
FRONT_CSV = "front.csv"
EVALUATIONS = "evaluations.parquet"
GENERATIONS_CSV = "generations.csv"
PROBLEM_TOML = "problem.toml"
PROBLEM_JSON = "problem.json"
FRONT_THINNED_CSV = "front_thinned.csv"
"""Thinned front (a run with epsilon tolerances): ``front.csv``'s columns, a subset of its rows."""
CONTINUOUS_FRONT_CSV = "continuous_front.csv"
"""The continuous relaxation's front (a run of a problem with choices, docs/model.md §17.5): ``front.csv``'s columns."""
FRONT_REFINED_CSV = "front_refined.csv"
"""Refined front (``hisopt refine``, SLP): ``front.csv``'s columns plus ``source_index``."""
REFINE_JSON = "refine.json"
"""Summary of the refinement (settings, hypervolumes, timing, per point)."""
REFINED_FILES = {"slp": (FRONT_REFINED_CSV, REFINE_JSON), "ipopt": ("front_refined_ipopt.csv", "refine_ipopt.json")}
"""Refinement method -> (refined front, summary): a second method never writes over the first's files."""
LAYOUT_STUDY_JSON = "study.json"
"""The record of a layout study directory (:mod:`hisopt.studies.layout_study`, whose runs are
run directories one level down): named here so that a run command given such a folder says so."""
SYNTHESIS_JSON = "synthesis.json"
"""The record of a topology synthesis (:mod:`hisopt.studies.synthesis`), named here for the same reason."""
CHECKPOINT_FORMAT = 2
READABLE_FORMATS = (1, 2)
HISTORY_DIR = "history"
"""Folder of the history chunks (checkpoint format 2)."""
HISTORY_FIELDS = ("hist_x", "hist_q", "hist_valid", "hist_gen")


@dataclass
class RunDirectory:
    """A run's directory together with its ``run.json`` record: a run keeps both or neither
    (an in-memory run has no :class:`RunDirectory`).

    Attributes
    ----------
    path : Path
        the run directory
    info : dict
        the ``run.json`` document, updated in place and written back atomically
    """

    path: Path
    info: dict[str, Any]

    def write_info(self) -> None:
        """Write ``info`` to ``path/run.json`` (atomically)."""
        atomic_write_json(self.path / RUN_JSON, self.info)


def prepare_run_directory(run_dir: Path, *, fresh: bool) -> Path:
    """Create ``run_dir`` if needed and prove it writable before any work starts.

    Parameters
    ----------
    run_dir : Path
        [-] the run directory
    fresh : bool
        [-] True for a new run: refuse a directory that already holds a run

    Raises
    ------
    RunError
        The directory cannot be created or written, or (``fresh``) already holds a run.
    """
    run_dir = Path(run_dir)
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RunError(f"cannot create run directory {run_dir}: {exc.strerror or exc}; choose a writable --out") from None
    if not run_dir.is_dir():
        raise RunError(f"run directory {run_dir} is not a directory; choose another --out")
    if fresh and (run_dir / RUN_JSON).exists():  # hisopt.optim.runstate.refuse_occupied says more, first
        raise RunError(f"--out {run_dir} already holds a run; continue it with `hisopt resume {run_dir}`, or choose another --out")
    if not fresh:  # temporary files of a write that a kill cut short
        for stale in run_dir.glob(".*.tmp"):
            with contextlib.suppress(OSError):
                stale.unlink()
    try:
        atomic_write_bytes(run_dir / ".write-test", b"ok\n")
        (run_dir / ".write-test").unlink()
    except OSError as exc:
        raise RunError(f"cannot write to run directory {run_dir}: {exc.strerror or exc}; choose a writable --out") from None
    return run_dir


def save_checkpoint(path: Path, meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
    """Write a checkpoint (``arrays`` plus the JSON ``meta``) atomically to ``path``."""
    buffer = io.BytesIO()
    payload: dict[str, Any] = {"meta": np.array(json.dumps(meta | {"format": CHECKPOINT_FORMAT}))}
    payload.update({name: np.asarray(value) for name, value in arrays.items()})
    np.savez(buffer, **payload)
    atomic_write_bytes(path, buffer.getvalue())


def save_history_chunk(run_dir: Path, first: int, parts: tuple[np.ndarray, ...]) -> dict[str, Any]:
    """Write evaluations ``first, first + 1, ...`` (``x, q, valid, generation``) as a history
    chunk (atomically); the record the checkpoint lists it by."""
    name = f"{HISTORY_DIR}/{first:012d}.npz"
    (Path(run_dir) / HISTORY_DIR).mkdir(exist_ok=True)
    buffer = io.BytesIO()
    np.savez(buffer, **dict(zip(HISTORY_FIELDS, parts, strict=True)))  # type: ignore[arg-type]
    atomic_write_bytes(Path(run_dir) / name, buffer.getvalue())
    return {"file": name, "first": int(first), "rows": int(len(parts[0]))}


def load_checkpoint(path: Path, *, history: bool = True) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Read a checkpoint written by :func:`save_checkpoint`: ``(meta, arrays)``, the arrays
    with the evaluations of its history chunks joined (``hist_*``; ``history=False``: without).

    Raises
    ------
    RunError
        The file or a chunk it names is missing, unreadable or of another format.
    """
    path = Path(path)
    if not path.is_file():
        raise RunError(f"{path}: checkpoint not found")
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
    except (OSError, ValueError) as exc:
        raise RunError(f"{path}: unreadable checkpoint ({exc})") from None
    meta = json.loads(str(arrays.pop("meta")))
    if meta.get("format") not in READABLE_FORMATS:
        raise RunError(f"{path}: checkpoint format {meta.get('format')!r}, expected {CHECKPOINT_FORMAT}")
    if history and meta.get("format") == 2:
        parts: list[dict[str, np.ndarray]] = []
        expected = 0
        for record in meta.get("history_chunks", []):
            chunk = path.parent / record["file"]
            try:
                with np.load(chunk, allow_pickle=False) as data:
                    parts.append({name: data[name] for name in HISTORY_FIELDS})
            except (OSError, ValueError, KeyError) as exc:
                raise RunError(f"{chunk}: unreadable history chunk ({exc}); start over with another --out") from None
            if record["first"] != expected or len(parts[-1]["hist_x"]) != record["rows"]:
                raise RunError(f"{chunk}: not the history chunk {path.name} names; start over with another --out")
            expected += record["rows"]
        if parts:
            arrays |= {name: np.concatenate([p[name] for p in parts]) for name in HISTORY_FIELDS}
        elif "archive_q" in arrays:  # a run's checkpoint before its first chunk
            n_var = arrays["pop_X"].shape[1] if "pop_X" in arrays else 0
            arrays |= {
                "hist_x": np.empty((0, n_var)),
                "hist_q": np.empty((0, arrays["archive_q"].shape[1])),
                "hist_valid": np.empty(0, dtype=bool),
                "hist_gen": np.empty(0, dtype=np.int64),
            }
    return meta, arrays


def checkpoint_generation(run_dir: Path) -> int:
    """[-] Generations completed according to ``run_dir``'s checkpoint (0 if none yet)."""
    path = Path(run_dir) / CHECKPOINT
    if not path.is_file():
        return 0
    meta, _ = load_checkpoint(path, history=False)
    return int(meta["generation"])


def generator_state(rng: np.random.Generator) -> dict[str, Any]:
    """A JSON-ready copy of a numpy ``Generator``'s bit-generator state (plain ints)."""
    return json.loads(json.dumps(rng.bit_generator.state))


def set_generator_state(rng: np.random.Generator, state: dict[str, Any]) -> None:
    """Restore a state from :func:`generator_state` into ``rng`` (same bit generator)."""
    if state.get("bit_generator") != type(rng.bit_generator).__name__:
        raise RunError(f"checkpoint holds a {state.get('bit_generator')} state, expected {type(rng.bit_generator).__name__}")
    rng.bit_generator.state = state


def legacy_state() -> dict[str, Any]:
    """The global numpy RNG state (``np.random.get_state()``) as plain lists and ints."""
    name, keys, pos, has_gauss, cached = np.random.get_state(legacy=True)
    return {"name": name, "keys": np.asarray(keys).tolist(), "pos": int(pos), "has_gauss": int(has_gauss), "cached_gaussian": float(cached)}


def set_legacy_state(state: dict[str, Any]) -> None:
    """Restore the global numpy RNG from :func:`legacy_state`."""
    np.random.set_state((state["name"], np.asarray(state["keys"], dtype=np.uint32), state["pos"], state["has_gauss"], state["cached_gaussian"]))


# --- reading a run directory -----------------------------------------------------------------
def read_run_json(run_dir: Path) -> dict[str, Any]:
    """``run_dir/run.json``; :class:`RunError` saying what to do when it is missing or unreadable."""
    run_dir = Path(run_dir)
    path = run_dir / RUN_JSON
    if run_dir.is_file():
        raise RunError(f"{run_dir}: a file, not a run directory; expected the --out directory of `hisopt optimize`")
    if not run_dir.is_dir():
        raise RunError(f"{run_dir}: not a run directory (not found); expected the --out directory of `hisopt optimize`")
    if not path.is_file() and (run_dir / LAYOUT_STUDY_JSON).is_file():
        raise RunError(
            f"{run_dir}: a layout study (`hisopt compare-layouts`), not a run; `hisopt status {run_dir}` summarises "
            f"it, `hisopt report {run_dir}` writes its report, and its runs are {run_dir}/<layout>/seed-<n>"
        )
    if not path.is_file() and (run_dir / SYNTHESIS_JSON).is_file():
        raise RunError(
            f"{run_dir}: a topology synthesis (`hisopt synthesize`), not a run; the same command resumes it, its report is "
            f"{run_dir}/report.html and its layout study {run_dir}/study (`hisopt status` and `hisopt report` take that)"
        )
    if not path.is_file():
        from hisopt.folders import RUN, folder_kind

        found = folder_kind(run_dir)
        if found is not None and found.kind.name != RUN:
            raise RunError(f"{found.describe(run_dir)}, written by `{found.kind.command}`, not a run; expected the --out directory of `hisopt optimize`")
        if any((run_dir / name).is_file() for name in (PROBLEM_TOML, PROBLEM_JSON)):
            raise RunError(f"{run_dir}: the run never started (no {RUN_JSON}); start it again with `hisopt optimize PROBLEM --out {run_dir}`")
        raise RunError(f"{run_dir}: not a run directory (no {RUN_JSON}); start a run with `hisopt optimize`")
    try:
        info = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise RunError(f"{path}: unreadable ({exc}); start over with another --out") from None
    if not isinstance(info, dict):
        raise RunError(f"{path}: not a hisopt run record; start over with another --out")
    return info


def refined_files(method: str) -> tuple[str, str]:
    """``(refined front, summary)`` file names of refinement ``method`` (:data:`REFINED_FILES`)."""
    return REFINED_FILES.get(method, (f"front_refined_{method}.csv", f"refine_{method}.json"))


def refined_fronts(run_dir: str | Path) -> list[Path]:
    """The refined fronts a run holds, one per refinement method, SLP's first."""
    return [Path(run_dir) / front for front, _ in REFINED_FILES.values() if (Path(run_dir) / front).is_file()]


def run_record(run_dir: Path) -> dict[str, Any]:
    """``run_dir/run.json`` of a run that started: :func:`read_run_json`, and a
    :class:`RunError` when the record lacks its problem (an empty ``{}`` or another file)."""
    info = read_run_json(run_dir)
    if not isinstance(info.get("problem"), dict):
        raise RunError(f"{Path(run_dir) / RUN_JSON}: lacks 'problem', so not the record of a run that started; start over with another --out")
    return info


def read_front(path: str | Path) -> pd.DataFrame:
    """A ``front.csv`` (full precision; the values round-trip), without its ``on_bound`` marks
    (derived from the values and the box: written again with every front)."""
    path = Path(path)
    if not path.is_file():
        raise RunError(f"{path}: front not found; expected a run directory with {path.name}")
    try:
        front = read_csv(path)
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise RunError(f"{path}: unreadable front ({exc})") from None
    return without_bound_column(front)


def run_problem(run_dir: Path) -> tuple[Problem, np.ndarray | None]:
    """The problem of a run directory and its recorded hypervolume reference point.

    Reads ``run.json`` and the run's problem copy (:func:`load_run_problem`, which refuses an
    edited copy or a changed original); a directory with only a ``problem.toml`` (a run that
    never started) gives that problem and no reference point.
    """
    run_dir = Path(run_dir)
    if not (run_dir / RUN_JSON).is_file() and (run_dir / PROBLEM_TOML).is_file():
        from hisopt.problem import load_problem

        return load_problem(run_dir / PROBLEM_TOML, warn_implausible=False), None  # a run's copy
    info = run_record(run_dir)
    reference = info.get("settings", {}).get("hypervolume_reference_log10")
    return load_run_problem(run_dir, info["problem"]), None if reference is None else np.asarray(reference, dtype=float)


# --- run.json, the problem copy, the outputs ------------------------------------------------
def now() -> str:
    """The current UTC time as ``run.json`` records it."""
    return datetime.now(UTC).isoformat(timespec="seconds")


def versions() -> dict[str, str]:
    """Versions of hisopt, Python and the numerical stack (recorded in ``run.json``)."""
    import pymoo
    import scipy

    from hisopt.version import __version__

    return {
        "hisopt": __version__,
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "pandas": pd.__version__,
        "pymoo": pymoo.__version__,
        "platform": platform.platform(),
    }


def problem_copy(problem: Problem) -> tuple[str, bytes, dict[str, Any]]:
    """The run's copy of the problem: ``(file name, bytes, run.json record)``.

    The problem file itself (``problem.toml``) when the problem was loaded from a file that
    is unchanged and unmodified since (``Problem.sha256`` matches and the file parses to the
    same specification); otherwise the specification as JSON (``problem.json``), e.g. for
    :func:`~hisopt.problem.problem_from_dict` or ``Problem.with_values``.
    """
    from hisopt.specification.catalogues import catalogue_names
    from hisopt.specification.config import parse_problem

    path = problem.path
    if path is not None and problem.sha256 is not None and Path(path).is_file():
        raw = Path(path).read_bytes()
        if sha256_bytes(raw) == problem.sha256:
            import tomllib

            try:
                same = parse_problem(tomllib.loads(raw.decode("utf-8")), str(path), warn_implausible=False) == problem.spec
            except (ConfigError, tomllib.TOMLDecodeError, UnicodeDecodeError):
                same = False
            # a catalogue file beside the problem is not beside its copy: the JSON holds its values
            same = same and not any(v.catalogue is not None and v.catalogue not in catalogue_names() for v in problem.spec.variables.values())
            if same:
                record: dict[str, Any] = {
                    "name": problem.name,
                    "path": str(Path(path).resolve()),
                    "sha256": problem.sha256,
                    "copy": PROBLEM_TOML,
                    "text": raw.decode("utf-8"),
                }
                return PROBLEM_TOML, raw, record
    text = json.dumps(problem.spec.model_dump(mode="json", by_alias=True), indent=2) + "\n"
    raw = text.encode("utf-8")
    record = {
        "name": problem.name,
        "path": None,
        "derived_from": None if path is None else str(Path(path).resolve()),
        "sha256": sha256_bytes(raw),
        "copy": PROBLEM_JSON,
        "text": text,
    }
    return PROBLEM_JSON, raw, record


def load_run_problem(run_dir: Path, record: dict[str, Any], check_original: bool = True) -> Problem:
    """The problem of a run from its own copy, after the checks of the module's resume rule
    (``check_original=False``: only the copy's own checksum, e.g. for a report).

    Raises
    ------
    RunError
        The copy is missing or edited, or the original problem file has changed.
    """
    from hisopt.problem import load_problem, problem_from_dict

    copy = run_dir / str(record.get("copy", ""))
    if not copy.is_file():
        raise RunError(f"{copy}: the run's copy of its problem is missing")
    digest = sha256_bytes(copy.read_bytes())
    if digest != record["sha256"]:
        raise RunError(
            f"{copy} was edited since the run started (sha256 {record['sha256'][:12]} -> {digest[:12]}); restore it or start a new run with `hisopt optimize`"
        )
    original = record.get("path")
    if check_original and original and Path(original).is_file():
        now = sha256_bytes(Path(original).read_bytes())
        if now != record["sha256"]:
            raise RunError(
                f"{original} changed since the run started (sha256 {record['sha256'][:12]} -> {now[:12]}); "
                "resuming would mix two problems: restore the file or start a new run with `hisopt optimize`"
            )
    # the run's problem warned when the run started; its copy does not warn again
    if copy.suffix == ".toml":
        return load_problem(copy, warn_implausible=False)
    return problem_from_dict(json.loads(copy.read_text(encoding="utf-8")), str(copy), warn_implausible=False)


def _summary(result: OptimizationResult) -> dict[str, Any]:
    out: dict[str, Any] = {
        "generations": int(len(result.generations)),
        "evaluations": int(len(result.history)),
        "front_size": int(len(result.front)),
        **({} if result.thinned is None else {"thinned_front_size": int(len(result.thinned))}),
        "hypervolume": result.hypervolume,
        "completed": result.completed,
        "stop": result.stop_record(),
        "hypervolume_history": [{"evaluations": e, "hypervolume": h} for e, h in result.hypervolume_history()],
    }
    if result.catalogue_cost is not None:
        out["catalogue_cost"] = result.catalogue_cost.record()
    if len(result.front):
        out["knee"] = {k: float(v) for k, v in result.knee.items()}
        out["asf_pick"] = {k: float(v) for k, v in result.asf_pick().items()}
    return out


def write_outputs(run_dir: Path, result: OptimizationResult) -> None:
    """``front.csv`` (with its ``on_bound`` marks), ``front_thinned.csv`` (with tolerances),
    the evaluations and ``generations.csv`` (each atomically)."""
    write_csv(with_bound_column(result.front, result.problem), run_dir / FRONT_CSV)
    if result.thinned is not None:
        write_csv(with_bound_column(result.thinned, result.problem), run_dir / FRONT_THINNED_CSV)
    if result.continuous_front is not None:
        write_csv(with_bound_column(result.continuous_front, result.problem), run_dir / CONTINUOUS_FRONT_CSV)
    interrupt.hook_point("final-write")
    write_csv(result.generations, run_dir / GENERATIONS_CSV)
    buffer = io.BytesIO()
    result.history.to_parquet(buffer, index=False)  # pyarrow, a declared dependency
    atomic_write_bytes(run_dir / EVALUATIONS, buffer.getvalue())


def update_run_json(
    run_dir: Path, info: dict[str, Any], session: dict[str, Any], status: str, result: OptimizationResult, session_s: float, evaluation_s: float
) -> None:
    """Record ``status``, the session's end, the timings and the result summary in ``run.json``."""
    info["status"] = status
    if status == "finished":
        info.pop("failure", None)
    session |= {
        "ended": now(),
        "status": status,
        "end_generation": int(len(result.generations)),
        "wall_time_s": session_s,
    }
    info["timings"] = {"wall_time_s": result.wall_time_s, "evaluation_s": evaluation_s}
    info["result"] = _summary(result)
    atomic_write_json(run_dir / RUN_JSON, info)
