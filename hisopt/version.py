"""The version of hisopt, in one place: a leaf any module may import (``hisopt.__version__``
re-exports it; pyproject.toml reads it for the distribution's metadata)."""

__version__ = "0.1.0"
