"""Small batched linear algebra (hisopt.linalg)."""

import subprocess
import sys

import numpy as np

from hisopt.linalg import bmm, bsum, cbmm, cmul, join, one_blas_thread, split


def test_bmm_matches_matmul_within_rounding_for_any_batch(rng):
    a = rng.standard_normal((64, 30, 14))
    b = rng.standard_normal((64, 14, 24))
    full = bmm(a, b)
    np.testing.assert_allclose(full, np.einsum("nik,nkj->nij", a, b), rtol=1e-13, atol=1e-13)
    # Other matrix sizes may take other BLAS kernels: equal within rounding, not bit for bit.
    for n, f in ((1, 30), (2, 17), (63, 2)):
        np.testing.assert_allclose(bmm(a[:n, :f], b[:n]), full[:n, :f], rtol=1e-13, atol=1e-13)


def test_bsum_and_complex_helpers(rng):
    a = rng.standard_normal((7, 5))
    np.testing.assert_allclose(bsum(a, axis=0), a.sum(axis=0), rtol=1e-14)
    z = rng.standard_normal((5, 4, 3)) + 1j * rng.standard_normal((5, 4, 3))
    w = rng.standard_normal((5, 3, 2)) + 1j * rng.standard_normal((5, 3, 2))
    np.testing.assert_array_equal(join(*split(z)), z)
    np.testing.assert_allclose(join(*cmul(split(z), split(z))), z * z, rtol=1e-14)
    np.testing.assert_allclose(join(*cbmm(split(z), split(w))), z @ w, rtol=1e-13, atol=1e-14)


def test_one_blas_thread_limits_and_restores_blas_threads():
    code = (
        "from threadpoolctl import threadpool_info\n"
        "from hisopt.linalg import one_blas_thread\n"
        "blas = lambda: [i['num_threads'] for i in threadpool_info() if i['user_api'] == 'blas']\n"
        "before = blas()\n"
        "with one_blas_thread():\n"
        "    inside = blas()\n"
        "print(before, inside, blas())\n"
    )
    env = {"OPENBLAS_NUM_THREADS": "2", "PATH": "/usr/bin:/bin"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stderr
    before, inside, after = (eval(part + "]") for part in out.stdout.strip().rstrip("]").split("] "))
    assert before and all(n == 2 for n in before) and all(n == 1 for n in inside) and after == before
    with one_blas_thread():  # usable in this process too
        assert np.allclose(np.eye(3) @ np.ones(3), 1.0)
