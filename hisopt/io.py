"""Atomic file output: write a temporary file in the same folder, fsync, then rename.

A crash, ``kill -9`` or an interrupt never leaves a half-written result behind; readers see
the old file or the new one.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import itertools
import json
import os
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

_UMASK: dict[str, int] = {}


def _umask() -> int:
    if "umask" not in _UMASK:
        current = os.umask(0o022)
        os.umask(current)
        _UMASK["umask"] = current
    return _UMASK["umask"]


def _fsync_path(path: str | Path, flags: int = os.O_RDONLY) -> None:
    # Not every platform allows opening (or fsyncing) a directory.
    with contextlib.suppress(OSError):
        fd = os.open(path, flags)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def atomic_write(path: str | Path, write: Callable[[str], None]) -> Path:
    """Call ``write(tmp_path)``, make it durable, then atomically move it to ``path``."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        write(tmp)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp creates 0600; honour the umask
        _fsync_path(tmp)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    _fsync_path(path.parent)  # makes the rename durable
    return path


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically."""

    def write(tmp: str) -> None:
        Path(tmp).write_bytes(data)

    return atomic_write(path, write)


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write UTF-8 ``text`` to ``path`` atomically."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_json(path: str | Path, data: dict[str, Any]) -> Path:
    """Write ``data`` as indented JSON to ``path`` atomically."""
    return atomic_write_text(path, json.dumps(data, indent=2, sort_keys=False, allow_nan=True) + "\n")


def write_csv(frame: pd.DataFrame, path: str | Path, units: Mapping[str, str] | None = None) -> Path:
    """CSV whose floats round-trip exactly (shortest decimals: ``0.1``), written atomically.

    Units (``units``, else ``frame.attrs["units"]``) go in a second header row, each in square
    brackets (``[Pa]``; ``[-]`` dimensionless, ``[]`` unknown), so that a spreadsheet shows
    them under the names; :func:`read_csv` recognises and strips that row.
    """
    units = dict(frame.attrs.get("units", {}) if units is None else units)
    text = frame.to_csv(index=False)
    if units:
        header, _, body = text.partition("\n")
        row = pd.DataFrame([[f"[{units.get(str(c), '')}]" for c in frame.columns]]).to_csv(index=False, header=False)
        text = header + "\n" + row + body
    return atomic_write_text(path, text)


def _is_units_row(cells: list[str]) -> bool:
    filled = [c.strip() for c in cells if c.strip()]
    return bool(filled) and all(c.startswith("[") and c.endswith("]") for c in filled)


def read_csv(path: str | Path, **kwargs: Any) -> pd.DataFrame:
    """Read a CSV written by :func:`write_csv` (or any plain CSV): floats exactly, units row
    (if any) moved to ``attrs["units"]``.

    ``kwargs`` go to :func:`pandas.read_csv`.

    Raises
    ------
    ProblemFileNotFoundError
        ``path`` does not exist (a :class:`FileNotFoundError` too).
    ConfigError
        ``path`` is a directory, or not a CSV pandas can read (a :class:`ValueError` too).
    """
    import csv

    from hisopt.errors import ConfigError, ProblemFileNotFoundError

    try:
        with open(path, encoding="utf-8", newline="") as handle:
            rows = list(itertools.islice(csv.reader(handle), 2))
    except FileNotFoundError:
        raise ProblemFileNotFoundError(f"{path}: not found; expected a CSV file") from None
    except IsADirectoryError:
        raise ConfigError("a directory; expected a CSV file", file=str(path)) from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"not UTF-8 text ({exc.reason} at byte {exc.start}); expected a CSV file", file=str(path)) from None
    has_units = len(rows) == 2 and _is_units_row(rows[1])
    try:
        frame = pd.read_csv(path, skiprows=[1] if has_units else None, **kwargs)
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise ConfigError(f"unreadable CSV ({str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__})", file=str(path)) from None
    if has_units:
        frame.attrs["units"] = {name: unit.strip()[1:-1] for name, unit in zip(rows[0], rows[1], strict=True) if unit.strip() not in ("", "[]")}
    return frame


def sha256_bytes(data: bytes) -> str:
    """Hex SHA-256 of ``data``."""
    return hashlib.sha256(data).hexdigest()


def ensure_writable_dir(path: str | Path) -> Path:
    """Create ``path`` if needed and check it is writable; ``RunError`` otherwise (before any work)."""
    from hisopt.errors import RunError

    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = tempfile.NamedTemporaryFile(dir=path, prefix=".write-test-", delete=True)
        probe.close()
    except OSError as exc:
        raise RunError(f"{path}: output directory is not writable ({exc.strerror or exc})") from None
    return path


def ensure_own_table(path: str | Path, columns: Sequence[str], what: str, option: str = "--out") -> Path:
    """Check before any work that ``path`` can be written as the table ``what`` with these
    ``columns``: a new file, or one whose header says it is that table (written before by the
    same command: it is written again). Nothing a user or another command made is written
    over (docs/model.md §8.5).

    Raises
    ------
    ConfigError
        ``path`` holds another file, or cannot be written (:func:`ensure_writable_file`).
    """
    from hisopt.errors import ConfigError

    path = ensure_writable_file(path, option)
    if path.exists():
        try:
            with path.open(encoding="utf-8", newline="") as handle:
                header = next(csv.reader(handle), [])
        except (OSError, UnicodeDecodeError):
            header = []
        if header != list(columns):
            raise ConfigError(f"{path} exists and is not {what} hisopt wrote; nothing is written over it: expected another --out name", key=option)
    return path


def ensure_writable_file(path: str | Path, option: str = "--out") -> Path:
    """Check before any work that ``path`` can be written as a file (its folder is created).

    Raises
    ------
    ConfigError
        ``path`` is a directory, or its folder cannot be created or written; the message
        names ``option`` and the path, never a temporary file.
    """
    from hisopt.errors import ConfigError

    path = Path(path)
    if path.is_dir():
        raise ConfigError(f"{path} is a directory; expected the path of a file to write", key=option)
    blocking = next((q for q in path.parents if q.exists() and not q.is_dir()), None)
    if blocking is not None:
        raise ConfigError(f"cannot write {path}: {blocking} is a file, not a folder", key=option)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        probe = tempfile.NamedTemporaryFile(dir=path.parent, prefix=".write-test-", delete=True)
        probe.close()
    except OSError as exc:
        raise ConfigError(f"cannot write {path} ({exc.strerror or exc}); expected a file in a writable folder", key=option) from None
    return path
