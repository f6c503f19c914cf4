"""Typed errors: every user mistake maps to one of these (all subclass builtins)."""

from __future__ import annotations


class HisoptError(Exception):
    """Base class of every error hisopt raises on purpose."""


class ConfigError(HisoptError, ValueError):
    """A problem file or parameter set is invalid.

    The message names the file (when there is one), the offending key and what was expected.
    """

    def __init__(self, message: str, *, file: str | None = None, key: str | None = None):
        self.file = file
        self.key = key
        self.detail = message  # the message without the file and key
        where = ": ".join(part for part in (file, key) if part)
        super().__init__(f"{where}: {message}" if where else message)


class ProblemFileNotFoundError(HisoptError, FileNotFoundError):
    """An input file (a problem file, a CSV, a measured record) or a run directory does not exist."""


class ModelError(HisoptError, ValueError):
    """The model cannot be built or solved for the given parameters (e.g. a singular circuit)."""


class RunError(HisoptError, ValueError):
    """A run directory is unusable (missing checkpoint, changed problem file, unwritable)."""


class PlausibilityWarning(UserWarning):
    """A value is physically possible but implausible (e.g. a precharge under 0.1 MPa): the
    work goes on with it as given (:mod:`hisopt.plausibility`; the CLI prints one
    ``warning: FILE: KEY: ...`` line).

    The message names the file (when there is one), the key and the physical reason.
    """

    def __init__(self, message: str, *, file: str | None = None, key: str | None = None):
        self.file = file
        self.key = key
        self.detail = message  # the message without the file and key
        where = ": ".join(part for part in (file, key) if part)
        super().__init__(f"{where}: {message}" if where else message)


def with_article(word: str | int) -> str:
    """``"an accumulator"``, ``"a valve"``, ``"an 8-design"`` for messages built from names
    and numbers (by sound: a vowel letter, or a number read aloud from eight, eleven or eighteen)."""
    text = str(word)
    digits = text.split("-")[0].split(" ")[0]
    if digits.isdigit():
        lead = digits[: len(digits) % 3 or 3].lstrip("0") or "0"  # the group read first: 8, 11, 18, 80-89, 800-899
        vowel = lead.startswith("8") or lead in ("11", "18")
    else:
        vowel = text[:1].lower() in tuple("aeio") or (text[:1].lower() == "u" and not text.lower().startswith(("uni", "use", "usu", "uti")))
    return f"{'an' if vowel else 'a'} {text}"
