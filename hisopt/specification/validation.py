"""One validation layer for every way a design or a value enters hisopt.

A design (one value per design variable) can come from the problem file's ``[his]`` table
(the baseline), from ``--set KEY=VALUE``, from a ``--designs`` CSV file, from library calls
with arrays, dicts, lists of dicts or DataFrames, and from a run's front (refinement start
points). All of them pass through the functions here, with the same rules and messages:

- :func:`parameter_rule` reads a parameter's physical rule (``p0 >= 0``, ``0 < lam < 1``,
  ...) from the pydantic field of :class:`~hisopt.hydraulics.roll_plane.RollPlaneHIS`, the
  one source of truth; nothing here re-lists a rule.
- :func:`design_matrix` turns any accepted form into an ``(n, n_var)`` float array, or raises
  :class:`~hisopt.errors.ConfigError` naming the row and the column.
- :func:`check_designs` gives every row a status: ``ok``; ``out_of_bounds`` (outside the
  ``[variables]`` box but physically valid: evaluated, never feasible); ``invalid`` (a value
  is not finite or breaks its parameter's rule: not evaluated, NaN results, never feasible),
  with a reason naming the parameter and the rule.
- :func:`parse_assignments` and :func:`apply_assignments` read ``--set KEY=VALUE`` values as
  TOML values and blame the option, not the problem file, for a bad one.

Problem and design files are read as text by :mod:`hisopt.specification.text_files`.
"""

from __future__ import annotations

import math
import tomllib
from collections import defaultdict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, Protocol, TypeVar

import numpy as np
import pandas as pd
from pydantic import BaseModel

from hisopt.arguments import problem_argument
from hisopt.errors import ConfigError
from hisopt.hydraulics.layout import FIELD_LOWER, FIELD_UPPER, Layout, parameter_uses
from hisopt.hydraulics.roll_plane import RollPlaneHIS
from hisopt.plausibility import rule_reason
from hisopt.quantities import unit_factor
from hisopt.specification.catalogues import listed


class DesignSpace(Protocol):
    """What the checks need of a problem (:class:`hisopt.problem.Problem` has it)."""

    @property
    def variable_names(self) -> tuple[str, ...]: ...

    @property
    def lower(self) -> np.ndarray: ...

    @property
    def upper(self) -> np.ndarray: ...

    @property
    def baseline(self) -> np.ndarray: ...

    def with_values(self, **values: Any) -> Any: ...

    def replace_values(self, values: Mapping[str, Any], option: str | None = None) -> Any: ...

    def parameter_rule(self, name: str) -> Rule: ...

    def layout(self) -> Layout: ...

    @property
    def spec(self) -> Any: ...

    @property
    def choices(self) -> dict[int, np.ndarray]: ...


P = TypeVar("P", bound=DesignSpace)

STATUS_OK = "ok"
STATUS_OUT_OF_BOUNDS = "out_of_bounds"
STATUS_INVALID = "invalid"
STATUS_FAILED = "failed"
"""Row statuses of evaluated designs (``failed``: valid input, but the model is unstable or
singular there, so the results are NaN)."""

DESIGN_PARAMETER_MODEL: type[BaseModel] = RollPlaneHIS
"""The pydantic model whose scalar fields are the possible design variables."""

MAGNITUDE_RANGE = (1e-15, 1e15)
"""[SI units] Smallest and largest magnitude of a non-zero number in a problem file or an
option (``--set``); designs (rows, arrays) only have the upper limit, since optimisers
produce values like 1e-154 next to a zero bound. Every physical value of a vehicle with HIS
lies well inside (a chamber volume of 1e-6 m^3, a bulk modulus of 1.5e9 Pa); outside it a
value is an exponent typo (2e60 for 2e6), and products of such values overflow or underflow
in the model."""

STRUCTURAL_SWITCHES = {"chamber_volume": "the chamber compliances"}
"""Scalar ``[his]`` fields whose fixed value 0 leaves an element out of the network (the
layout is compiled from ``[his]``): a design variable of that name needs a non-zero
``[his]`` value, or it would be silently ignored."""


# --- physical rules, read from the pydantic fields ------------------------------------------
@dataclass(frozen=True)
class Rule:
    """The physical rule of one parameter: an interval, each end open or closed.

    Attributes
    ----------
    name : str
        [-] parameter name
    lower : float | None
        [parameter unit] lower end (None: unbounded)
    lower_closed : bool
        [-] True for ``>=``, False for ``>``
    upper : float | None
        [parameter unit] upper end (None: unbounded)
    upper_closed : bool
        [-] True for ``<=``, False for ``<``
    """

    name: str
    lower: float | None = None
    lower_closed: bool = True
    upper: float | None = None
    upper_closed: bool = True

    def holds(self, values: Any) -> np.ndarray:
        """[-] Whether each value is finite, at most 1e15 in magnitude and obeys the rule (NaN never does)."""
        v = np.asarray(values, dtype=float)
        ok = plausible(v, tiny=False)
        with np.errstate(invalid="ignore"):
            if self.lower is not None:
                ok &= v >= self.lower if self.lower_closed else v > self.lower
            if self.upper is not None:
                ok &= v <= self.upper if self.upper_closed else v < self.upper
        return ok

    @property
    def text(self) -> str:
        """The rule as people write it: ``p0 >= 0``, ``0 < lam < 1``."""
        lo = None if self.lower is None else f"{self.lower:g} {'<=' if self.lower_closed else '<'} "
        hi = None if self.upper is None else f" {'<=' if self.upper_closed else '<'} {self.upper:g}"
        if lo and hi:
            return f"{lo}{self.name}{hi}"
        if lo:
            return f"{self.name} {'>=' if self.lower_closed else '>'} {self.lower:g}"
        if hi:
            return f"{self.name}{hi}"
        return f"{self.name} finite"

    def tightened(self, lower: float, closed: bool) -> Rule:
        """This rule and ``value >= lower`` (``closed``) or ``value > lower``, together."""
        if self.lower is None or lower > self.lower:
            return replace(self, lower=lower, lower_closed=closed)
        if lower == self.lower:
            return replace(self, lower_closed=self.lower_closed and closed)
        return self

    def capped(self, upper: float, closed: bool) -> Rule:
        """This rule and ``value <= upper`` (``closed``) or ``value < upper``, together."""
        if self.upper is None or upper < self.upper:
            return replace(self, upper=upper, upper_closed=closed)
        if upper == self.upper:
            return replace(self, upper_closed=self.upper_closed and closed)
        return self


def plausible(values: Any, tiny: bool = True) -> np.ndarray:
    """[-] Finite values of a magnitude up to ``MAGNITUDE_RANGE[1]`` and, with ``tiny``, zero or
    at least ``MAGNITUDE_RANGE[0]`` (:data:`MAGNITUDE_RANGE`)."""
    v = np.abs(np.asarray(values, dtype=float))
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(v) & (v <= MAGNITUDE_RANGE[1])
        return ok & ((v == 0) | (v >= MAGNITUDE_RANGE[0])) if tiny else ok


def magnitude_problem(value: float, tiny: bool = True) -> str | None:
    """What is wrong with a number that is not :func:`plausible` (None if it is)."""
    if not math.isfinite(value):
        return "expected a finite number"
    if not plausible(value, tiny):
        if not tiny:
            return f"expected a magnitude of at most {MAGNITUDE_RANGE[1]:g} (SI units; an exponent typo?)"
        return f"expected zero or a magnitude between {MAGNITUDE_RANGE[0]:g} and {MAGNITUDE_RANGE[1]:g} (SI units; an exponent typo?)"
    return None


def implausible_number(data: Any, path: tuple[str, ...] = ()) -> tuple[str, str] | None:
    """The first number in nested dicts and lists (a parsed problem file) that is not
    :func:`plausible`: ``(dotted key, message)``; None if every number is."""
    items = data.items() if isinstance(data, Mapping) else enumerate(data) if isinstance(data, list) else ()
    for key, value in items:
        where = path + (str(key),)
        if isinstance(value, (Mapping, list)):
            found = implausible_number(value, where)
            if found:
                return found
        elif isinstance(value, (int, float)) and not isinstance(value, bool):
            too_big = isinstance(value, int) and abs(value) > MAGNITUDE_RANGE[1]  # float() of a huge int overflows
            problem = magnitude_problem(float(MAGNITUDE_RANGE[1] * 10 if too_big else value))
            if problem:
                return ".".join(where), f"{problem}, got {value!r}"
    return None


def parameter_rule(name: str, model: type[BaseModel] = DESIGN_PARAMETER_MODEL, layout: Layout | None = None) -> Rule:
    """The rule of parameter ``name``: its field of ``model`` (``gt``/``ge``/``lt``/``le``
    metadata) and, with a ``layout``, the rule of every element field that reads it
    (:data:`hisopt.hydraulics.layout.FIELD_LOWER` and ``FIELD_UPPER``: a valve resistance
    ``>= 0``, a gas volume ``> 0``, a polytropic exponent ``<= 2``, ...), all together.

    Raises
    ------
    KeyError
        ``model`` has no field ``name`` and no element of ``layout`` reads it.
    """
    uses = parameter_uses(layout).get(name, []) if layout is not None else []
    if name not in model.model_fields and not uses:
        raise KeyError(name)
    rule: dict[str, Any] = {}
    for item in model.model_fields[name].metadata if name in model.model_fields else ():
        for attr, end, closed in (("gt", "lower", False), ("ge", "lower", True), ("lt", "upper", False), ("le", "upper", True)):
            value = getattr(item, attr, None)
            if value is not None:
                rule[end], rule[f"{end}_closed"] = float(value), closed
    out = Rule(name, **rule)
    for use in uses:
        out = out.tightened(*FIELD_LOWER[use])
        out = out.capped(*FIELD_UPPER[use]) if use in FIELD_UPPER else out
    return out


def design_parameters(model: type[BaseModel] = DESIGN_PARAMETER_MODEL) -> tuple[str, ...]:
    """[-] Fields that may be design variables: the scalar float fields of ``[his]``."""
    return tuple(k for k, f in model.model_fields.items() if f.annotation in (float, float | None))


def switched_off(name: str, his: BaseModel) -> str | None:
    """Why design variable ``name`` would do nothing with these fixed ``[his]`` values (None: it acts)."""
    if name in STRUCTURAL_SWITCHES and not getattr(his, name):
        return (
            f"expected a non-zero [his] {name} when {name} is a design variable: with {name} = 0 "
            f"{STRUCTURAL_SWITCHES[name]} are left out of the model, so the variable would do nothing"
        )
    return None


def bounds_problem(name: str, lower: float, upper: float, layout: Layout | None = None) -> str | None:
    """Why the box ``[lower, upper]`` of design variable ``name`` breaks its rule (None: it does not)."""
    rule = parameter_rule(name, layout=layout)
    bad = [f"{which} bound {value:g}" for which, value in (("lower", lower), ("upper", upper)) if not rule.holds(value)]
    if bad:
        return f"expected bounds inside the parameter's range {rule.text}{rule_reason(name)}, got {' and '.join(bad)}"
    return None


# --- designs: any accepted form -> (n, n_var) float array ---------------------------------
def _number(value: Any, where: str, source: str | None = None) -> float:
    if isinstance(value, (bool, np.bool_)):
        raise ConfigError(f"expected a number, got the boolean {value!r}", file=source, key=where)
    if isinstance(value, (int, float, np.integer, np.floating)):
        return float(value)
    if isinstance(value, str):  # numbers written as text, e.g. from a CSV read as text
        try:
            return float(value)
        except ValueError:
            pass
    raise ConfigError(f"expected a number, got {_short(value)}", file=source, key=where)


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def match_columns(columns: Sequence[Any], names: Sequence[str], source: str | None = None) -> dict[str, Any]:
    """Which column holds each variable: the exact name, else the one column equal to it
    ignoring case and surrounding spaces (``P0`` for ``p0``).

    Raises
    ------
    ConfigError
        A variable has no column, or two columns could be it.
    """
    found: dict[str, Any] = {}
    for name in names:
        exact = [c for c in columns if str(c) == name]
        loose = [c for c in columns if str(c).strip().lower() == name.lower()]
        if len(exact) > 1 or (exact and len(loose) > 1) or (not exact and len(loose) > 1):
            both = ", ".join(repr(str(c)) for c in (loose if len(loose) > 1 else exact))
            raise ConfigError(f"columns {both} all name the design variable {name!r}; expected one column per variable", file=source)
        if not (exact or loose):
            hint = ""
            if len(columns) == 1 and any(sep in str(columns[0]) for sep in ";\t|"):
                hint = f" (the header is the single column {_short(str(columns[0]))}: expected comma-separated columns)"
            raise ConfigError(f"missing column {name!r}; expected columns {', '.join(names)}{hint}", file=source)
        found[name] = (exact or loose)[0]
    return found


def _frame_matrix(frame: pd.DataFrame, problem: DesignSpace, source: str | None) -> np.ndarray:
    names = problem.variable_names
    cols = match_columns(list(frame.columns), names, source)
    x = np.empty((len(frame), len(names)))
    for j, name in enumerate(names):
        column = frame[cols[name]]
        if pd.api.types.is_bool_dtype(column):
            raise ConfigError(f"column {name!r} holds booleans; expected numbers", file=source)
        try:
            if column.dtype == object:
                raise TypeError  # check each cell: booleans would pass as 0 and 1
            x[:, j] = column.to_numpy(dtype=float)
        except (TypeError, ValueError):
            x[:, j] = [_number(v, f"row {i + 1}, column {name!r}", source) for i, v in enumerate(column.tolist())]
    given = frame.attrs.get("units")
    if isinstance(given, Mapping) and given:  # a frame that names its units (hisopt.io.read_csv): to SI
        si_units = variable_si_units(problem)
        for j, name in enumerate(names):
            unit = given.get(str(cols[name]))
            if isinstance(unit, str) and si_units[name] is not None:
                x[:, j] *= unit_factor(unit, str(si_units[name]), file=source, key=f"column {name!r} (attrs['units'])")
    return x


def variable_si_units(problem: DesignSpace) -> dict[str, str | None]:
    """[-] The SI unit of each design variable (:func:`hisopt.hydraulics.catalogue.parameter_unit`)."""
    from hisopt.hydraulics.catalogue import parameter_unit

    uses = parameter_uses(problem.layout())
    return {name: parameter_unit(name, uses) for name in problem.variable_names}


def _first_non_number(arr: np.ndarray, names: Sequence[str], source: str | None) -> None:
    """Raise for the first cell of a 1-D or 2-D object array that is not a number."""
    rows = arr if arr.ndim == 2 else arr[None, :]
    for i, row in enumerate(rows):
        for j, value in enumerate(row):
            column = repr(names[j]) if j < len(names) else str(j + 1)
            _number(value, f"row {i + 1}, column {column}", source)


def design_matrix(problem: DesignSpace, designs: Any, source: str | None = None) -> np.ndarray:
    """Designs as an ``(n, n_var)`` float array, columns in the problem's variable order.

    Parameters
    ----------
    problem : DesignSpace
        the problem (its variable names and baseline)
    designs : Any
        [variable units] an array ``(n, n_var)`` or one design ``(n_var,)``; a DataFrame
        with the variable columns (other columns are ignored; ``P0`` is taken for ``p0`` when
        no column is exactly ``p0``; a column whose ``attrs["units"]`` names another unit, e.g.
        ``MPa`` from a units row read by :func:`hisopt.io.read_csv`, is converted); a dict of names to values or arrays (missing names take
        the baseline); or a list of such dicts, one per design
    source : str | None, optional
        [-] where the designs come from (named in errors), e.g. a file name

    Returns
    -------
    numpy.ndarray
        ``(n, n_var)``; values are not checked against the rules here (:func:`check_designs`).

    Raises
    ------
    ConfigError
        A column or name is missing or unknown, a value is not a number or is a boolean (the
        row, counted from 1, and the column are named), or the shape is wrong.
    """
    names = problem.variable_names
    if isinstance(designs, pd.DataFrame):
        return _frame_matrix(designs, problem, source)
    if isinstance(designs, Mapping):
        return _mapping_matrix(problem, designs, source, "")
    if isinstance(designs, (list, tuple)) and any(isinstance(d, Mapping) for d in designs):
        rows = []
        for i, d in enumerate(designs):
            if not isinstance(d, Mapping):
                raise ConfigError(f"row {i + 1}: expected a dict like the other rows, got {_short(d)}", file=source)
            row = _mapping_matrix(problem, d, source, f"row {i + 1}: ")
            if len(row) != 1:
                raise ConfigError(f"row {i + 1}: expected one value per name in a list of designs", file=source)
            rows.append(row)
        return np.vstack(rows)
    expected = f"an array of shape (n, {len(names)}) in the order {', '.join(names)}"
    if isinstance(designs, np.ndarray) and designs.dtype.kind in "iuf":
        x = designs.astype(float, copy=False)
    else:
        try:
            obj = np.asarray(designs, dtype=object)
        except ValueError:  # ragged nesting
            raise ConfigError(f"expected {expected}; rows differ in length", file=source) from None
        if obj.ndim == 1 and any(isinstance(v, (list, tuple, np.ndarray)) for v in obj):
            raise ConfigError(f"expected {expected}; rows differ in length", file=source)
        if obj.ndim not in (1, 2):
            raise ConfigError(f"expected {expected}, got shape {obj.shape}", file=source)
        _first_non_number(obj, names, source)
        x = obj.astype(float)
    if x.ndim not in (1, 2) or x.size == 0 and x.ndim == 1:
        raise ConfigError(f"expected {expected}, got shape {x.shape}", file=source)
    if x.ndim == 1:
        x = x[None, :]
    if x.shape[1] != len(names):
        raise ConfigError(f"expected designs of shape (n, {len(names)}) in the order {', '.join(names)}, got {x.shape}", file=source)
    return x


def _mapping_matrix(problem: DesignSpace, designs: Mapping[str, Any], source: str | None, prefix: str) -> np.ndarray:
    names = problem.variable_names
    unknown = [k for k in designs if k not in names]
    if unknown:
        raise ConfigError(f"{prefix}unknown design variable {unknown[0]!r}; expected {', '.join(names)}", file=source)
    cols = []
    for name, base in zip(names, problem.baseline, strict=True):
        value = np.asarray(designs.get(name, base), dtype=object)
        if value.ndim > 1:
            raise ConfigError(f"{prefix}{name}: expected a number or a 1-D sequence, got shape {value.shape}", file=source)
        cols.append(np.array([_number(v, f"{prefix}{name}", source) for v in value.ravel()]).reshape(value.shape))
    try:
        return np.stack(np.broadcast_arrays(*[np.atleast_1d(c) for c in cols]), axis=-1)
    except ValueError:
        sizes = ", ".join(f"{n}: {np.size(c)}" for n, c in zip(names, cols, strict=True))
        raise ConfigError(f"{prefix}values of different lengths ({sizes}); expected one value or one per design each", file=source) from None


# --- designs: statuses and reasons ---------------------------------------------------------
@dataclass(frozen=True)
class DesignCheck:
    """Status and reason of every design row (see the module docstring).

    Attributes
    ----------
    status : np.ndarray
        [-] ``(n,)`` one of ``ok``, ``out_of_bounds``, ``invalid``
    reason : np.ndarray
        [-] ``(n,)`` why a row is flagged (empty for ``ok``) and what happens to it
    detail : np.ndarray
        [-] ``(n,)`` the reason without what happens to the row
    """

    status: np.ndarray
    reason: np.ndarray
    detail: np.ndarray

    @property
    def evaluable(self) -> np.ndarray:
        """[-] Rows the model can be evaluated at (not ``invalid``), ``(n,)``."""
        return self.status != STATUS_INVALID

    @property
    def ok(self) -> np.ndarray:
        """[-] Rows with nothing to flag, ``(n,)``."""
        return self.status == STATUS_OK


def admissible(problem: DesignSpace, x: np.ndarray) -> np.ndarray:
    """[-] Rows whose every value is finite and obeys its parameter's rule, ``(n,)``, and
    whose cylinders' rods are thinner than their bores (:func:`cylinder_breaks`)."""
    problem_argument(problem)
    x = _number_array(x, len(problem.variable_names))
    ok = np.ones(x.shape[0], dtype=bool)
    for j, name in enumerate(problem.variable_names):
        ok &= problem.parameter_rule(name).holds(x[:, j])
    for _, bad, _ in cylinder_breaks(problem, x):
        ok &= ~bad
    return ok


def _number_array(x: Any, n_var: int) -> np.ndarray:
    """``x`` as a float array ``(n, n_var)`` (NaN allowed: such a row is not admissible), else
    a :class:`ConfigError` naming ``x``."""
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"expected an array of numbers of shape (n, {n_var}), got {_short(x)}", key="x") from None
    if arr.ndim != 2 or arr.shape[1] != n_var:
        raise ConfigError(f"expected an array of shape (n, {n_var}), got shape {arr.shape}", key="x")
    return arr


def cylinder_breaks(problem: DesignSpace, x: np.ndarray) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Per axle sized by bore and rod with at least one of them a design variable:
    ``(axle suffix, rows whose rod is not thinner than the bore (n,), [bore, rod] (n, 2))``.
    The rear axle counts when it has a size of its own (else it follows the front); a fixed
    pair is checked when the file is read (:class:`~hisopt.hydraulics.roll_plane.RollPlaneHIS`)."""
    names = problem.variable_names
    his = problem.spec.his
    given = lambda n: n in names or getattr(his, n) is not None  # noqa: E731
    out = []
    for axle in ("", "_rear"):
        if axle and not (given("bore_rear") or given("rod_rear")):
            continue  # the rear follows the front's sizes: checked there
        sources = [next((n for n in (f"{part}{axle}", part) if given(n)), None) for part in ("bore", "rod")]
        if None in sources or not any(n in names for n in sources):
            continue
        pair = [x[:, names.index(n)] if n in names else np.full(len(x), float(getattr(his, n))) for n in sources]  # type: ignore[arg-type]
        with np.errstate(invalid="ignore"):
            out.append((axle, ~(pair[1] < pair[0]), np.stack(pair, axis=1)))
    return out


def check_designs(problem: DesignSpace, x: np.ndarray) -> DesignCheck:
    """Status and reason of every row of ``x`` (n, n_var): rules first, then the box.

    A reason names each offending parameter, its value and the rule or bound it breaks,
    e.g. ``lam = 1.5 breaks 0 < lam < 1`` or ``p0 = 9e+06 is above the upper bound 4e+06``.
    """
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    invalid: dict[int, list[str]] = defaultdict(list)  # only flagged rows: no Python loop over all
    outside: dict[int, list[str]] = defaultdict(list)
    lower, upper, choices = problem.lower, problem.upper, problem.choices
    for j, name in enumerate(problem.variable_names):
        col = x[:, j]
        rule = problem.parameter_rule(name)
        for i in map(int, np.flatnonzero(~rule.holds(col))):
            v, problem_text = col[i], magnitude_problem(col[i], tiny=False)
            invalid[i].append(f"{name} = {v:g}: {problem_text}" if problem_text else f"{name} = {v:g} breaks {rule.text}")
        with np.errstate(invalid="ignore"):
            low, high = col < lower[j], col > upper[j]
        for i in map(int, np.flatnonzero(low)):
            outside[i].append(f"{name} = {col[i]:g} is below the lower bound {lower[j]:g}")
        for i in map(int, np.flatnonzero(high)):
            outside[i].append(f"{name} = {col[i]:g} is above the upper bound {upper[j]:g}")
        if j in choices:
            for i in map(int, np.flatnonzero(~listed(col, choices[j]) & ~low & ~high & np.isfinite(col))):
                outside[i].append(f"{name} = {col[i]:g} is not one of its listed choices")
    for axle, bad, sizes in cylinder_breaks(problem, x):
        for i in map(int, np.flatnonzero(bad)):
            invalid[i].append(f"rod{axle} = {sizes[i, 1]:g} is not thinner than bore{axle} = {sizes[i, 0]:g}")
    status = np.full(n, STATUS_OK, dtype=object)
    reason = np.full(n, "", dtype=object)
    detail = np.full(n, "", dtype=object)
    for row in sorted(set(invalid) | set(outside)):
        if row in invalid:
            status[row], detail[row] = STATUS_INVALID, "; ".join(invalid[row])
            reason[row] = detail[row] + " (not evaluated)"
        else:
            status[row], detail[row] = STATUS_OUT_OF_BOUNDS, "; ".join(outside[row]) + " of [variables]"
            reason[row] = detail[row] + " (evaluated, not feasible)"
    return DesignCheck(status, reason, detail)


def require_admissible(problem: DesignSpace, x: np.ndarray, source: str | None = None) -> None:
    """Raise :class:`ConfigError` naming the first row that breaks a rule or is not finite."""
    ok = admissible(problem, x)
    if not ok.all():
        i = int(np.flatnonzero(~ok)[0])
        reason = check_designs(problem, np.asarray(x, dtype=float)[i : i + 1]).detail[0]
        where = f"design row {i + 1}" if len(ok) > 1 else "design"
        raise ConfigError(f"{where}: {reason}", file=source)


def flag_summary(status: Sequence[str] | np.ndarray, source: str | None = None) -> str | None:
    """One line counting flagged rows, e.g. ``designs.csv: 2 of 6 designs flagged (1 invalid,
    1 out_of_bounds); see the status and reason columns`` (None if nothing is flagged)."""
    status = np.asarray(status, dtype=object)
    counts = {s: int(np.sum(status == s)) for s in (STATUS_INVALID, STATUS_OUT_OF_BOUNDS, STATUS_FAILED)}
    flagged = sum(counts.values())
    if not flagged:
        return None
    parts = ", ".join(f"{c} {s}" for s, c in counts.items() if c)
    prefix = f"{source}: " if source else ""
    return f"{prefix}{flagged} of {len(status)} designs flagged ({parts}); none of them is feasible, see the status and reason columns"


# --- --set KEY=VALUE --------------------------------------------------------------------------
def parse_value(text: str) -> Any:
    """A ``--set`` value as a TOML value (``3e6``, ``true``, ``"x"``), else the bare text."""
    try:
        return tomllib.loads(f"v = {text.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        return text.strip()


def parse_assignments(items: Sequence[str] | None, option: str = "--set") -> dict[str, Any]:
    """``["p0=3e6", "pipe_model=distributed"]`` -> ``{"p0": 3e6, "pipe_model": "distributed"}``.

    Raises
    ------
    ConfigError
        An item is not ``KEY=VALUE`` or a key is given twice.
    """
    out: dict[str, Any] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise ConfigError(f"expected KEY=VALUE, e.g. p0=3e6; got {item!r}", key=option)
        if not value.strip():
            raise ConfigError(f"expected a value after '=', e.g. {key}=3e6; got {item!r}", key=option)
        if key in out:
            raise ConfigError(f"{key!r} is set twice; give each key once", key=option)
        out[key] = parse_value(value)
    return out


def apply_assignments(problem: P, items: Sequence[str] | None, option: str = "--set") -> P:
    """``problem`` with ``--set KEY=VALUE`` overrides of ``[his]`` values; a bad value is
    blamed on the option (``--set p0=abc: expected a number ...``), not on the file, and so is
    an implausible one (a :class:`~hisopt.errors.PlausibilityWarning` ``--set p0=50000.0: ...``)."""
    values = parse_assignments(items, option)
    if not values:
        return problem
    try:
        return problem.replace_values(values, option)
    except ConfigError as exc:
        key = str(exc.key or "")
        name = key.removeprefix("his.").split(".")[0]
        if name in values:
            raise ConfigError(exc.detail, key=f"{option} {name}={assignment_text(values[name])}") from None
        raise ConfigError(f"{key + ': ' if key else ''}{exc.detail}", key=option + " " + " ".join(items or [])) from None


def assignment_text(value: Any) -> str:
    """A ``--set`` value as messages write it back: ``50000.0``, ``true``, ``distributed``."""
    return value if isinstance(value, str) else str(value).lower() if isinstance(value, bool) else repr(value)
