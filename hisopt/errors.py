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
    """A problem file (or run directory) does not exist."""


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
