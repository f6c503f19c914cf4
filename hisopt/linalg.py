"""Small batched linear algebra for the evaluator, and the BLAS threading rule.

Determinism contract (docs/model.md §9): a design's objectives may differ by rounding between
batches (a BLAS kernel rounds a matrix product differently for other matrix sizes, and the
evaluator pads each batch to its longest frequency grid), but never by more than 1e-12
relative; and the same work in the same order gives the same numbers. The one thing that
could break the second rule is BLAS splitting a product between threads, which changes with
``OPENBLAS_NUM_THREADS`` and the machine: :func:`one_blas_thread` rules it out.

Complex arithmetic on the hot path works on (real, imag) pairs of real arrays, so that
matrix products go to real gemm (two real products share one call, see
:func:`hisopt.evaluation.evaluate.PoleResidueOutputs`).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

import numpy as np

_CONTROLLER: dict[str, Any] = {}


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the enclosed numpy linear algebra on one BLAS thread.

    A threaded BLAS splits a product into blocks per thread, and a block's edge may be
    computed by another kernel; one thread gives the same numbers whatever
    ``OPENBLAS_NUM_THREADS`` says. The evaluator's matrices are small (a 14 x 14 state
    matrix, products of a few hundred frequencies by a few dozen columns), so a second
    thread would not speed them up anyway; processes are the unit of parallelism.
    """
    if "controller" not in _CONTROLLER:
        from threadpoolctl import ThreadpoolController

        _CONTROLLER["controller"] = ThreadpoolController()
    with _CONTROLLER["controller"].limit(limits=1, user_api="blas"):
        yield


def bmm(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Matrix product ``a @ b`` over the last two axes, broadcasting leading axes."""
    return np.matmul(a, b)


def bsum(a: np.ndarray, axis: int) -> np.ndarray:
    """Sum over ``axis`` in sequential order (the same order for every batch)."""
    a = np.moveaxis(np.asarray(a), axis, 0)
    out = a[0]
    for k in range(1, a.shape[0]):
        out = out + a[k]
    return out


def split(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Real and imaginary parts as contiguous real arrays."""
    z = np.asarray(z)
    return np.ascontiguousarray(z.real), np.ascontiguousarray(z.imag)


def join(re: np.ndarray, im: np.ndarray) -> np.ndarray:
    """Complex array from real and imaginary parts (exact)."""
    out = np.empty(np.broadcast_shapes(re.shape, im.shape), dtype=complex)
    out.real = re
    out.imag = im
    return out


def cmul(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Complex product of (real, imag) pairs in real arithmetic."""
    return a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]


def cbmm(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Complex batched matrix product of (real, imag) pairs in real arithmetic."""
    return bmm(a[0], b[0]) - bmm(a[1], b[1]), bmm(a[0], b[1]) + bmm(a[1], b[0])
