"""hisopt: design optimiser for vehicles with roll-plane hydraulically interconnected suspension.

Public API (docs/model.md §8)::

    import hisopt
    problem = hisopt.load_problem("problems/roll_plane_his.toml")
    df = problem.evaluate(X)
    modes = hisopt.modal_analysis(problem, design, his=True)
    run = hisopt.optimize(problem, ...)
"""

from __future__ import annotations

from typing import Any

from hisopt.errors import ConfigError, HisoptError, ModelError, ProblemFileNotFoundError, RunError
from hisopt.modal import modal_analysis
from hisopt.problem import Problem, load_problem

__version__ = "0.1.0"

__all__ = [
    "ConfigError",
    "HisoptError",
    "ModelError",
    "Problem",
    "ProblemFileNotFoundError",
    "RunError",
    "load_problem",
    "modal_analysis",
    "optimize",
    "resume",
]


def __getattr__(name: str) -> Any:
    # Optimisation pulls in pymoo; import it only when asked for.
    if name in ("optimize", "resume"):
        from hisopt.optim import run

        return getattr(run, name)
    raise AttributeError(f"module 'hisopt' has no attribute {name!r}")
