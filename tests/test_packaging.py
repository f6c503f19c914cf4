"""The wheel a user installs carries every file of the package.

The tests import hisopt from an editable install, which reads data files straight from the
source tree, so a data file left out of the wheel (hisopt/data/*) would pass them and break
every real install. This test builds the wheel, offline, with the build backend pyproject.toml
names; .ci/run also installs it in a clean environment and runs hisopt from there.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile

from tests.conftest import ROOT


def test_wheel_ships_every_package_file(tmp_path):
    src = tmp_path / "src"  # a copy, so that the build leaves nothing in the checkout
    shutil.copytree(ROOT / "hisopt", src / "hisopt", ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, src / name)
    built = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--no-build-isolation", "--no-index",
         "--wheel-dir", str(tmp_path / "dist"), str(src)],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert built.returncode == 0, built.stderr
    (wheel,) = (tmp_path / "dist").glob("hisopt-*.whl")
    shipped = set(zipfile.ZipFile(wheel).namelist())

    package = sorted(p.relative_to(src).as_posix() for p in (src / "hisopt").rglob("*") if p.is_file())
    assert [name for name in package if name not in shipped] == []
    # The files the code opens at run time (importlib.resources), named explicitly.
    assert {
        "hisopt/data/iso8608_classes.csv",
        "hisopt/data/roll_plane_his.toml",
        "hisopt/data/layouts/roll_plane.toml",
        "hisopt/data/layouts/pitch_plane.toml",
    } <= shipped  # the layout catalogue too
    assert "hisopt/cli/application.py" in shipped and any(n.endswith("entry_points.txt") for n in shipped)
    # The distribution's version is hisopt/version.py's (pyproject reads it: one home).
    from hisopt.version import __version__

    metadata = next(n for n in shipped if n.endswith(".dist-info/METADATA"))
    assert f"\nVersion: {__version__}\n" in zipfile.ZipFile(wheel).read(metadata).decode()


def test_no_module_imports_the_package_root():
    """The package root is the public API and lazily imports the layers (optim, problem, ...):
    a module under it that imported it back (e.g. for ``__version__``, now hisopt.version's)
    would be an import running up. Only ``python -m hisopt`` may import the root; an import of
    one of its submodules (``from hisopt import interrupt``) names that submodule, not the root."""
    import ast

    package = ROOT / "hisopt"
    submodules = {p.stem for p in package.glob("*.py")} | {p.name for p in package.iterdir() if (p / "__init__.py").is_file()}
    offenders = []
    for path in sorted(package.rglob("*.py")):
        if path.relative_to(package).as_posix() in ("__init__.py", "__main__.py"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):  # function-level imports included
            if isinstance(node, ast.Import):
                roots = [a.name for a in node.names if a.name == "hisopt"]
            elif isinstance(node, ast.ImportFrom) and node.module == "hisopt" and not node.level:
                roots = [a.name for a in node.names if a.name not in submodules]
            else:
                continue
            offenders += [f"{path.relative_to(ROOT)}:{node.lineno}: {name}" for name in roots]
    assert offenders == []
