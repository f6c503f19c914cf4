"""Pole-aware frequency quadrature for response integrals and maxima (docs/model.md §10.3).

Lightly damped modes (roll damping ratios near 1e-4 at the corners of the design box) make
peaks far narrower than any plain grid resolves. The band is split into panels at fixed
breakpoints (log and linear spacing, for the road's 1/f^2 slope and the wheelbase delay's
oscillation) and, around every mode, at ``f_d +- b r^k`` (``b = zeta f_n`` the half-power
half-width, ratio ``r``): in such panels a resonance is smooth, so Gauss-Legendre nodes
integrate it to high accuracy. All functions are batched over designs (rows).
"""

from __future__ import annotations

import numpy as np


def base_edges(f_lo_hz: float, f_hi_hz: float, n_log: int = 24, n_lin: int = 24, extra_hz: np.ndarray | None = None) -> np.ndarray:
    """[Hz] Fixed panel breakpoints: log- and linearly spaced over the band, plus ``extra_hz``."""
    edges = np.r_[np.geomspace(f_lo_hz, f_hi_hz, n_log + 1), np.linspace(f_lo_hz, f_hi_hz, n_lin + 1)]
    if extra_hz is not None:
        extra = np.asarray(extra_hz, dtype=float)
        edges = np.r_[edges, extra[(extra > f_lo_hz) & (extra < f_hi_hz)]]
    return np.unique(edges)


def pole_edges(
    poles: np.ndarray, f_lo_hz: float, f_hi_hz: float, ratio: float = 3.0, levels: int = 8, reach: float = 0.5
) -> np.ndarray:
    """[Hz] Breakpoints clustered geometrically around each lightly damped pole.

    Parameters
    ----------
    poles : [rad/s] eigenvalues, shape ``(n, n_poles)``; only those with ``Im > 0`` are used
    ratio : [-] growth of successive distances from the damped frequency
    levels : [-] number of distances each side (the smallest is the half-width ``b``)
    reach : [-] stop once a distance exceeds ``reach * f_d``: beyond it the base panels suffice

    Returns
    -------
    ndarray, shape ``(n, n_poles * (2 levels + 1))``, NaN where unused.
    """
    f_d = poles.imag / (2 * np.pi)
    b = np.maximum(-poles.real / (2 * np.pi), 1e-12 * np.abs(poles) / (2 * np.pi))
    dist = b[..., None] * ratio ** np.arange(levels)
    use = (dist <= reach * f_d[..., None]) & (poles.imag > 0)[..., None]
    dist = np.where(use, dist, np.nan)
    cand = np.concatenate([f_d[..., None] - dist, f_d[..., None] + dist, np.where(poles.imag > 0, f_d, np.nan)[..., None]], axis=-1)
    cand = cand.reshape(poles.shape[0], -1)
    return np.where((cand > f_lo_hz) & (cand < f_hi_hz), cand, np.nan)


def panel_nodes(edges: np.ndarray, order: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on the panels between sorted breakpoints.

    Parameters
    ----------
    edges : [Hz] breakpoints per design, shape ``(n, K)``, NaN for unused entries; must
        contain the band limits
    order : [-] nodes per panel

    Returns
    -------
    f_hz, w_hz : shape ``(n, M)``, sorted by frequency within each row; padding nodes sit at
        the upper band limit with weight 0, so every node is a valid frequency.
    """
    e = np.sort(edges, axis=1)  # NaN sorts last
    k = int(np.max(np.sum(np.isfinite(e), axis=1)))
    e = e[:, :k]
    top = np.nanmax(e, axis=1, keepdims=True)
    e = np.where(np.isfinite(e), e, top)
    lo, hi = e[:, :-1], e[:, 1:]
    x, w = np.polynomial.legendre.leggauss(order)
    half = 0.5 * (hi - lo)
    f = (0.5 * (hi + lo))[..., None] + half[..., None] * x
    wt = half[..., None] * w
    return f.reshape(e.shape[0], -1), wt.reshape(e.shape[0], -1)
