"""hisopt: design optimiser for vehicles with roll-plane hydraulically interconnected suspension.

Public API (docs/model.md §8)::

    import hisopt
    problem = hisopt.load_problem("problems/roll_plane_his.toml")
    df = problem.evaluate(X)
    modes = hisopt.modal_analysis(problem, design, his=True)
    run = hisopt.optimize(problem, ...)
    table = hisopt.compare_layouts(problem, layouts="axle_roll,pitch_plane", seeds="1-3", out="runs/layouts")
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

from hisopt.errors import ConfigError, HisoptError, ModelError, ProblemFileNotFoundError, RunError
from hisopt.version import __version__ as __version__

if TYPE_CHECKING:
    from hisopt.coupled.modal import modal_analysis
    from hisopt.optim.run import optimize, resume
    from hisopt.problem import Problem, load_problem
    from hisopt.studies.layout_study import compare_layouts

__all__ = [
    "ConfigError",
    "HisoptError",
    "ModelError",
    "Problem",
    "ProblemFileNotFoundError",
    "RunError",
    "compare_layouts",
    "load_problem",
    "modal_analysis",
    "optimize",
    "resume",
]

# The model pulls in scipy and pandas, optimisation pymoo: import them only when asked for,
# so that `import hisopt.cli` (and `hisopt --help`) stays light.
_LAZY = {
    "Problem": "hisopt.problem",
    "load_problem": "hisopt.problem",
    "compare_layouts": "hisopt.studies.layout_study",
    "modal_analysis": "hisopt.coupled.modal",
    "optimize": "hisopt.optim.run",
    "resume": "hisopt.optim.run",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'hisopt' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
