"""Sphinx configuration of the hisopt API reference (built from the docstrings).

Build from the repository root (warnings are errors; nothing is fetched from the network)::

    sphinx-build -W -b html docs/api docs/api/_build

tests/test_api_docs.py runs the same build on a copy of this folder.
"""

from __future__ import annotations

import hisopt

project = "hisopt"
release = version = hisopt.__version__
author = "hisopt authors"

extensions = ["sphinx.ext.autodoc", "sphinx.ext.autosummary", "numpydoc"]

autosummary_generate = True  # one page per public name, under generated/
autosummary_imported_members = True  # the public names are defined in submodules and re-exported
autodoc_default_options = {"members": True, "inherited-members": False, "show-inheritance": False}
autodoc_typehints = "none"  # the numpydoc sections give the types, with units
autodoc_member_order = "bysource"

numpydoc_show_class_members = False  # autodoc's :members: documents methods once
numpydoc_validation_checks: set[str] = set()  # style is checked by review, not by the build

html_theme = "alabaster"
exclude_patterns = ["_build"]
