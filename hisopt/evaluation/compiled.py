"""Kernels compiled by numba on their first call, for modules that must stay cheap to import.

The optimiser's kernels (the archive update, the progress hypervolume) live in modules that
``hisopt --help`` and the CLI's start-up import; compiling them at import would load numba
there. :class:`CompiledOnFirstUse` wraps a plain Python function and compiles it
(``njit(cache=True)``: machine code cached on disk) the first time it is called, after
importing numba the evaluator's way (:mod:`hisopt.evaluation.kernels` switches numba's cffi
and BLAS support off first).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any


class CompiledOnFirstUse:
    """A function compiled with ``numba.njit(cache=True)`` when first called.

    Parameters
    ----------
    function : Callable[..., Any]
        a function numba can compile in nopython mode
    """

    def __init__(self, function: Callable[..., Any]):
        self.function = function
        self._dispatcher: Any = None

    def dispatcher(self) -> Any:
        """The numba dispatcher (compiling, or loading from the cache, on the first call)."""
        if self._dispatcher is None:
            importlib.import_module("hisopt.evaluation.kernels")  # numba imported the evaluator's way first
            from numba import njit

            self._dispatcher = njit(cache=True)(self.function)
        return self._dispatcher

    def __call__(self, *args: Any) -> Any:
        return self.dispatcher()(*args)
