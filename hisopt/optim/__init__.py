"""Pareto optimisation of hisopt problems: pymoo adapter, NSGA runs, archive, decisions.

``hisopt.optimize`` (:func:`hisopt.optim.run.optimize`) and :func:`hisopt.optim.run.resume`
are the entry points; pymoo is imported only when a run starts.
"""

from __future__ import annotations

from typing import Any

__all__ = ["OptimizationResult", "optimize", "resume"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from hisopt.optim import run

        return getattr(run, name)
    raise AttributeError(f"module 'hisopt.optim' has no attribute {name!r}")
