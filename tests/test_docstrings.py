"""One docstring style across hisopt: numpydoc sections (issue 23, habits).

The rule, checked on every module, class and function docstring under ``hisopt/`` (read with
``ast``, so nothing is imported):

1. A docstring parses as numpydoc: :class:`numpydoc.docscrape.NumpyDocString` (numpydoc's own
   parser, the one its Sphinx extension and ``numpydoc.validate`` use) accepts it without a
   warning (no unknown or repeated section).
2. Every entry of a ``Parameters``, ``Other Parameters``, ``Attributes``, ``Returns``,
   ``Yields``, ``Receives``, ``Raises`` or ``Warns`` section has an indented description. An entry
   written on one line as ``name : description`` parses as a name whose *type* is the description
   and whose description is empty, so this is what catches the old one-line style. One form
   numpydoc allows stays allowed: a ``Returns``/``Yields``/``Raises``/``Warns`` entry that is a
   bare type (``TimeResponse``, ``ndarray, shape (4, 3)``) when the summary already says what it is.
3. Outside those sections no line looks like an entry (``name : text`` or ``a, b : text`` at the
   start of a line): a parameter list must sit under its section header.

Why numpydoc's parser and not ``numpydoc.validate`` or ruff's ``D`` rules: ``validate`` imports
each object and also demands content this habit does not ask for (a capitalised description
ending with a period, every parameter documented, examples); ruff's pydocstyle rules with
``convention = "numpy"`` check section headers and underlines (pyproject.toml enforces that
subset) but not the shape of an entry, so neither rejects ``name : description``. The parser does
the parsing; this test states which of its results are errors.
"""

from __future__ import annotations

import ast
import re
import warnings
from pathlib import Path

import pytest
from numpydoc.docscrape import NumpyDocString

PACKAGE = Path(__file__).resolve().parents[1] / "hisopt"

# sections whose entries are "name : type" lines, each followed by an indented description
ENTRY_SECTIONS = ("Parameters", "Other Parameters", "Attributes", "Returns", "Yields", "Receives", "Raises", "Warns")
# an entry line: one name or a comma list of names (optionally starred), " : ", then text
ENTRY_LINE = re.compile(r"^\s*\*{0,2}\w+(?:, ?\*{0,2}\w+)* : \S")
# sections whose unnamed entries may be a bare type, and what a bare type looks like: dotted names,
# brackets and "|" joined by ", ", " | " or " or ", optionally followed by ", shape ..."
TYPE_ONLY_SECTIONS = ("Returns", "Yields", "Raises", "Warns")
BARE_TYPE = re.compile(r"[\w.\[\]|]+(?:(?:, | \| | or | of )[\w.\[\]|]+)*(?:, shape \S.*)?")


def docstring_problems(doc: str) -> list[str]:
    """Problems of one (cleaned) docstring under the module rule; empty when it follows it.

    Parameters
    ----------
    doc : str
        The docstring as :func:`ast.get_docstring` returns it (indentation removed).

    Returns
    -------
    list of str
        One line per problem: the section and entry, or the stray entry-like line.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            parsed = NumpyDocString(doc)
        except Exception as exc:  # numpydoc raises ParseError or warns (unknown section)
            return [f"not numpydoc: {exc}"]
    problems = []
    for section in ENTRY_SECTIONS:
        for entry in parsed[section]:
            if any(line.strip() for line in entry.desc):
                continue
            if section in TYPE_ONLY_SECTIONS and not entry.name and BARE_TYPE.fullmatch(entry.type):
                continue
            label = " : ".join(part for part in (entry.name, entry.type) if part)
            problems.append(f"{section}: entry without an indented description: {label!r}")
    # the text numpydoc left outside the entry sections
    free = [*parsed["Summary"], *parsed["Extended Summary"], *parsed["Notes"], *parsed["Warnings"], *parsed["References"], *parsed["Examples"]]
    problems += [f"entry outside a section (add a Parameters/Returns/Attributes header): {line.strip()!r}" for line in free if ENTRY_LINE.match(line)]
    return problems


def package_docstrings() -> list[tuple[str, str]]:
    """``(where, docstring)`` of every module, class and function of the package."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        rel = path.relative_to(PACKAGE.parent).as_posix()
        for node in ast.walk(tree):
            if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
                doc = ast.get_docstring(node, clean=True)
                if doc:
                    found.append((f"{rel}:{getattr(node, 'lineno', 1)} {getattr(node, 'name', '<module>')}", doc))
    return found


def test_package_docstrings_use_numpydoc_sections():
    docs = package_docstrings()
    assert len(docs) > 500  # the walk found the package (about 1,000 docstrings), not an empty folder
    bad = [f"{where}: {problem}" for where, doc in docs for problem in docstring_problems(doc)]
    assert not bad, f"{len(bad)} docstring problem(s):\n" + "\n".join(bad)


GOOD = """Mean square of a PSD.

Parameters
----------
f_hz : numpy.ndarray
    [Hz] Frequencies.
psd, weights : numpy.ndarray
    [unit^2/Hz] and [Hz].

Returns
-------
float
    [unit^2] The integral (docs/model.md section 5).

Raises
------
ValueError
    The shapes differ.
"""


@pytest.mark.parametrize(
    "doc, expected",
    [
        # the old one-line style inside a section: the description lands in the type slot
        ("Mean square.\n\nParameters\n----------\nf_hz : [Hz] frequencies\n", "entry without an indented description: 'f_hz : [Hz] frequencies'"),
        ("Areas.\n\nReturns\n-------\n(A_t, A_b) : [m^2]\n", "Returns: entry without an indented description"),
        ("A record.\n\nAttributes\n----------\nx : [m] position\n", "Attributes: entry without an indented description"),
        ("Checked.\n\nRaises\n------\nValueError : the shapes differ\n", "Raises: entry without an indented description: 'ValueError : the shapes"),
        # prose where the type of an unnamed return belongs
        ("Dominance.\n\nReturns\n-------\nBoolean array of shape ``(m, n)``.\n", "Returns: entry without an indented description: 'Boolean array"),
        # a parameter list with no section header at all
        ("Mean square.\n\nf_hz : [Hz] frequencies\npsd : [unit^2/Hz] the PSD\n", "entry outside a section"),
        ("Mean square.\n\nNotes\n-----\na, b : [m] the ends\n", "entry outside a section"),
        # not numpydoc at all: an unknown section header
        ("Mean square.\n\nArguments\n---------\nf_hz : float\n    [Hz] frequency.\n", "not numpydoc"),
    ],
)
def test_rule_rejects_the_old_style(doc, expected):
    problems = docstring_problems(doc)
    assert any(expected in problem for problem in problems), problems


def test_rule_accepts_numpydoc_and_prose():
    assert docstring_problems(GOOD) == []
    # a bare type as the whole Returns or Raises entry is numpydoc too
    assert docstring_problems("Run it.\n\nReturns\n-------\nTimeResponse\n\nRaises\n------\nValueError\n") == []
    assert docstring_problems("Map.\n\nReturns\n-------\nndarray, shape (4, 3)\n") == []
    # prose with a colon and one-line docstrings stay allowed
    assert docstring_problems("[Pa] Pressure rise: see docs/model.md section 4.") == []
    assert docstring_problems("Summary.\n\nThe ratio x/y : a number, not an entry (starts with 'The ratio').") == []
