"""Atomic file output: write to a temporary file in the same folder, then rename.

A crash or an interrupt never leaves a half-written result behind; readers see the old file
or the new one.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path

import pandas as pd


def atomic_write(path: str | Path, write: Callable[[str], None]) -> Path:
    """Call ``write(tmp_path)`` then atomically move the result to ``path``."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the usual permissions
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


def write_csv(frame: pd.DataFrame, path: str | Path) -> Path:
    """CSV with full float precision (values round-trip exactly), written atomically."""
    return atomic_write(path, lambda tmp: frame.to_csv(tmp, index=False, float_format="%.17g"))


def write_text(text: str, path: str | Path) -> Path:
    """Text file written atomically."""
    return atomic_write(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


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
