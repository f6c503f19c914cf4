"""Run-directory input/output: atomic writes, the checkpoint format, problem copies.

Every file of a run directory is written atomically: the bytes go to a temporary file in
the same directory, which is flushed, ``fsync``-ed and moved over the target with
:func:`os.replace`. A reader (or a resumed run after ``SIGKILL``) therefore sees either the
previous complete file or the new complete file, never a torn one.

Checkpoint format (``checkpoint.npz``, one file, written after every generation): plain
numpy arrays (no pickles, loaded with ``allow_pickle=False``) plus one JSON document in the
0-d string array ``meta``. The arrays hold the algorithm's population (``pop_X``, ``pop_F``,
``pop_G`` and the survival attributes ``pop_rank`` ...), the archive (``archive_X``,
``archive_Q``, ``archive_id``), every evaluated design (``hist_X``, ``hist_Q``,
``hist_valid``, ``hist_gen``) and NSGA-III's normalisation state (``norm_*``); ``meta``
holds the generation counter, the random generator states as plain integers and lists,
the per-generation statistics and the settings.
"""

from __future__ import annotations

import contextlib
import io
import json

from pathlib import Path
from typing import Any

import numpy as np

from hisopt.errors import RunError
from hisopt.io import atomic_write_bytes, atomic_write_json, atomic_write_text, sha256_bytes  # noqa: F401 (re-exported)

CHECKPOINT = "checkpoint.npz"
RUN_JSON = "run.json"
FRONT_CSV = "front.csv"
EVALUATIONS = "evaluations.parquet"
EVALUATIONS_CSV = "evaluations.csv"
GENERATIONS_CSV = "generations.csv"
PROBLEM_TOML = "problem.toml"
PROBLEM_JSON = "problem.json"
CHECKPOINT_FORMAT = 1


def prepare_run_directory(run_dir: Path, *, fresh: bool) -> Path:
    """Create ``run_dir`` if needed and prove it writable before any work starts.

    Parameters
    ----------
    run_dir : [-] the run directory
    fresh : [-] True for a new run: refuse a directory that already holds a run

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
    payload = {"meta": np.array(json.dumps(meta | {"format": CHECKPOINT_FORMAT}))}
    payload.update({name: np.asarray(value) for name, value in arrays.items()})
    np.savez(buffer, **payload)
    atomic_write_bytes(path, buffer.getvalue())


def load_checkpoint(path: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Read a checkpoint written by :func:`save_checkpoint`: ``(meta, arrays)``.

    Raises
    ------
    RunError
        The file is missing, unreadable or of another format.
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
    if meta.get("format") != CHECKPOINT_FORMAT:
        raise RunError(f"{path}: checkpoint format {meta.get('format')!r}, expected {CHECKPOINT_FORMAT}")
    return meta, arrays


def checkpoint_generation(run_dir: Path) -> int:
    """[-] Generations completed according to ``run_dir``'s checkpoint (0 if none yet)."""
    path = Path(run_dir) / CHECKPOINT
    if not path.is_file():
        return 0
    meta, _ = load_checkpoint(path)
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
    name, keys, pos, has_gauss, cached = np.random.get_state()
    return {"name": name, "keys": keys.tolist(), "pos": int(pos), "has_gauss": int(has_gauss), "cached_gaussian": float(cached)}


def set_legacy_state(state: dict[str, Any]) -> None:
    """Restore the global numpy RNG from :func:`legacy_state`."""
    np.random.set_state(
        (state["name"], np.asarray(state["keys"], dtype=np.uint32), state["pos"], state["has_gauss"], state["cached_gaussian"])
    )
