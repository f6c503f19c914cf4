"""Compile the evaluator's kernels ahead of the first run: ``python -m hisopt.evaluation.warmup``.

numba compiles :mod:`hisopt.evaluation.kernels` on first use and caches the machine code on
disk (next to the source, in ``__pycache__``, or in ``NUMBA_CACHE_DIR``); a pip wheel has no
post-install hook, so without this step the first run after installing pays the compile
(seconds). README's set-up runs this module once after ``pip install``: it compiles every
kernel for every argument type the evaluator passes (:data:`SIGNATURES`; a test checks that
the evaluator uses no other) without evaluating anything, so later runs only load the cache.
It computes nothing and changes no result: the code compiled is the code a run would compile.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable

from numba import types

# The array types the callers pass: C-contiguous, writable, float64, complex128 or int64.
_F1, _F2, _F3, _F4 = types.float64[::1], types.float64[:, ::1], types.float64[:, :, ::1], types.float64[:, :, :, ::1]
_C1, _C2, _C3 = types.complex128[::1], types.complex128[:, ::1], types.complex128[:, :, ::1]
_I1, _I2 = types.int64[::1], types.int64[:, ::1]
# One road channel's terms (hisopt.evaluation.pole_residue.PoleResidue.kernel_terms).
_CHANNEL = types.Tuple((_C2, _F3, _F3, _C2, _F3, _F3, _F3, _I2))

SIGNATURES: dict[str, list[tuple[types.Type, ...]]] = {
    "mirror_deviation": [(_F3, _I1, _F1, types.float64)],
    "balance": [(_F3, types.int64)],
    "modal_terms": [(_C2, _C3, _C3, _F3, _F3, _F2, _I2, _C2, _F3, _F3, _C2, _F3, _F3)],
    "lay_nodes": [(_C2, _C1, _F1, types.float64, types.float64, types.float64, _F1, _F1, types.int64)],
    "channel_psd": [(_F2, _F1, _F3, _CHANNEL, _CHANNEL, _I1, _F2, _F4)],
    "weighted_sums": [(_F2, _F2, _F3, _F3, _F2, _F2, _I1, _I1, _F1, _I1, types.int64, _F2, _F3, _F3)],
    "local_maxima": [(_F2, types.float64, _I2)],
}
"""Argument types of each kernel the evaluator calls, by name in :mod:`hisopt.evaluation.kernels`
(the kernels these call, such as ``panel_edges``, compile with them)."""


def compile_kernels(report: Callable[[str], None] | None = None) -> float:
    """Compile (or load from numba's cache) every kernel for its :data:`SIGNATURES`.

    Parameters
    ----------
    report : Callable[[str], None] | None, optional
        called with one line per kernel (its name and seconds taken)

    Returns
    -------
    float
        [s] wall time taken
    """
    from hisopt.evaluation import kernels

    start = time.perf_counter()
    for name, signatures in SIGNATURES.items():
        dispatcher = getattr(kernels, name)
        for signature in signatures:
            began = time.perf_counter()
            dispatcher.compile(signature)
            if report is not None:
                report(f"{name}: {time.perf_counter() - began:.1f} s")
    return time.perf_counter() - start


def main() -> None:
    """Compile the kernels and say where the cache is and how long it took."""
    from numba.core import config

    where = config.CACHE_DIR or "__pycache__ next to hisopt/evaluation/kernels.py (or numba's user cache)"
    seconds = compile_kernels(lambda line: print(f"  {line}", file=sys.stderr))
    print(f"hisopt: evaluator kernels compiled and cached in {seconds:.1f} s ({where})")


if __name__ == "__main__":
    main()
