"""Small batched linear algebra with a fixed order of operations.

The evaluator promises that a design's objectives do not depend on its batch (an optimiser's
archive must re-evaluate exactly). numpy's complex kernels fuse multiply-adds differently in
different loops, and BLAS switches to other kernels for matrix-vector shapes, so the hot path
does complex arithmetic on (real, imag) pairs of real arrays and multiplies matrices with
:func:`bmm`, which uses real gemm only where its per-matrix result is batch-independent.
"""

from __future__ import annotations

import numpy as np


def bmm(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Matrix product ``a @ b`` over the last two axes, broadcasting leading axes.

    Real products with every matrix dimension >= 2 go to BLAS (gemm: the same per-matrix
    result for any batch, checked by the tests); the rest (matrix-vector shapes, for which
    BLAS switches to gemv, and complex operands) use a fixed-order multiply-add.
    """
    a = np.asarray(a)
    b = np.asarray(b)
    if (
        a.dtype == np.float64
        and b.dtype == np.float64
        and min(a.shape[-2], a.shape[-1], b.shape[-1]) >= 2
    ):
        return np.matmul(a, b)
    out = a[..., :, 0, None] * b[..., 0, None, :]
    for k in range(1, a.shape[-1]):
        out = out + a[..., :, k, None] * b[..., k, None, :]
    return out


def bsum(a: np.ndarray, axis: int) -> np.ndarray:
    """Sum over ``axis`` in sequential order (batch-independent, unlike pairwise ``np.sum``)."""
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
    """Complex product in real arithmetic (numpy's complex kernels may fuse multiply-adds
    differently in different loops; separate real operations are rounded the same everywhere)."""
    return a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]


def cbmm(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Complex batched matrix product in real arithmetic (see :func:`bmm`, :func:`cmul`)."""
    return bmm(a[0], b[0]) - bmm(a[1], b[1]), bmm(a[0], b[1]) + bmm(a[1], b[0])
