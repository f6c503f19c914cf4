"""The model documentation lives in ``docs/`` and cannot drift from the code.

- No reference to the old out-of-repository design file remains in the sources, problem
  files, README, notebooks, docs or tests.
- Every ``docs/<file>.md §N`` reference (and every bare ``§N`` inside ``docs/model.md``)
  names a numbered section heading that exists.
- The reference-value tables of ``docs/model.md`` §7.1 match ``Problem.evaluate`` within the
  0.1 % the other reference tests use, and cover every quantity of the objective registry.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from hisopt.coupled.operating_point import accumulator_quantities
from hisopt.metrics import METRICS
from hisopt.problem import problem_from_dict
from tests.conftest import every_quantity

ROOT = Path(__file__).resolve().parents[1]
MODEL_DOC = ROOT / "docs" / "model.md"
SCANNED = ("hisopt", "problems", "notebooks", "docs", "tests", "benchmarks", "README.md")
SUFFIXES = {".py", ".toml", ".md", ".ipynb", ".csv", ".txt"}

OLD_REFERENCE = re.compile(r"\bDESIGN\b")
"""The old design file was cited as "DESIGN section N", "DESIGN sec. N", "DESIGN.md", ..."""

HEADING = re.compile(r"^#{1,6}\s+(\d+(?:\.\d+)*)\.?\s", re.MULTILINE)
DOC_REFERENCE = re.compile(r"(docs/[\w./-]+\.md)`?((?:(?:\s*,\s*|\s+and\s+|\s*-\s*|\s+)?§\s?\d+(?:\.\d+)*)+)")
SECTION = re.compile(r"§\s?(\d+(?:\.\d+)*)")


def _files() -> list[Path]:
    out = []
    for name in SCANNED:
        path = ROOT / name
        candidates = [path] if path.is_file() else sorted(path.rglob("*"))
        out += [p for p in candidates if p.is_file() and p.suffix in SUFFIXES and ".ipynb_checkpoints" not in p.parts]
    return [p for p in out if p != Path(__file__).resolve()]


def _sections(doc: Path) -> set[str]:
    return set(HEADING.findall(doc.read_text(encoding="utf-8")))


def test_no_reference_to_the_old_design_file():
    hits = []
    for path in _files():
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if OLD_REFERENCE.search(line):
                hits.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()}")
    assert not hits, "cite docs/model.md §N instead:\n" + "\n".join(hits)


def test_model_doc_has_the_numbered_sections():
    sections = _sections(MODEL_DOC)
    assert {str(n) for n in range(1, 11)} <= sections
    assert {"3.2", "3.7", "5.3", "6.2", "7.1", "10.3"} <= sections


def test_every_docs_section_reference_exists():
    checked, broken = 0, []
    for path in _files():
        text = path.read_text(encoding="utf-8")
        for match in DOC_REFERENCE.finditer(text):
            doc = ROOT / match.group(1)
            numbers = SECTION.findall(match.group(2))
            checked += len(numbers)
            if not doc.is_file():
                broken.append(f"{path.relative_to(ROOT)}: {match.group(0)!r}: no file {match.group(1)}")
                continue
            missing = [n for n in numbers if n not in _sections(doc)]
            if missing:
                broken.append(f"{path.relative_to(ROOT)}: {match.group(0)!r}: no section {', '.join(missing)}")
    assert checked > 20  # the code does cite the documentation
    assert not broken, "\n".join(broken)


def test_model_doc_internal_section_references_exist():
    text = MODEL_DOC.read_text(encoding="utf-8")
    sections = _sections(MODEL_DOC)
    missing = sorted({n for n in SECTION.findall(text) if n not in sections})
    assert not missing, f"docs/model.md cites sections it lacks: {missing}"


def _reference_tables() -> dict[tuple[float, ...], dict[str, float]]:
    """The tables of docs/model.md §7.1: design tuple -> {quantity: value}."""
    text = MODEL_DOC.read_text(encoding="utf-8")
    start = text.index("### 7.1")
    section = text[start : text.index("\n### ", start + 1)]
    values: dict[tuple[float, ...], dict[str, float]] = {}
    names: list[str] = []
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("| design"):
            names = [c.split()[0] for c in cells[1:]]
        elif line.startswith("| ("):
            design = tuple(float(v) for v in cells[0].strip("()").split(","))
            values.setdefault(design, {}).update(zip(names, (float(c) for c in cells[1:]), strict=True))
    return values


def test_reference_tables_match_the_evaluator(problem):
    tables = _reference_tables()
    assert len(tables) == 2
    for quantities in tables.values():
        # every quantity has documented reference values, but the swing, which only a charged
        # HIS has (its checks: tests/test_accumulator_swing.py, docs/model.md §16.9), and the
        # buildability rules (tests/test_buildability.py, §21)
        assert set(quantities) == {name for name, m in METRICS.items() if m.kind not in ("swing", "build")}
    data = problem.spec.model_dump(by_alias=True)
    objectives, constraints = every_quantity()
    static = ("static_gas_fraction", "static_pressure_ratio", "pressure_rating_usage")  # +inf at p0 = 0 fails a design
    data["objectives"], data["constraints"] = objectives, [c for c in constraints if c["name"] not in static]
    everything = problem_from_dict(data, "all-metrics")
    designs = np.array(list(tables))
    df = everything.evaluate(designs)
    accumulators = accumulator_quantities(problem.model(designs).his)  # what the evaluator reads them from
    for i, (row, expected) in enumerate(zip(df.itertuples(), tables.values(), strict=True)):
        for name, value in expected.items():
            got = accumulators[name][i] if name in static else getattr(row, name)
            assert got == pytest.approx(value, rel=1e-3), (name, row)
