"""Command-line usage errors as one line, whichever typer (and click) parsed the command.

typer 0.29 carries its own copy of click (``typer._click``), exception classes included;
older typer raises click's own. Both keep click's interface, so a usage error is recognised
by what it carries (``exit_code`` 2, ``format_message()``, ``param``, ``option_name``,
``ctx``), never by where its class lives. Option values are parsed here too, so that their
messages are ours (``expected an integer, got 'abc'``) and not the parser's of the day.
"""

from __future__ import annotations

import ast
import contextlib
import difflib
import importlib.util
import re
import warnings
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Annotated, Any

import typer

# Option names at least this similar to a mistyped one are offered as "did you mean".
_CLOSE_MATCH = 0.75


def integer(text: str) -> int:
    """Option value: an integer (``typer.Option(parser=integer)``)."""
    try:
        return int(text)
    except (TypeError, ValueError):
        raise typer.BadParameter(f"expected an integer, got {text!r}") from None


def quantity(unit: str) -> Callable[[str], float]:
    """Option value parser: a number in the SI unit ``unit`` (``0.05``) or with its own unit
    (``"5 cm"``), converted to SI (:func:`hisopt.quantities.to_si`)."""

    def parse(text: str) -> float:
        from hisopt.errors import ConfigError
        from hisopt.quantities import to_si

        try:
            return to_si(text, unit)
        except ConfigError as exc:
            raise typer.BadParameter(exc.detail) from None

    return parse


def scalar_fields(module: str, model: str) -> tuple[str, ...]:
    """The scalar fields of the pydantic model ``module.model``, in declaration order, read
    from its source (``ast``): ``--help`` names them without importing the model, which would
    import numpy.

    A field is scalar unless its annotation names a ``dict``, a ``list`` or a class (a
    sub-table: a class defined in ``module`` or imported into it from another module); numbers,
    strings, booleans and ``Literal`` aliases are scalar. tests/test_cli.py checks the result
    against the imported model's fields.
    """
    tree = ast.parse(_source(module))
    classes = {node.name for node in tree.body if isinstance(node, ast.ClassDef)}
    imported = {
        alias.asname or alias.name: (node.module, alias.name)
        for node in tree.body
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0
        for alias in node.names
    }

    def is_table(annotation: ast.expr) -> bool:
        for node in ast.walk(annotation):
            if isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name) and node.value.id in ("dict", "list"):
                return True
            if isinstance(node, ast.Name) and node.id in classes:
                return True
            if isinstance(node, ast.Name) and node.id in imported:
                # A top-level class starts a line with "class Name"; a regex is a hundred
                # times quicker than parsing the module (network.py) for it.
                source, name = imported[node.id]
                if re.search(rf"^class {re.escape(name)}\b", _source(source), re.MULTILINE):
                    return True
        return False

    body = next(node for node in tree.body if isinstance(node, ast.ClassDef) and node.name == model).body
    return tuple(node.target.id for node in body if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and not is_table(node.annotation))


def _source(module: str) -> str:
    spec = importlib.util.find_spec(module)
    if spec is None or spec.origin is None:
        raise ModuleNotFoundError(module)
    return Path(spec.origin).read_text(encoding="utf-8")


# Option types several commands share (the hisopt.cli command modules).
ProblemArg = Annotated[Path, typer.Argument(metavar="PROBLEM", help="problem file (TOML), e.g. problems/roll_plane_his.toml")]
WorkersOpt = Annotated[
    int | None,
    typer.Option("--workers", parser=integer, metavar="N", help="start a local Dask cluster with N worker processes"),
]
SchedulerOpt = Annotated[
    str | None,
    typer.Option("--scheduler", metavar="ADDRESS", help="address of an existing Dask scheduler, e.g. tcp://host:8786"),
]


def is_usage_error(exc: BaseException) -> bool:
    """True for click's (or typer's copy of click's) ``UsageError`` and its subclasses."""
    return (
        getattr(exc, "exit_code", None) == 2
        and callable(getattr(exc, "format_message", None))
        and any(cls.__name__ == "UsageError" for cls in type(exc).__mro__)
    )


def usage_error_line(exc: BaseException, args: Sequence[str]) -> str | None:
    """The one-line message for a command-line usage error, or None if ``exc`` is not one.

    Parameters
    ----------
    exc
        The exception the command-line parser raised.
    args
        [-] The command-line arguments (without the program name), to name an unknown command.

    Returns
    -------
    str or None
        E.g. ``--pop: expected an integer, got 'abc'``, ``no such option --bogus; ...``,
        ``missing argument PROBLEM``, ``no such command 'bogus'; expected one of ...``.
    """
    if not is_usage_error(exc):
        return None
    kinds = {cls.__name__ for cls in type(exc).__mro__}
    ctx = getattr(exc, "ctx", None)
    param = getattr(exc, "param", None)
    path = getattr(ctx, "command_path", None)
    hint = f"; see `{path} --help`" if path else ""
    option = str(getattr(exc, "option_name", "") or "")
    if "NoSuchOption" in kinds:
        close = [p for p in getattr(exc, "possibilities", None) or () if _similarity(option, p) >= _CLOSE_MATCH]
        return f"no such option {option}" + (f"; did you mean {' or '.join(sorted(close))}?" if close else hint)
    if "MissingParameter" in kinds and param is not None:
        kind = getattr(param, "param_type_name", "parameter")
        return f"missing {kind} {_label(param)}"
    if "BadParameter" in kinds:
        label = _label(param) if param is not None else _hint_label(getattr(exc, "param_hint", None))
        message = _one_line(str(getattr(exc, "message", exc)))
        return f"{label}: {message}" if label else f"invalid value: {message}"
    message = _one_line(exc.format_message()).rstrip(".")  # type: ignore[attr-defined]
    if "BadOptionUsage" in kinds and option and "requires" in message:  # `--pop` with no value
        return f"{option}: expected a value"
    unknown = _unknown_command(ctx, args)
    if unknown is not None:
        return unknown
    return message + hint


def _label(param: Any) -> str:
    """``--pop`` for an option, ``PROBLEM`` for an argument."""
    if getattr(param, "param_type_name", "") == "argument":
        return str(getattr(param, "metavar", None) or str(param.name).upper())
    opts = sorted(getattr(param, "opts", ()) or (), key=len)
    return opts[-1] if opts else str(getattr(param, "name", ""))


def _hint_label(param_hint: Any) -> str:
    if param_hint is None:
        return ""
    hints = [param_hint] if isinstance(param_hint, str) else list(param_hint)
    return " / ".join(str(h).strip("'\"") for h in hints)


def _unknown_command(ctx: Any, args: Sequence[str]) -> str | None:
    """``no such command 'x'; ...`` when the first positional argument is not a command."""
    group = getattr(ctx, "command", None)
    if not callable(getattr(group, "list_commands", None)):
        return None
    names = list(group.list_commands(ctx))  # type: ignore[union-attr]
    word = next((a for a in args if not a.startswith("-")), None)
    if word is None or word in names:
        return None
    close = difflib.get_close_matches(word, names, n=1)
    guess = f" (did you mean {close[0]!r}?)" if close else ""
    return f"no such command {word!r}{guess}; expected one of {', '.join(names)}"


def _similarity(a: str, b: str) -> float:
    return difflib.SequenceMatcher(None, a, b).ratio()


def _one_line(text: str) -> str:
    lines = [line.strip() for line in text.strip().splitlines() if line.strip()]
    message = " ".join(lines)
    return message[:1].lower() + message[1:] if message[:2].istitle() else message


@contextlib.contextmanager
def one_line_warnings() -> Iterator[None]:
    """Print each :class:`~hisopt.errors.PlausibilityWarning` once, as one ``warning: FILE: KEY:
    ...`` line on stderr, whatever the warning filters say (``-W error`` included); other
    warnings as Python shows them. Filters and printer are restored on exit."""
    from hisopt.errors import PlausibilityWarning

    seen: set[str] = set()
    with warnings.catch_warnings():
        show = warnings.showwarning

        def printer(message: Warning | str, category: type[Warning], *args: Any, **kwargs: Any) -> None:
            if not issubclass(category, PlausibilityWarning):
                show(message, category, *args, **kwargs)
            elif str(message) not in seen:  # "always" below; a value read twice warns once
                seen.add(str(message))
                typer.echo(f"warning: {message}", err=True)

        warnings.simplefilter("always", PlausibilityWarning)
        warnings.showwarning = printer
        yield
