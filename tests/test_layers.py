"""The package's layers (docs/model.md §11.1): imports run one way, down.

``LAYERS`` below is the one statement of the layer order, top to bottom; docs/model.md §11.1
shows it as a table, and a test here checks that the table says the same. The walk reads every
module of ``hisopt`` with :mod:`ast` (nothing is imported, so a module that fails to import
still gets checked) and fails on

- an import of a module in a higher layer (down and sideways within a layer are fine);
- an import cycle between modules;
- plotly imported anywhere but ``hisopt.plotting`` and ``hisopt.report``;
- ``hisopt.plotting`` importing any hisopt module other than itself and the small leaves;
- a module that no layer claims (so a new folder must be placed before it can land).

Which imports count: every ``import`` and ``from ... import`` at module level, inside
functions and classes (lazy imports run too, just later) and inside ``try`` blocks; calls to
``importlib.import_module`` with a literal name; and, in a module that calls ``import_module``
with a computed name (the package root's lazy exports), every hisopt module named by a string
literal in that module. Imports under ``if TYPE_CHECKING:`` are not counted: they never run,
they only name types for annotations (the ``else:`` branch of such an ``if`` does run and
counts). Importing ``a.b.c`` is counted as an import of ``a.b.c`` only, not of the packages
``a`` and ``a.b`` whose ``__init__`` Python also runs, so that ``import hisopt.errors`` is not
an import of the package root.

The unit tests at the end run the checker on small synthetic packages, so that each kind of
failure is shown to be caught.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

import networkx as nx
import pytest

from tests.conftest import ROOT

PACKAGE = "hisopt"

LAYERS: list[list[str]] = [
    # the package root: the public API (lazy exports); matches the bare package name only
    ["hisopt"],
    # interfaces
    ["hisopt.__main__", "hisopt.cli", "hisopt.report"],
    # studies: sweeps, spectra, layout screening, layout study
    ["hisopt.studies"],
    # optimisation: the CasADi/IPOPT refinement over the runs, archive and decisions
    ["hisopt.optim.gradient"],
    ["hisopt.optim"],
    # simulation: time domain, nonlinear model, drop tests, identification
    ["hisopt.simulation"],
    ["hisopt.problem"],
    # evaluation: evaluator, kernels, quadrature, poles and residues, channels, transient, ...
    ["hisopt.evaluation"],
    # the problem specification: config, design space, designs, validation
    ["hisopt.specification"],
    # the coupled car + HIS
    ["hisopt.coupled"],
    # the physics wings over the standards they read
    ["hisopt.vehicle", "hisopt.hydraulics", "hisopt.road"],
    ["hisopt.standards"],
    # plotting: draws the data handed to it; imports only plotly and the small leaves
    ["hisopt.plotting"],
    # the small leaves at the package root: they import only each other
    [
        "hisopt.constants",
        "hisopt.errors",
        "hisopt.units",
        "hisopt.quantities",
        "hisopt.metrics",
        "hisopt.io",
        "hisopt.folders",
        "hisopt.linalg",
        "hisopt.interrupt",
        "hisopt.robust",
        "hisopt.plausibility",
        "hisopt.arguments",
        "hisopt.version",
    ],
]
PLOTLY_ALLOWED = ("hisopt.plotting", "hisopt.report")
PLOTTING = "hisopt.plotting"


@dataclass(frozen=True)
class Import:
    """One counted import: ``source`` (a module of the package) imports ``target`` at ``line``."""

    source: str
    target: str  # a module of the package, or a third-party dotted name
    line: int


# --- the checker ---------------------------------------------------------------------------


def _under(name: str, prefix: str) -> bool:
    """``name`` is ``prefix`` or inside it (``a.bc`` is not inside ``a.b``)."""
    return name == prefix or name.startswith(prefix + ".")


def modules(root: Path) -> dict[str, Path]:
    """Dotted module name -> file, for every ``.py`` under the package directory ``root``."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        name = ".".join(path.relative_to(root.parent).with_suffix("").parts).removesuffix(".__init__")
        out[name] = path
    return out


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _is_import_module(func: ast.expr) -> bool:
    return (isinstance(func, ast.Name) and func.id in {"import_module", "__import__"}) or (isinstance(func, ast.Attribute) and func.attr == "import_module")


class _Collector(ast.NodeVisitor):
    """Raw imported names of one module, skipping ``if TYPE_CHECKING:`` bodies."""

    def __init__(self, package: str) -> None:
        self.package = package  # the package relative imports start from
        self.names: list[tuple[str, list[str], int]] = []  # (base, imported names, line)
        self.strings: list[tuple[str, int]] = []
        self.dynamic = False  # import_module with a computed name

    def visit_If(self, node: ast.If) -> None:
        if _is_type_checking(node.test):
            for child in node.orelse:  # the else branch runs
                self.visit(child)
        else:
            self.generic_visit(node)

    def visit_Import(self, node: ast.Import) -> None:
        for alias in node.names:
            self.names.append((alias.name, [], node.lineno))

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        base = node.module or ""
        if node.level:
            parts = self.package.split(".")
            base = ".".join(parts[: len(parts) - node.level + 1] + ([base] if base else []))
        self.names.append((base, [alias.name for alias in node.names], node.lineno))

    def visit_Call(self, node: ast.Call) -> None:
        if _is_import_module(node.func) and node.args:
            arg = node.args[0]
            if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                self.names.append((arg.value, [], node.lineno))
            else:
                self.dynamic = True
        self.generic_visit(node)

    def visit_Constant(self, node: ast.Constant) -> None:
        if isinstance(node.value, str):
            self.strings.append((node.value, node.lineno))


def imports(root: Path) -> list[Import]:
    """Every counted import of every module under the package directory ``root``.

    A target inside the package is resolved to the module that runs (``from a.b import c`` is
    ``a.b.c`` if that is a module, else ``a.b``); a third-party target keeps its dotted name.
    """
    mods = modules(root)

    def resolve(name: str) -> str | None:
        while name and name not in mods:
            name = name.rpartition(".")[0]
        return name or None

    out: list[Import] = []
    for mod, path in mods.items():
        collector = _Collector(mod if path.name == "__init__.py" else mod.rpartition(".")[0])
        collector.visit(ast.parse(path.read_text(encoding="utf-8"), filename=str(path)))
        found: list[tuple[str, int]] = []
        for base, names, line in collector.names:
            if _under(base, root.name):
                found += [(resolve(f"{base}.{n}") if f"{base}.{n}" in mods else resolve(base), line) for n in names or [""]]
            else:
                found.append((base, line))
        if collector.dynamic:  # a computed import_module name: any module the file names may be meant
            found += [(s, line) for s, line in collector.strings if s in mods]
        seen = set()
        for target, line in found:
            if target and target != mod and target not in seen:
                seen.add(target)
                out.append(Import(mod, target, line))
    return out


def layer_of(module: str, layers: list[list[str]], package: str = PACKAGE) -> int | None:
    """Index of the layer whose longest prefix claims ``module`` (the bare package: exact only)."""
    best: tuple[int, int] | None = None  # (prefix length, layer)
    for index, prefixes in enumerate(layers):
        for prefix in prefixes:
            if module == prefix or (prefix != package and _under(module, prefix)):
                if best is None or len(prefix) > best[0]:
                    best = (len(prefix), index)
    return None if best is None else best[1]


def _where(root: Path, imp: Import) -> str:
    path = modules(root)[imp.source].relative_to(root.parent)
    return f"{path}:{imp.line}: {imp.source} imports {imp.target}"


def unplaced(root: Path, layers: list[list[str]]) -> list[str]:
    """Modules no layer claims."""
    return [m for m in modules(root) if layer_of(m, layers, root.name) is None]


def upward(root: Path, layers: list[list[str]]) -> list[str]:
    """Imports of a module in a higher layer (a smaller index), one line each."""
    out = []
    for imp in imports(root):
        if not _under(imp.target, root.name):
            continue
        source, target = layer_of(imp.source, layers, root.name), layer_of(imp.target, layers, root.name)
        if source is not None and target is not None and target < source:
            out.append(f"{_where(root, imp)} (layer {source} imports layer {target})")
    return out


def cycles(root: Path) -> list[list[str]]:
    """One import cycle (a closed path of modules) for each strongly connected set."""
    graph = nx.DiGraph()
    graph.add_edges_from((i.source, i.target) for i in imports(root) if _under(i.target, root.name))
    out = []
    for component in nx.strongly_connected_components(graph):
        if len(component) > 1:
            path = [u for u, _ in nx.find_cycle(graph.subgraph(component))]
            start = path.index(min(path))  # start at the smallest name, so the report is stable
            path = path[start:] + path[:start]
            out.append([*path, path[0]])
    return sorted(out)


def plotly_outside(root: Path, allowed: tuple[str, ...] = PLOTLY_ALLOWED) -> list[str]:
    """Imports of plotly by modules outside ``allowed``."""
    return [_where(root, imp) for imp in imports(root) if _under(imp.target, "plotly") and not any(_under(imp.source, a) for a in allowed)]


def plotting_beyond_leaves(root: Path, layers: list[list[str]], plotting: str = PLOTTING) -> list[str]:
    """Imports by the plotting layer of package modules other than its own and the leaves."""
    leaves = len(layers) - 1
    out = []
    for imp in imports(root):
        if _under(imp.source, plotting) and _under(imp.target, root.name) and not _under(imp.target, plotting):
            if layer_of(imp.target, layers, root.name) != leaves:
                out.append(_where(root, imp))
    return out


# --- hisopt itself -------------------------------------------------------------------------

HISOPT = ROOT / PACKAGE


def test_every_module_has_a_layer():
    assert not unplaced(HISOPT, LAYERS), "place these modules in tests/test_layers.py LAYERS and docs/model.md §11.1"


def test_no_import_runs_up_the_layers():
    found = upward(HISOPT, LAYERS)
    assert not found, "imports that run up the layers (docs/model.md §11.1):\n" + "\n".join(found)


def test_no_import_cycles():
    found = cycles(HISOPT)
    assert not found, "import cycles:\n" + "\n".join(" -> ".join(c) for c in found)


def test_only_plotting_and_report_import_plotly():
    found = plotly_outside(HISOPT)
    assert not found, "plotly belongs in hisopt/plotting (or hisopt/report):\n" + "\n".join(found)


def test_plotting_imports_only_the_leaves():
    found = plotting_beyond_leaves(HISOPT, LAYERS)
    assert not found, "hisopt/plotting draws data handed to it and imports only the small leaves:\n" + "\n".join(found)


def test_the_walk_sees_the_package():
    """The checks above are not vacuous: the walk finds the imports known to be there."""
    found = {(i.source, i.target) for i in imports(HISOPT)}
    assert len(modules(HISOPT)) > 80 and len(found) > 200
    assert ("hisopt.evaluation.evaluate", "hisopt.coupled.response") in found
    assert ("hisopt.evaluation.evaluate", "hisopt.evaluation.psd") in found  # `from hisopt.evaluation import psd`
    assert ("hisopt.plotting.figures", "plotly.graph_objects") in found
    assert ("hisopt", "hisopt.optim.run") in found  # the root's lazy export map


def _doc_layers() -> list[list[str]]:
    """The paths of docs/model.md §11.1's layer table, row by row."""
    text = (ROOT / "docs" / "model.md").read_text(encoding="utf-8")
    section = text.split("### 11.1 ", 1)[1].split("\n### ", 1)[0]
    rows = [line for line in section.splitlines() if line.startswith("| ") and "`hisopt" in line]
    return [[p for p in line.split("|")[3].replace("`", "").replace(",", " ").split()] for line in rows]


def _as_path(prefix: str) -> str:
    path = prefix.replace(".", "/")
    if prefix == PACKAGE:
        return f"{PACKAGE}/__init__.py"
    return f"{path}/" if (ROOT / path).is_dir() else f"{path}.py"


def test_docs_show_the_same_layers():
    assert _doc_layers() == [[_as_path(p) for p in layer] for layer in LAYERS]


# --- the checker on small synthetic packages -----------------------------------------------

SYNTHETIC_LAYERS = [["pkg"], ["pkg.top"], ["pkg.mid"], ["pkg.draw"], ["pkg.leaf", "pkg.leaf2"]]


def _package(tmp_path: Path, files: dict[str, str]) -> Path:
    root = tmp_path / "pkg"
    for name, text in {"__init__.py": "", "top.py": "", "leaf.py": "", "leaf2.py": "", "draw/__init__.py": "",
                       "mid/__init__.py": "", "mid/a.py": "", "mid/b.py": "", **files}.items():  # fmt: skip
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return root


def test_checker_passes_a_clean_package(tmp_path):
    root = _package(tmp_path, {
        "top.py": "import pkg.mid.a\nfrom pkg import leaf\n",
        "mid/a.py": "from . import b\nfrom ..leaf import x\nimport numpy\n",
        "mid/b.py": "from pkg.leaf2 import y\n",
        "draw/__init__.py": "import plotly.graph_objects as go\nfrom pkg.leaf import z\n",
        "leaf.py": "import pkg.leaf2\n",
        "__init__.py": "from importlib import import_module\n_LAZY = {'f': 'pkg.top'}\n"
                       "def __getattr__(n):\n    return import_module(_LAZY[n])\n",
    })  # fmt: skip
    assert {(i.source, i.target) for i in imports(root)} == {
        ("pkg.top", "pkg.mid.a"), ("pkg.top", "pkg.leaf"), ("pkg.mid.a", "pkg.mid.b"), ("pkg.mid.a", "pkg.leaf"),
        ("pkg.mid.a", "numpy"), ("pkg.mid.b", "pkg.leaf2"), ("pkg.draw", "plotly.graph_objects"),
        ("pkg.draw", "pkg.leaf"), ("pkg.leaf", "pkg.leaf2"), ("pkg", "importlib"), ("pkg", "pkg.top"),
    }  # fmt: skip
    assert not unplaced(root, SYNTHETIC_LAYERS)
    assert not upward(root, SYNTHETIC_LAYERS)
    assert not cycles(root)
    assert not plotly_outside(root, ("pkg.draw",))
    assert not plotting_beyond_leaves(root, SYNTHETIC_LAYERS, "pkg.draw")


@pytest.mark.parametrize(
    "text",
    [
        "import pkg.top\n",  # top level
        "from pkg import top\n",  # from the package: resolves to the module
        "from .. import top\n",  # relative
        "def f():\n    from pkg.top import g\n",  # lazy, inside a function
        "class C:\n    def f(self):\n        import pkg.top\n",  # inside a method
        "try:\n    import pkg.top\nexcept ImportError:\n    pass\n",
        "import importlib\ndef f():\n    return importlib.import_module('pkg.top')\n",
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    pass\nelse:\n    import pkg.top\n",
    ],
)
def test_checker_finds_an_upward_import(tmp_path, text):
    root = _package(tmp_path, {"mid/a.py": text})
    found = upward(root, SYNTHETIC_LAYERS)
    assert len(found) == 1 and "pkg.mid.a imports pkg.top" in found[0] and "layer 2 imports layer 1" in found[0]
    assert found[0].startswith("pkg/mid/a.py:")


def test_checker_finds_an_import_of_the_package_root(tmp_path):
    root = _package(tmp_path, {"mid/a.py": "from pkg import __version__\n", "__init__.py": "__version__ = '1'\n"})
    assert [line.split(": ", 1)[1] for line in upward(root, SYNTHETIC_LAYERS)] == ["pkg.mid.a imports pkg (layer 2 imports layer 0)"]


def test_checker_ignores_type_checking_imports(tmp_path):
    root = _package(tmp_path, {
        "mid/a.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg.top import T\n",
        "mid/b.py": "import typing\nif typing.TYPE_CHECKING:\n    import pkg.top\n",
    })  # fmt: skip
    assert not upward(root, SYNTHETIC_LAYERS)


def test_checker_finds_cycles_sideways_and_through_lazy_imports(tmp_path):
    root = _package(tmp_path, {
        "mid/a.py": "from pkg.mid import b\n",
        "mid/b.py": "def f():\n    from pkg.mid.a import g\n",
        "leaf.py": "import pkg.leaf2\n",
        "leaf2.py": "import pkg.leaf\n",
    })  # fmt: skip
    assert not upward(root, SYNTHETIC_LAYERS)  # all sideways: only the cycle check catches them
    assert cycles(root) == [["pkg.leaf", "pkg.leaf2", "pkg.leaf"], ["pkg.mid.a", "pkg.mid.b", "pkg.mid.a"]]


def test_checker_finds_a_cycle_through_the_lazy_export_map(tmp_path):
    root = _package(tmp_path, {
        "__init__.py": "from importlib import import_module\n_LAZY = {'f': 'pkg.mid.a'}\n"
                       "def __getattr__(n):\n    return import_module(_LAZY[n])\n",
        "mid/a.py": "import pkg\n",
    })  # fmt: skip
    assert cycles(root) == [["pkg", "pkg.mid.a", "pkg"]]


@pytest.mark.parametrize("text", ["import plotly\n", "import plotly.express as px\n", "from plotly import graph_objects\n",
                                  "def plot():\n    import plotly.graph_objects as go\n"])  # fmt: skip
def test_checker_finds_plotly_outside_the_drawing_layers(tmp_path, text):
    root = _package(tmp_path, {"mid/b.py": text, "draw/__init__.py": text})
    found = plotly_outside(root, ("pkg.draw",))
    assert len(found) == 1 and found[0].startswith("pkg/mid/b.py:") and "pkg.mid.b imports plotly" in found[0]


def test_checker_finds_plotting_importing_beyond_the_leaves(tmp_path):
    root = _package(tmp_path, {"draw/__init__.py": "from pkg.leaf import x\nfrom pkg.mid import b\n"})
    found = plotting_beyond_leaves(root, SYNTHETIC_LAYERS, "pkg.draw")
    assert len(found) == 1 and "pkg.draw imports pkg.mid.b" in found[0]


def test_checker_finds_a_module_no_layer_claims(tmp_path):
    root = _package(tmp_path, {"extra/x.py": ""})
    assert unplaced(root, SYNTHETIC_LAYERS) == ["pkg.extra.x"]
    assert layer_of("pkg.topper", SYNTHETIC_LAYERS, "pkg") is None  # prefixes match whole names only
