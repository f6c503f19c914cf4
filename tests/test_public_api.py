"""One public API: what README, docs, notebooks and examples import is public, and nothing else.

Public means a name of ``hisopt.__all__``, or of the ``__all__`` of a documented sub-package
(``hisopt._DOCUMENTED_SUBPACKAGES``: hisopt.plotting, hisopt.report, hisopt.road). The
checker reads every code block of README.md and docs/*.md (fenced and indented), every code
cell of notebooks/*.ipynb and every examples/*.py, and reports each ``import``/``from`` of a
hisopt name, and each ``hisopt.a.b`` attribute path, that is not public. Its own unit tests
below show that it fails on a private import. The old module paths of issue 23 still import,
with a DeprecationWarning naming the new path, as the very same module object.
"""

from __future__ import annotations

import ast
import importlib
import json
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import hisopt
from tests.conftest import ROOT

SOURCES = ("README.md", "docs/*.md", "notebooks/*.ipynb", "examples/*.py")
FENCED = re.compile(r"^(?P<fence>```+|~~~+)[^\n]*\n(?P<code>.*?)^(?P=fence)[ \t]*$", re.S | re.M)
IMPORT_LINE = re.compile(r"(?:from\s+hisopt[\w.]*\s+import\s+[\w ,]+|import\s+hisopt[\w.]*(?:\s+as\s+\w+)?)")
"""An import statement inside a block that is not Python as a whole (a shell line, ``python -c``)."""


def public_names() -> dict[str, set[str]]:
    """Module -> its public names: ``hisopt`` and each documented sub-package."""
    public = {"hisopt": set(hisopt.__all__) | {"__version__"}}
    for package in hisopt._DOCUMENTED_SUBPACKAGES:
        public[package] = set(importlib.import_module(package).__all__)
    return public


def markdown_blocks(text: str) -> list[tuple[int, str]]:
    """(line, code) of every fenced block and every indented block outside them."""
    blocks, outside, last = [], [], 0
    for match in FENCED.finditer(text):
        blocks.append((text.count("\n", 0, match.start("code")) + 1, match.group("code")))
        outside.append(text[last : match.start()])
        last = match.end()
    outside.append(text[last:])
    offset = 0
    for chunk in outside:
        start = text.index(chunk, offset) if chunk else offset
        offset = start + len(chunk)
        lines = chunk.split("\n")
        i = 0
        while i < len(lines):
            # an indented block starts after a blank line (a list item's continuation does not)
            if lines[i].startswith("    ") and lines[i].strip() and (i == 0 or not lines[i - 1].strip()):
                j = i
                while j < len(lines) and (lines[j].startswith("    ") or not lines[j].strip()):
                    j += 1
                blocks.append((text.count("\n", 0, start) + i + 1, textwrap.dedent("\n".join(lines[i:j]))))
                i = j
            else:
                i += 1
    return blocks


def notebook_cells(path: Path) -> list[tuple[int, str]]:
    """(cell number, code) of a notebook's code cells, IPython magics and shell lines dropped."""
    cells = json.loads(path.read_text(encoding="utf-8"))["cells"]
    out = []
    for number, cell in enumerate(cells):
        if cell["cell_type"] == "code":
            source = "".join(cell["source"])
            out.append((number, "\n".join(line for line in source.splitlines() if not line.lstrip().startswith(("%", "!")))))
    return out


def code_blocks(path: Path) -> list[tuple[int, str]]:
    if path.suffix == ".md":
        return markdown_blocks(path.read_text(encoding="utf-8"))
    if path.suffix == ".ipynb":
        return notebook_cells(path)
    return [(1, path.read_text(encoding="utf-8"))]


def _attribute_path(node: ast.Attribute) -> list[str] | None:
    """``hisopt.a.b`` -> ["hisopt", "a", "b"]; None for a chain not rooted at the name hisopt."""
    parts: list[str] = []
    current: ast.expr = node
    while isinstance(current, ast.Attribute):
        parts.insert(0, current.attr)
        current = current.value
    return ["hisopt", *parts] if isinstance(current, ast.Name) and current.id == "hisopt" else None


def hisopt_uses(code: str) -> tuple[list[str], bool]:
    """The hisopt names a block uses, as dotted paths ("hisopt.road.step_profile", "hisopt"),
    and whether the block parsed as Python (else only its import statements were read)."""
    try:
        tree = ast.parse(code)
        parsed = True
    except SyntaxError:
        statements = []
        for match in IMPORT_LINE.finditer(code):
            try:
                statements.append(ast.parse(match.group(0).strip()))
            except SyntaxError:  # e.g. an import cut by a line break: still a hisopt import
                statements.append(ast.parse("import " + match.group(0).split()[1]))
        tree, parsed = ast.Module(body=[s for t in statements for s in t.body], type_ignores=[]), False
    uses: list[str] = []
    seen_attributes: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            uses += [alias.name for alias in node.names if alias.name.split(".")[0] == "hisopt"]
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "hisopt" and not node.level:
            uses += [f"{node.module}.{alias.name}" for alias in node.names]
        elif isinstance(node, ast.Attribute) and id(node) not in seen_attributes:
            path = _attribute_path(node)
            if path:
                uses.append(".".join(path))
                inner = node.value  # the shorter chains of this one are not separate uses
                while isinstance(inner, ast.Attribute):
                    seen_attributes.add(id(inner))
                    inner = inner.value
    return uses, parsed


def is_public(dotted: str, public: dict[str, set[str]]) -> bool:
    """Whether ``hisopt.x[.y...]`` stays within the public names (attributes of a public object are its own business)."""
    parts = dotted.split(".")
    if parts == ["hisopt"]:
        return True
    module = "hisopt"
    for part in parts[1:]:
        if f"{module}.{part}" in public:  # a documented sub-package: go on inside it
            module = f"{module}.{part}"
            continue
        return part in public[module]
    return True  # the sub-package itself


def private_uses(code: str, public: dict[str, set[str]]) -> list[str]:
    return [use for use in hisopt_uses(code)[0] if not is_public(use, public)]


def _source_files() -> list[Path]:
    return sorted(p for pattern in SOURCES for p in ROOT.glob(pattern))


# --- the checker can fail --------------------------------------------------------------------


def test_checker_flags_private_imports_and_paths():
    public = public_names()
    assert private_uses("from hisopt.evaluation.evaluate import Evaluator", public) == ["hisopt.evaluation.evaluate.Evaluator"]
    assert private_uses("import hisopt.evaluation.evaluate as ev", public) == ["hisopt.evaluation.evaluate"]
    assert private_uses("from hisopt import _LAZY, Evaluator", public) == ["hisopt._LAZY"]
    assert private_uses("from hisopt.road import interpolation", public) == ["hisopt.road.interpolation"]
    assert private_uses("import hisopt\np = hisopt.problem.problem_from_dict(d)", public) == ["hisopt.problem.problem_from_dict"]
    assert private_uses("from hisopt.evaluate import Evaluator", public) == ["hisopt.evaluate.Evaluator"]  # deprecated paths too
    # a shell block is not Python: its import statements are still read
    assert private_uses('python -c "from hisopt.units import display_frame; print(1)"', public) == ["hisopt.units.display_frame"]


def test_checker_passes_public_imports():
    public = public_names()
    code = """
import hisopt
from hisopt import Evaluator, load_problem, sweep
from hisopt.road import random_profile
from hisopt.plotting import COLORS
import hisopt.report
problem = hisopt.load_problem("p.toml")
run = hisopt.optimize(problem).front.columns
x = hisopt.road.step_profile
"""
    assert private_uses(code, public) == []
    assert private_uses('python -c "import hisopt; print(hisopt.__version__)"', public) == []


def test_checker_finds_fenced_and_indented_blocks():
    text = (
        "Prose `hisopt.x`.\n\n```python\nfrom hisopt.kernels import a\n```\n\n"
        "- item\n    continued\n\nText:\n\n    import hisopt.evaluation\n    y = 1\n\nEnd.\n"
    )
    blocks = markdown_blocks(text)
    assert [code.strip() for _, code in blocks] == ["from hisopt.kernels import a", "import hisopt.evaluation\ny = 1"]
    assert [line for line, _ in blocks] == [4, 12]
    flagged = [use for _, code in blocks for use in private_uses(code, public_names())]
    assert flagged == ["hisopt.kernels.a", "hisopt.evaluation"]  # prose and list continuations are not code


# --- the documentation, notebooks and examples -----------------------------------------------


def test_docs_notebooks_and_examples_import_only_public_names():
    public = public_names()
    files = _source_files()
    assert {p.suffix for p in files} == {".md", ".ipynb", ".py"}  # every kind of source was found
    uses, bad = 0, []
    for path in files:
        for where, code in code_blocks(path):
            found, _ = hisopt_uses(code)
            uses += len(found)
            bad += [f"{path.relative_to(ROOT)}:{where}: {use}" for use in found if not is_public(use, public)]
    assert uses > 50  # the scan does see the imports and hisopt.* calls (about 90 today)
    assert not bad, "import these from hisopt (or a documented sub-package) instead:\n" + "\n".join(bad)


# --- the public API itself --------------------------------------------------------------------


def test_all_and_dir_agree():
    eager = {"ConfigError", "HisoptError", "ModelError", "PlausibilityWarning", "ProblemFileNotFoundError", "RunError"}
    assert hisopt.__all__ == sorted(set(hisopt.__all__))  # sorted, no repeats
    assert set(hisopt.__all__) == eager | set(hisopt._LAZY)
    assert set(hisopt.__all__) <= set(dir(hisopt))
    for name in hisopt.__all__:
        assert getattr(hisopt, name) is not None
        if name in hisopt._LAZY:  # the lazy name is the object its module defines
            assert getattr(hisopt, name) is getattr(importlib.import_module(hisopt._LAZY[name]), name)
    for package in hisopt._DOCUMENTED_SUBPACKAGES:
        module = importlib.import_module(package)
        assert module.__all__ == sorted(set(module.__all__))
        assert set(module.__all__) <= set(dir(module))
        assert all(getattr(module, name) is not None for name in module.__all__)
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        _ = hisopt.no_such_name


def test_import_hisopt_stays_light():
    code = "import sys, hisopt; print(sorted(m for m in ('numpy', 'scipy', 'pandas', 'plotly', 'pymoo', 'casadi') if m in sys.modules))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert done.stdout.strip() == "[]"


# --- old module paths -------------------------------------------------------------------------


def _forget(old: str) -> None:
    """Drop an alias from sys.modules and from its parent, so that the next import finds it again."""
    sys.modules.pop(old, None)
    parent, _, child = old.rpartition(".")
    if parent in sys.modules and isinstance(sys.modules[parent].__dict__.get(child), type(sys)):
        delattr(sys.modules[parent], child)


@pytest.mark.parametrize("old", sorted(hisopt._MOVED))
def test_old_module_path_is_the_new_module_with_a_warning(old):
    new = hisopt._MOVED[old]
    assert not (ROOT / (old.replace(".", "/") + ".py")).exists()  # served by the finder, not by a shim file
    _forget(old)
    try:
        with pytest.warns(DeprecationWarning, match=re.escape(f"{old} is deprecated")) as record:
            module = importlib.import_module(old)
        assert module is importlib.import_module(new)
        assert new in str(record[0].message)
        assert module.__spec__.name == new  # the new module keeps its own identity
    finally:
        _forget(old)


def test_from_old_path_import_gives_the_same_object_and_warns_at_the_import_line():
    from hisopt.evaluation.evaluate import Evaluator as new

    _forget("hisopt.evaluate")
    try:
        with pytest.warns(DeprecationWarning, match=r"hisopt\.evaluation\.evaluate") as record:
            from hisopt.evaluate import Evaluator as old  # noqa: I001
        assert old is new is hisopt.Evaluator
        assert record[0].filename == __file__  # points at the user's import, not at importlib
    finally:
        _forget("hisopt.evaluate")


def test_unknown_old_path_still_fails():
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("hisopt.no_such_module")
