"""Output folders and their kinds: every folder a hisopt command writes knows what it is.

Each writing command owns one kind of folder (:data:`KINDS`). Before any work it *claims* its
``--out`` (:func:`claim`): a folder that does not exist yet, an empty one, or one of its own
kind is accepted (the same command on its own folder resumes or writes it again, as before);
a folder of another kind, or a non-empty folder hisopt did not write, is refused in one line
naming the option, the folder and what it is, and nothing on disk changes. Nothing is ever
written over what a user or another command made; ``--force`` is not needed: name a new folder.

A folder's kind is read from its record (:func:`folder_kind`):

- ``run.json`` (an optimisation run, :mod:`hisopt.optim.rundir`), ``study.json`` (a layout
  study) and ``synthesis.json`` (a topology synthesis): the records those commands keep anyway;
- :data:`MARKER` (``hisopt-folder.json``: the kind, the command and the hisopt version) for
  every other kind, written by :func:`claim` when the folder is claimed; a run gets one too,
  since its ``run.json`` is written only when its first generation begins (a run stopped
  before that is still a run, not a folder holding someone's ``problem.toml``);
- for a folder written before hisopt kept markers, the files that kind writes
  (``sweep_*.csv``, ``tolerance.csv``, ...).

The library functions behind the commands call :func:`claim` too (the check is written once),
so ``hisopt.optimize(out=...)``, ``compare_layouts(out=...)`` and the other writers refuse what
the command line refuses.
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from hisopt.errors import RunError
from hisopt.io import atomic_write_json
from hisopt.version import __version__

MARKER = "hisopt-folder.json"
"""The marker :func:`claim` writes (a kind without a record of its own, and a run before its ``run.json``): ``{"kind", "command", "hisopt", "created"}``."""
MARKER_FORMAT = "hisopt-folder/1"


@dataclass(frozen=True)
class FolderKind:
    """One kind of output folder.

    Attributes
    ----------
    name : str
        [-] the kind's key in :data:`KINDS` and in :data:`MARKER`
    what : str
        [-] what a person calls it, with its article ("an optimisation run")
    command : str
        [-] the command that writes it ("hisopt optimize")
    record : str
        [-] the file that marks it: its own record, or :data:`MARKER`
    legacy : tuple[str, ...]
        [-] glob patterns that together mark a folder of this kind written before markers:
        each must match (all the files the command writes, so that a user's folder holding
        one file of the same name is not taken for one)
    marked : bool
        [-] :func:`claim` writes :data:`MARKER` (every kind whose record is not written at once)
    """

    name: str
    what: str
    command: str
    record: str
    legacy: tuple[str, ...] = ()
    marked: bool = True


RUN, SEED_STUDY, LAYOUT_STUDY, SYNTHESIS = "run", "seed-study", "layout-study", "synthesis"
SWEEP, REGIONS, SHEET, TOLERANCE, SENSITIVITY, RESPONSE, DROPTEST = "sweep", "regions", "sheet", "tolerance", "sensitivity", "response", "droptest"
VERIFY = "verification"

KINDS: dict[str, FolderKind] = {
    kind.name: kind
    for kind in (
        FolderKind(RUN, "an optimisation run", "hisopt optimize", "run.json"),
        FolderKind(SEED_STUDY, "a seed study", "hisopt study", MARKER, ("seed-*/run.json", "front.csv", "runs.csv")),
        FolderKind(LAYOUT_STUDY, "a layout study", "hisopt compare-layouts", "study.json", marked=False),
        FolderKind(SYNTHESIS, "a topology synthesis", "hisopt synthesize", "synthesis.json", marked=False),
        FolderKind(SWEEP, "a sweep", "hisopt sweep", MARKER, ("sweep_*.csv", "sweep_*.html")),
        FolderKind(REGIONS, "a feasible-region study", "hisopt regions", MARKER, ("regions_*.csv", "regions_*.html")),
        FolderKind(SHEET, "a design sheet", "hisopt sheet", MARKER, ("sheet.toml", "sheet.md", "sheet.html")),
        FolderKind(TOLERANCE, "a tolerance study", "hisopt tolerance", MARKER, ("tolerance.csv", "violations.csv", "tolerance.html")),
        FolderKind(SENSITIVITY, "a sensitivity study", "hisopt sensitivity", MARKER, ("sensitivity.csv", "sensitivity.html")),
        FolderKind(RESPONSE, "a response study", "hisopt response", MARKER, ("response.csv", "response.html")),
        FolderKind(DROPTEST, "a drop test study", "hisopt droptest", MARKER, ("droptest.csv", "droptest.html")),
        FolderKind(VERIFY, "a time-domain verification", "hisopt verify", MARKER, ("verify.csv", "verify.json", "verify.html")),
    )
}
"""Every kind of folder a hisopt command writes, by name."""

OWN_TEMPORARIES = ".write-test"
"""Files hisopt's own writability probes may leave (and ``.*.tmp``, an atomic write cut short): not a user's."""


@dataclass(frozen=True)
class Found:
    """What :func:`folder_kind` found in a folder.

    Attributes
    ----------
    kind : FolderKind
        [-] the folder's kind
    evidence : str
        [-] the file that says so (its record, the marker, or a legacy folder's file)
    """

    kind: FolderKind
    evidence: str

    def describe(self, path: str | Path) -> str:
        """``"runs/paper is an optimisation run (run.json)"``."""
        return f"{path} is {self.kind.what} ({self.evidence})"


def _entries(path: Path) -> list[str]:
    """The names in ``path`` that someone put there (hisopt's writability probes aside)."""
    return sorted(p.name for p in path.iterdir() if not (p.name.startswith(OWN_TEMPORARIES) or (p.name.startswith(".") and p.name.endswith(".tmp"))))


def _marker_kind(path: Path) -> Found:
    """The kind :data:`MARKER` in ``path`` names; :class:`RunError` if it is unreadable."""
    marker = path / MARKER
    try:
        record = json.loads(marker.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise RunError(f"{marker}: unreadable ({exc}); {path} is a hisopt folder of unknown kind: name a new folder") from None
    name = record.get("kind") if isinstance(record, dict) else None
    if name not in KINDS:
        raise RunError(f"{marker}: unknown folder kind {name!r} (written by another hisopt version?); name a new folder")
    return Found(KINDS[name], MARKER)


def _is_layout_study(path: Path) -> bool:
    try:
        record = json.loads((path / KINDS[LAYOUT_STUDY].record).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(record, dict) and str(record.get("format", "")).startswith("hisopt-layout-study/")


def folder_kind(path: str | Path) -> Found | None:
    """The kind of the folder ``path`` (module docstring), or None: missing, empty, a file, or
    a folder hisopt did not write.

    Raises
    ------
    RunError
        ``path`` holds :data:`MARKER` but it is unreadable or names an unknown kind.
    """
    path = Path(path)
    if not path.is_dir():
        return None
    for name in (RUN, SYNTHESIS):  # their records, whatever else the folder holds
        if (path / KINDS[name].record).is_file():
            return Found(KINDS[name], KINDS[name].record)
    if _is_layout_study(path):
        return Found(KINDS[LAYOUT_STUDY], KINDS[LAYOUT_STUDY].record)
    if (path / MARKER).is_file():
        return _marker_kind(path)
    for kind in KINDS.values():
        hits = [next(iter(sorted(path.glob(pattern))), None) for pattern in kind.legacy]
        if hits and all(hit is not None for hit in hits):
            return Found(kind, " and ".join(str(hit.relative_to(path)) for hit in hits if hit is not None))
    return None


def check_claim(path: str | Path, kind: str, option: str = "--out") -> Found | None:
    """Refuse ``path`` as ``kind``'s output folder unless it is new, empty or of that kind;
    what it holds (None: new or empty). Reads only: nothing is created or written.

    Raises
    ------
    RunError
        ``path`` is a file, a folder of another kind, or a non-empty folder hisopt did not
        write; the message names ``option``, the folder and what it is.
    """
    own = KINDS[kind]
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise RunError(f"{option} {path} is a file; {own.what} ({own.command}) writes a folder: name a new one")
    blocking = next((q for q in path.parents if q.exists() and not q.is_dir()), None)
    if blocking is not None:
        raise RunError(f"{option} {path}: {blocking} is a file, not a folder; name a folder to write")
    found = folder_kind(path)
    if found is None:
        entries = _entries(path) if path.is_dir() else []
        if entries:
            shown = ", ".join(entries[:3]) + (", ..." if len(entries) > 3 else "")
            raise RunError(f"{option} {path} holds files hisopt did not write ({shown}); {own.what} writes its own folder: name a new or empty one")
        return None
    if found.kind.name != kind:
        raise RunError(f"{option} {found.describe(path)}; {own.what} writes its own folder: name a new one")
    return found


def claim(path: str | Path, kind: str, option: str = "--out") -> Path:
    """Make ``path`` ``kind``'s output folder, before any work (module docstring).

    Checks with :func:`check_claim`, then creates the folder, proves it writable and, for a
    kind that is :attr:`FolderKind.marked`, writes :data:`MARKER` (a folder of that kind
    written before markers gets one too). A refused claim creates and writes nothing.

    Parameters
    ----------
    path : str | Path
        [-] the folder
    kind : str
        [-] a key of :data:`KINDS`
    option : str, optional
        [-] the option that named it, for messages

    Returns
    -------
    Path
        ``path``

    Raises
    ------
    RunError
        As :func:`check_claim`, or the folder cannot be created or written.
    """
    path = Path(path)
    check_claim(path, kind, option)
    try:
        path.mkdir(parents=True, exist_ok=True)
        tempfile.NamedTemporaryFile(dir=path, prefix=".write-test-", delete=True).close()
        if KINDS[kind].marked and not (path / MARKER).is_file():
            record: dict[str, Any] = {"format": MARKER_FORMAT, "kind": kind, "command": KINDS[kind].command, "hisopt": __version__}
            atomic_write_json(path / MARKER, record | {"created": datetime.now(UTC).isoformat(timespec="seconds")})
    except OSError as exc:
        raise RunError(f"{option} {path}: the folder is not writable ({exc.strerror or exc}); name a writable folder") from None
    return path
