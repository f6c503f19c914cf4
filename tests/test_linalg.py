"""Batch-independent small linear algebra (hisopt.linalg)."""

import numpy as np

from hisopt.linalg import bmm, cbmm, cmul, join, split


def test_bmm_matches_matmul_and_is_batch_independent(rng):
    a = rng.standard_normal((64, 30, 14))
    b = rng.standard_normal((64, 14, 24))
    full = bmm(a, b)
    np.testing.assert_allclose(full, a @ b, rtol=1e-13, atol=1e-13)
    for n, f in ((1, 30), (2, 17), (63, 2)):
        assert np.array_equal(bmm(a[:n, :f], b[:n]), full[:n, :f])
    assert np.array_equal(bmm(a[5:9], b[5:9])[0], full[5])
    # matrix-vector shapes and complex operands take the fixed-order path
    v = rng.standard_normal((64, 1, 14))
    assert np.array_equal(bmm(v, b)[3], bmm(v[3:4], b[3:4])[0])


def test_complex_helpers(rng):
    z = rng.standard_normal((5, 4, 3)) + 1j * rng.standard_normal((5, 4, 3))
    w = rng.standard_normal((5, 3, 2)) + 1j * rng.standard_normal((5, 3, 2))
    np.testing.assert_array_equal(join(*split(z)), z)
    np.testing.assert_allclose(join(*cmul(split(z), split(z))), z * z, rtol=1e-14)
    np.testing.assert_allclose(join(*cbmm(split(z), split(w))), z @ w, rtol=1e-13, atol=1e-14)
