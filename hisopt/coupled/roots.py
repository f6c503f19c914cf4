"""Roots of the coupled model with distributed pipes: Newton's method on ``det K_dyn(s) = 0``.

The lumped realisation's roots (:mod:`hisopt.coupled.mode_energy`) start the iteration; the
step uses ``d ln det K / ds = tr(K^-1 dK/ds)`` (docs/model.md §3.9).
"""

from __future__ import annotations

import numpy as np

from hisopt.coupled.model import CoupledModel


def _log_det_slope(k: np.ndarray, dk: np.ndarray) -> np.ndarray:
    """``tr(K^-1 dK/ds)`` of a batch ``(..., 7, 7)``; ``inf`` (a Newton step of 0) where ``K``
    is singular to working precision: there ``s`` is a root already (Newton lands on one
    exactly now and then), and one such root must not fail the whole batch."""
    try:
        return np.trace(np.linalg.solve(k, dk), axis1=-2, axis2=-1)
    except np.linalg.LinAlgError:
        out = np.empty(k.shape[:-2], dtype=complex)
        for i in np.ndindex(out.shape):  # rare: only a batch with an exactly singular K
            try:
                out[i] = np.trace(np.linalg.solve(k[i], dk[i]))
            except np.linalg.LinAlgError:
                out[i] = np.inf
        return out


def refine_roots(model: CoupledModel, roots: np.ndarray, iterations: int = 30) -> np.ndarray:
    """Newton refinement of roots of ``det K_dyn(s)`` (batched over the roots).

    The step is ``-1 / tr(K^-1 dK/ds)`` with ``dK/ds`` from a complex central difference.

    Parameters
    ----------
    roots : np.ndarray
        ``(R,)`` roots of a one-design model, or ``(n, R)``, row ``i`` design ``i``'s
    """
    s = np.asarray(roots, dtype=complex).copy()
    for _ in range(iterations):
        h = 1e-6 * np.abs(s)
        k = model.dynamic_stiffness(s)
        dk = (model.dynamic_stiffness(s + h) - model.dynamic_stiffness(s - h)) / (2 * h)[..., None, None]
        step = -1.0 / _log_det_slope(k, dk).reshape(s.shape)
        s = s + step
        if np.all(np.abs(step) < 1e-12 * np.abs(s)):
            break
    return s
