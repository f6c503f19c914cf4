"""Problem and design files read as text, with one clear line for what cannot be read.

:func:`read_file` reads a problem or design file as UTF-8 (a BOM is accepted) and says in
one line when the path is a directory, unreadable, a binary file or text in another
encoding (UTF-16 or UTF-32, as Windows editors save "Unicode" files); :func:`read_text`
gives its text alone.
"""

from __future__ import annotations

from pathlib import Path

from hisopt.errors import ConfigError, ProblemFileNotFoundError


def read_text(path: str | Path, what: str, missing_error: type[Exception] = ConfigError) -> str:
    """The UTF-8 text of a problem or design file (a BOM is dropped), or one clear error line
    (see :func:`read_file`)."""
    return read_file(path, what, missing_error)[1]


def _wide_encoding(raw: bytes) -> str | None:
    """``"UTF-16"`` or ``"UTF-32"`` (with the byte order) when ``raw`` is text in one of them,
    as Windows editors save "Unicode" files: by its byte-order mark, or without one by its
    NUL bytes (nearly every other byte, or three in four, never the text's own) in text that
    decodes."""
    import codecs

    marks = (
        (codecs.BOM_UTF32_LE, "UTF-32 (little-endian)"),
        (codecs.BOM_UTF32_BE, "UTF-32 (big-endian)"),
        (codecs.BOM_UTF16_LE, "UTF-16 (little-endian)"),
        (codecs.BOM_UTF16_BE, "UTF-16 (big-endian)"),
    )
    for mark, name in marks:  # UTF-32 first: its little-endian mark begins with UTF-16's
        if raw.startswith(mark):
            return name
    head = raw[:4096]
    for size, codec, name in (
        (4, "utf-32-le", "UTF-32 (little-endian)"),
        (4, "utf-32-be", "UTF-32 (big-endian)"),
        (2, "utf-16-le", "UTF-16 (little-endian)"),
        (2, "utf-16-be", "UTF-16 (big-endian)"),
    ):
        whole = head[: len(head) - len(head) % size]
        if len(whole) < 2 * size:
            continue
        zeros = [whole[i::size].count(0) for i in range(size)]
        text_at = 0 if codec.endswith("le") else size - 1  # where ASCII's one non-zero byte sits
        units = len(whole) // size  # mostly ASCII: its other bytes all but always zero (0.9 leaves room for accents, dashes)
        if zeros[text_at] == 0 and all(z >= 0.9 * units for i, z in enumerate(zeros) if i != text_at):
            try:
                whole.decode(codec)
            except UnicodeDecodeError:
                continue
            return name
    return None


def read_file(path: str | Path, what: str, missing_error: type[Exception] = ConfigError) -> tuple[bytes, str]:
    """The bytes and the UTF-8 text of a problem or design file (a BOM is dropped from the text).

    Parameters
    ----------
    path : str | Path
        [-] the file
    what : str
        [-] what the file should be, for the messages, e.g. ``"a TOML problem file"``
    missing_error : type[Exception], optional
        [-] the error type for a path that does not exist

    Raises
    ------
    ConfigError
        The path is a directory, unreadable, binary, or not UTF-8 (the byte's line and
        column are named).
    """
    path = Path(path)
    if path.is_dir():
        raise ConfigError(f"is a directory; expected {what}", file=str(path))
    if not path.exists():
        if missing_error is ProblemFileNotFoundError:
            raise ProblemFileNotFoundError(f"{path}: not found; expected {what}")
        raise ConfigError(f"not found; expected {what}", file=str(path))
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ConfigError(f"cannot read ({exc.strerror or exc}); expected {what}", file=str(path)) from None
    wide = _wide_encoding(raw)
    if wide:
        raise ConfigError(f"{wide} text; save it as UTF-8, expected {what}", file=str(path))
    if b"\x00" in raw[:8192]:
        raise ConfigError(f"binary data (NUL bytes); expected {what} as UTF-8 text", file=str(path))
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        column = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise ConfigError(
            f"not UTF-8 text (byte 0x{raw[exc.start]:02x} at line {line}, column {column}); save it as UTF-8, expected {what}",
            file=str(path),
        ) from None
    return raw, text.removeprefix("\ufeff")
