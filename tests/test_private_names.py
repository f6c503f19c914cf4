"""No private names cross module boundaries inside ``hisopt/`` (issue 23, habits).

A *private name* is an identifier with a leading underscore that is not a dunder
(``_legendre`` is private, ``__version__`` is not). A module of ``hisopt/`` may use its own
private names; it may not reach another module's:

- ``from hisopt.x import _name`` (also relative, ``from .x import _name``), nor import from a
  private module (``from hisopt._x import y``, ``import hisopt._x``);
- ``alias._name`` where ``alias`` is bound by an import to another module or package of
  hisopt (``from hisopt.hydraulics import backend as bk`` then ``bk._ca()``;
  ``import hisopt.x`` then ``hisopt.x._name``).

Private attributes of objects (``self._cache``) are the objects' business, not imports, and are
not checked. Tests may use private names; this walks only the package.
"""

from __future__ import annotations

import ast
from pathlib import Path

from tests.conftest import ROOT


def is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def module_name(root: Path, path: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def is_module(root: Path, dotted: str) -> bool:
    base = root.joinpath(*dotted.split("."))
    return base.with_suffix(".py").is_file() or base.is_dir()


def private_crossings(root: Path, package: str = "hisopt") -> list[str]:
    """``"module:line: what"`` for every private name of one module used by another, in the
    modules of ``root / package``."""
    found = []
    for path in sorted((root / package).rglob("*.py")):
        me = module_name(root, path)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        modules: dict[str, str] = {}  # local name -> the hisopt module (or package) it is bound to
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:  # relative: from the importing module's package
                    here = me.split(".") if path.name == "__init__.py" else me.split(".")[:-1]
                    base = ".".join(here[: len(here) - node.level + 1] + ([base] if base else []))
                if base.split(".")[0] != package:
                    continue
                for alias in node.names:
                    if is_private(alias.name) or any(map(is_private, base.split("."))):
                        found.append(f"{me}:{node.lineno}: from {base} import {alias.name}")
                    if is_module(root, f"{base}.{alias.name}"):
                        modules[alias.asname or alias.name] = f"{base}.{alias.name}"
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.split(".")[0] != package:
                        continue
                    if any(map(is_private, alias.name.split("."))):
                        found.append(f"{me}:{node.lineno}: import {alias.name}")
                    modules[alias.asname or package] = alias.name if alias.asname else package
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Attribute) and is_private(node.attr)):
                continue
            chain, value = [], node.value
            while isinstance(value, ast.Attribute):
                chain.append(value.attr)
                value = value.value
            if isinstance(value, ast.Name) and value.id in modules:
                owner = ".".join([modules[value.id], *reversed(chain)])
                if owner != me and is_module(root, owner):
                    found.append(f"{me}:{node.lineno}: {owner}.{node.attr}")
    return found


def test_no_private_name_crosses_a_module_boundary():
    assert private_crossings(ROOT) == []


def test_the_check_finds_every_kind_of_crossing(tmp_path):
    """A made-up package with one crossing of each kind, and the uses that are allowed."""
    pkg = tmp_path / "hisopt"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("__version__ = '0'\n")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "_hidden.py").write_text("x = 1\n")
    (pkg / "sub" / "low.py").write_text("_secret = 1\nSHOWN = 2\n\n\ndef _helper():\n    return _secret\n")
    (pkg / "user.py").write_text(
        "import hisopt.sub.low\n"
        "from hisopt import __version__, _hidden\n"  # 2: a private module
        "from hisopt.sub import low as lo\n"
        "from hisopt.sub.low import SHOWN, _helper\n"  # 4: a private function
        "from .sub.low import _secret\n"  # 5: relative
        "\n"
        "class A:\n"
        "    def __init__(self):\n"
        "        self._cache = {}\n"  # an object's own attribute: allowed
        "\n"
        "def f(other):\n"
        "    return lo._secret + hisopt.sub.low._helper() + other._cache + lo.SHOWN + lo.__name__\n"  # 12: two
    )
    assert sorted(private_crossings(tmp_path)) == sorted(
        [
            "hisopt.user:2: from hisopt import _hidden",
            "hisopt.user:4: from hisopt.sub.low import _helper",
            "hisopt.user:5: from hisopt.sub.low import _secret",
            "hisopt.user:12: hisopt.sub.low._secret",
            "hisopt.user:12: hisopt.sub.low._helper",
        ]
    )
