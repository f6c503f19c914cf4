"""Mutation corpus through the CLI: broken problem files, options and design files.

For every mutation the CLI must exit 0 with a correct, flagged result, or exit 2 with one
line naming the file (or option), the key or row, and what was expected; never exit 1, never
a traceback. Problem files: values replaced by booleans, infinities, NaN, huge and tiny
magnitudes, strings, lists and tables; keys deleted or added; tables emptied; list entries
duplicated; then written as UTF-8, with a BOM, as Latin-1 or as binary, truncated, or
replaced by a directory, an unreadable path or a missing file; some with ``--set``. Design
files: rows that are fine, out of the box, rule-breaking, NaN, infinite, empty or not numbers;
comma, semicolon or tab delimited; header case and spaces varied, columns shuffled, extra
columns, a units row, a BOM, CRLF, blank lines; missing or doubled columns, ragged rows, no
rows. An oracle written here (not hisopt's validation) says which outcome each must have.

The examples are derandomized (the same corpus on every run); their number is
``HISOPT_MUTATIONS`` (problem files, default 400) and half of it (design files). The outcome
counts are printed in the test summary.
"""

from __future__ import annotations

import collections
import copy
import json
import math
import os
import tomllib
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hisopt.io import read_csv
from tests.cli_inprocess import Outcome, run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT

N_PROBLEMS = int(os.environ.get("HISOPT_MUTATIONS", "400"))
COUNTS: dict[str, collections.Counter] = {"problem files": collections.Counter(), "design files": collections.Counter()}
SCRATCH = Path(os.environ.get("HISOPT_MUTATION_DIR", "/tmp")) / f"hisopt-mutations-{os.getpid()}"

BASES = [tomllib.loads(p.read_text(encoding="utf-8")) for p in (DEFAULT_PROBLEM, ROOT / "problems" / "roll_plane_his_handling.toml")]
LO = {"p0": 0.0, "dA": 1e-4, "lam": 0.1, "Rv": 0.0}
HI = {"p0": 4e6, "dA": 25e-4, "lam": 0.8, "Rv": 16e5}
NAMES = ("p0", "dA", "lam", "Rv")


# --- a TOML writer for mutated dictionaries (inline tables, so any nesting is valid) ----------
def toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return "{ " + ", ".join(f"{json.dumps(str(k))} = {toml_value(x)}" for k, x in v.items()) + " }"


def to_toml(data: dict) -> str:
    return "".join(f"{json.dumps(str(k))} = {toml_value(v)}\n" for k, v in data.items())


def _paths(data, prefix=()):
    for key, value in data.items():
        yield prefix + (key,)
        if isinstance(value, dict):
            yield from _paths(value, prefix + (key,))


PATHS = sorted({p for base in BASES for p in _paths(base)})
HUGE = st.floats(1e16, 1e308) | st.sampled_from([1e300, 1.7976931348623157e308, 2e60])
TINY = st.floats(5e-324, 1e-16) | st.sampled_from([5e-324, 1e-300, 2e-60])
VALUES = st.one_of(
    st.booleans(),
    st.sampled_from([math.inf, -math.inf, math.nan, 0.0, -0.0, -1.0, 1.0, 0.5, 2, -3]),
    HUGE,
    HUGE.map(lambda x: -x),
    TINY,
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(10**20), 10**20),
    st.text(max_size=6),
    st.lists(st.floats(-1e3, 1e3), max_size=3),
    st.just({}),
    st.dictionaries(st.text(min_size=1, max_size=5), st.floats(-1, 1), max_size=2),
)


@st.composite
def mutated_problem(draw):
    data = copy.deepcopy(draw(st.sampled_from(BASES)))
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(PATHS))
        parent = data
        for key in path[:-1]:
            parent = parent.get(key) if isinstance(parent, dict) else None
        if not isinstance(parent, dict):
            continue
        action = draw(st.sampled_from(["replace", "replace", "replace", "scale", "scale", "delete", "add", "empty", "duplicate"]))
        value = parent.get(path[-1])
        if action == "scale" and isinstance(value, (int, float)) and not isinstance(value, bool):
            scaled = value * draw(st.sampled_from([0.0, 0.5, 0.9, 1.1, 2.0, 10.0, -1.0]))
            parent[path[-1]] = int(scaled) if isinstance(value, int) else scaled  # often still valid
        elif action == "replace":
            parent[path[-1]] = draw(VALUES)
        elif action == "delete":
            parent.pop(path[-1], None)
        elif action == "add":
            parent[draw(st.text(min_size=1, max_size=6))] = draw(VALUES)
        elif action == "empty" and isinstance(parent.get(path[-1]), dict):
            parent[path[-1]] = {}
        elif action == "duplicate":
            for key in ("objectives", "constraints"):
                if isinstance(data.get(key), list) and data[key]:
                    data[key] = data[key] + [data[key][0]]
                    break
    return data


BOOLEAN_KEYS = ("gravity_moment", "catalogue_cost")
"""The problem file's switches (``[handling] gravity_moment``, ``[optimizer] catalogue_cost``):
a boolean there is a value, anywhere else a mutation to refuse."""


def must_refuse(data) -> str | None:
    """The oracle: why this problem must be refused (exit 2), or None if it may load."""

    def walk(v, key=None):
        if isinstance(v, dict):
            for k, x in v.items():
                yield from walk(x, k)
        elif isinstance(v, list):
            for x in v:
                yield from walk(x, key)
        else:
            yield key, v

    for key, v in walk(data):
        if isinstance(v, bool) and key not in BOOLEAN_KEYS:
            return "boolean"
        if isinstance(v, float) and not math.isfinite(v):
            return "not finite"
        if isinstance(v, (int, float)) and v != 0 and not 1e-15 <= abs(v) <= 1e15:
            return "magnitude"
    objectives = data.get("objectives")
    if isinstance(objectives, list) and len(set(map(str, objectives))) < len(objectives):
        return "duplicate objective"
    if not data.get("variables"):
        return "no variables"
    his, road = data.get("his"), data.get("road")
    gamma = his.get("gamma") if isinstance(his, dict) else None
    if isinstance(gamma, (int, float)) and not 1.0 <= gamma <= 2.0:  # no gas has a polytropic exponent outside [1, 2]
        return "polytropic exponent"
    speed = road.get("speed") if isinstance(road, dict) else None
    if isinstance(speed, (int, float)) and speed > 150.0:  # faster than any road vehicle (540 km/h)
        return "speed"
    return None


SET_VALUES = st.sampled_from(["abc", "true", "inf", "nan", "-1", "1e309", "1e300", "0", "3e6", "0.5", "1,2", '"x"', "[1, 2]", "{ a = 1 }", "distributed"])
SET_KEYS = st.sampled_from(["p0", "dA", "lam", "Rv", "V0", "gamma", "pipe_model", "nope", "P0"])
FORMS = ["utf-8", "utf-8", "utf-8", "bom", "latin-1", "binary", "truncated", "directory", "unreadable", "missing"]


def assert_exit_2(out: Outcome, *names: str) -> None:
    assert out.code == 2, out
    assert len(out.error_lines) == 1, out.stderr
    line = out.error_lines[0]
    assert line.startswith("error: ") and "Traceback" not in out.stderr and "internal error" not in line, line
    assert any(name in line for name in names), (names, line)
    assert "expected" in line, line


def assert_flagged_results(results: Path) -> str:
    df = read_csv(results)
    objectives = [c for c in df.columns if c not in NAMES and c not in ("feasible", "status", "reason")]
    finite = np.isfinite(df[objectives].to_numpy(dtype=float)).all(axis=1)
    ok = (df["status"] == "ok").to_numpy()
    assert not (df["feasible"] & ~df["status"].eq("ok")).any()  # nothing flagged is feasible
    assert np.all(finite[ok]), df  # an ok row has finite results
    assert np.all(df.loc[~ok, "reason"].astype(str).str.len() > 0)  # every flag says why
    return "exit 0, ok" if ok.all() else "exit 0, flagged"


@settings(max_examples=N_PROBLEMS, derandomize=True, database=None, deadline=None, suppress_health_check=list(HealthCheck))
@given(mutated_problem(), st.sampled_from(FORMS), st.integers(0, 10_000), st.one_of(st.none(), st.tuples(SET_KEYS, SET_VALUES)), st.booleans())
def test_mutated_problem_files_exit_0_flagged_or_2_with_one_line(data, form, cut, assignment, modes):
    SCRATCH.mkdir(parents=True, exist_ok=True)
    path = SCRATCH / "problem.toml"
    if path.is_dir():
        path.rmdir()
    text = to_toml(data)
    if form == "directory":
        path.unlink(missing_ok=True)
        path.mkdir()
    elif form == "unreadable":
        path = Path("/proc/self/mem")
    elif form == "missing":
        path = SCRATCH / "missing" / "problem.toml"
    elif form == "latin-1":
        path.write_bytes(("# caf\u00e9 au lait\n" + text).encode("latin-1", errors="replace"))
    elif form == "binary":
        path.write_bytes(b"\x00\x01\x02\xff" + text.encode("utf-8")[:100])
    elif form == "truncated":
        path.write_text(text[: cut % max(len(text), 1)], encoding="utf-8")
    else:
        path.write_bytes((b"\xef\xbb\xbf" if form == "bom" else b"") + text.encode("utf-8"))
    results = SCRATCH / "results.csv"
    results.unlink(missing_ok=True)
    args = ["modes", path] if modes else ["evaluate", path, "--out", results]
    if assignment:
        args += ["--set", "=".join(assignment)]
    out = run_cli(*args)
    assert out.code in (0, 2), out
    assert "Traceback" not in out.stderr and "internal error" not in out.stderr, out.stderr
    if form in ("directory", "unreadable", "missing", "latin-1", "binary"):
        expect = {"directory": "is a directory", "unreadable": "cannot read", "missing": "not found", "latin-1": "not UTF-8", "binary": "binary"}
        assert_exit_2(out, str(path))
        assert expect[form] in out.stderr
        outcome = "exit 2"
    elif out.code == 2:
        assert_exit_2(out, str(path), "--set")
        outcome = "exit 2"
    else:
        if form != "truncated":
            assert must_refuse(data) is None, (must_refuse(data), data)
        outcome = "exit 0, ok" if modes else assert_flagged_results(results)
    if form in ("utf-8", "bom") and must_refuse(data):
        assert out.code == 2, (must_refuse(data), out)
    COUNTS["problem files"][outcome] += 1


# --- design files ----------------------------------------------------------------------------------
ROW_KINDS = ["ok"] * 6 + ["out_of_bounds"] * 2 + ["rule"] * 2 + ["nan", "inf", "empty", "huge", "tiny", "text"]


@st.composite
def design_row(draw):
    kind = draw(st.sampled_from(ROW_KINDS))
    values = {n: repr(draw(st.floats(LO[n], HI[n]))) for n in NAMES}
    name = draw(st.sampled_from(NAMES))
    if kind == "out_of_bounds":
        values[name] = repr(HI[name] * draw(st.floats(1.01, 1.2))) if name != "lam" else repr(draw(st.floats(0.81, 0.99)))
        if name in ("dA", "lam") and draw(st.booleans()):
            values[name] = repr(LO[name] * draw(st.floats(0.1, 0.99)))  # below the box, still > 0
    elif kind == "rule":
        values[name] = {"p0": "-1", "dA": draw(st.sampled_from(["0", "-1e-3"])), "lam": draw(st.sampled_from(["0", "1", "1.5", "-0.2"])), "Rv": "-5"}[name]
    elif kind == "nan":
        values[name] = draw(st.sampled_from(["nan", "NaN"]))
    elif kind == "inf":
        values[name] = draw(st.sampled_from(["inf", "-inf", "1e309"]))
    elif kind == "empty":
        values[name] = ""
    elif kind == "huge":
        values[name] = draw(st.sampled_from(["1e300", "-1e300", "2e16"]))
    elif kind == "tiny":  # next to a zero bound, as optimisers produce: fine for p0 and Rv
        values[name] = draw(st.sampled_from(["1e-154", "5e-324", "-1e-300"]))
    elif kind == "text":
        values[name] = draw(st.sampled_from(["abc", "1,5", "true", "--"]))
    return kind, values


def expected_status(values: dict[str, str]) -> str:
    """The oracle: the rules of paper Table 2's variables and the default box, written out here."""
    v = {n: float(values[n]) if values[n] else math.nan for n in NAMES}
    if any(not math.isfinite(x) or abs(x) > 1e15 for x in v.values()):
        return "invalid"
    if v["p0"] < 0 or v["dA"] <= 0 or not 0 < v["lam"] < 1 or v["Rv"] < 0:
        return "invalid"
    return "ok" if all(LO[n] <= v[n] <= HI[n] for n in NAMES) else "out_of_bounds"


@settings(max_examples=max(N_PROBLEMS // 2, 1), derandomize=True, database=None, deadline=None, suppress_health_check=list(HealthCheck))
@given(
    st.lists(design_row(), min_size=1, max_size=5),
    st.sampled_from([",", ";", "\t"]),
    st.sampled_from(["exact", "upper", "title", "spaces"]),
    st.permutations(NAMES),
    st.booleans(),  # extra column
    st.booleans(),  # units row
    st.booleans(),  # BOM
    st.booleans(),  # CRLF and blank lines
    st.sampled_from(["none"] * 7 + ["missing", "doubled", "ragged", "no rows"]),
)
def test_mutated_design_files_flag_every_row_or_exit_2(rows, delimiter, case, order, extra, units, bom, crlf, damage):
    SCRATCH.mkdir(parents=True, exist_ok=True)
    header = {"exact": list(order), "upper": [n.upper() for n in order], "title": [n.title() for n in order], "spaces": [f" {n} " for n in order]}[case]
    columns = list(order)
    if extra:
        header, columns = header + ["note"], columns + ["note"]
    if damage == "missing":
        header, columns = header[1:], columns[1:]
    if damage == "doubled":
        header, columns = header + [order[0].upper() if case == "exact" else order[0]], columns + [order[0]]
    lines = [delimiter.join(header)]
    if units:
        si = {"p0": "[Pa]", "dA": "[m^2]", "lam": "[-]", "Rv": "[Pa s m^-3]"}  # as hisopt writes them (a unit row converts)
        lines.append(delimiter.join(si.get(c, "[-]") for c in columns))
    for _, values in rows if damage != "no rows" else []:
        lines.append(delimiter.join(values.get(c, "x") for c in columns))
        if crlf:
            lines.append("")
    if damage == "ragged" and rows:
        lines[-1 if lines[-1] else -2] += delimiter + "1"
    newline = "\r\n" if crlf else "\n"
    path = SCRATCH / "designs.csv"
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + (newline.join(lines) + newline).encode("utf-8"))
    results = SCRATCH / "design-results.csv"
    results.unlink(missing_ok=True)
    out = run_cli("evaluate", DEFAULT_PROBLEM, "--designs", path, "--out", results)
    assert "Traceback" not in out.stderr and "internal error" not in out.stderr, out.stderr
    structural = damage != "none" or any(kind == "text" for kind, _ in rows)
    if structural:
        assert_exit_2(out, str(path))
        outcome = "exit 2"
    else:
        assert out.code == 0, out
        df = read_csv(results)
        expected = [expected_status(values) for _, values in rows]
        assert list(df["status"]) == expected, (rows, df[["status", "reason"]])
        flagged = sum(s != "ok" for s in expected)
        warnings = [line for line in out.error_lines if line.startswith("warning: ")]
        assert len(warnings) == (1 if flagged else 0) and len(out.error_lines) == len(warnings)
        if flagged:
            assert f"{flagged} of {len(rows)} designs flagged" in warnings[0]
        outcome = assert_flagged_results(results)
    COUNTS["design files"][outcome] += 1
