"""Error-controlled frequency quadrature for response integrals and maxima (docs/model.md §10.3).

Gauss-Legendre with ``n`` nodes on a panel of half-width ``h`` errs by at most
``(64/15) M h rho^(-2n) / (rho^2 - 1)`` when the integrand is analytic, and bounded by ``M``,
inside the panel's Bernstein ellipse of parameter ``rho`` (Trefethen, *Approximation Theory
and Approximation Practice*, Thm 19.3). The integrand's singularities are known before it is
evaluated: the poles of the frequency responses (``f = (Im lambda - j Re lambda) / 2 pi``), the
road spectrum's and the coherence's at ``f = 0``, and the comfort weighting's poles. Panels are
laid so that none of them lies inside the ellipse of the parameter :func:`design_rho` gives for
the tolerance; lightly damped modes get geometrically shrinking panels, quiet stretches wide
ones (:func:`hisopt.evaluation.kernels.panel_edges`).

The rear wheels' delay ``tau`` multiplies parts of the integrand by ``cos`` and
``sin(2 pi f tau)``, entire functions that grow like ``cosh(2 pi tau Im f)`` off the axis, so
on a wide panel the bound carries ``cosh(pi tau h (rho - 1/rho))`` (:func:`ripple_bound`).
After a first evaluation, each panel whose bound times its share of an integral exceeds the
tolerance is split into equal parts that meet it (:func:`ripple_splits`): the panels follow
the ripple where it matters, at any speed. All functions are batched over designs (rows).
"""

from __future__ import annotations

import functools

import numpy as np

GAUSS_CONSTANT = 64.0 / 15.0
"""The constant of the Gauss-Legendre error bound (Trefethen, ATAP Thm 19.3)."""

MAX_PANELS = 1024
"""Panels per design at most (a design needing more gets one wide last panel)."""

MAX_SPLIT = 64
"""Parts a panel is split into at most for the delay ripple."""

POLE_MARGIN = 10.0
"""[-] Panels near singularities are laid for ``tolerance / POLE_MARGIN``: the bound's ``M``
(the integrand's largest modulus on the ellipse) grows as the ellipse nears a pole."""


def gauss_bound(rho: np.ndarray, order: int) -> np.ndarray:
    """[-] Relative Gauss-Legendre error bound ``(64/15) rho^(-2n) / (rho^2 - 1)`` (per ``M h``)."""
    rho = np.asarray(rho, dtype=float)
    return GAUSS_CONSTANT * rho ** (-2.0 * order) / (rho * rho - 1.0)


@functools.cache
def design_rho(order: int, tolerance: float) -> float:
    """Smallest ellipse parameter whose :func:`gauss_bound` is within ``tolerance``."""
    lo, hi = 1.0 + 1e-9, 1e6
    for _ in range(200):
        mid = np.sqrt(lo * hi)
        lo, hi = (mid, hi) if gauss_bound(mid, order) > tolerance else (lo, mid)
    return float(hi)


def singularities(poles: np.ndarray, fixed_hz: np.ndarray) -> np.ndarray:
    """[Hz] The integrand's singularities per design, ``(n, k + S)`` complex (upper half plane).

    Parameters
    ----------
    poles : np.ndarray
        [rad/s] eigenvalues ``(n, k)``: ``H(j 2 pi f)`` is singular at
        ``f = (Im lambda - j Re lambda) / 2 pi``, and ``|H|^2`` at its conjugate too (the same
        ellipses); an undamped pole is moved off the axis by ``1e-9 |f|``
    fixed_hz : np.ndarray
        [Hz] singularities of every design (the road's at 0, the weighting's poles)
    """
    f = poles / (2 * np.pi)
    height = np.maximum(np.abs(f.real), 1e-9 * np.abs(f))
    moving = f.imag + 1j * height
    fixed = np.broadcast_to(np.asarray(fixed_hz, dtype=complex), (poles.shape[0], np.size(fixed_hz)))
    return np.concatenate([moving, fixed.real + 1j * np.abs(fixed.imag)], axis=1)


def panels(f_lo_hz: float, f_hi_hz: float, forced_hz: np.ndarray, sing_hz: np.ndarray, order: int, tolerance: float) -> np.ndarray:
    """[Hz] Panel breakpoints per design, ``(n, P + 1)``, NaN after each row's last.

    Every panel's error is within ``tolerance`` of its share of the integral whatever the
    integrand's values (:func:`gauss_bound` at :func:`design_rho`), the delay aside.

    Parameters
    ----------
    forced_hz : np.ndarray
        [Hz] breakpoints every design keeps (the comfort bands' edges, say)
    sing_hz : np.ndarray
        :func:`singularities`
    """
    from hisopt.evaluation.kernels import panel_edges

    rho = design_rho(order, tolerance / POLE_MARGIN)
    forced = np.sort(np.asarray(forced_hz, dtype=float))
    forced = forced[(forced > f_lo_hz) & (forced < f_hi_hz)]
    out = np.empty((sing_hz.shape[0], MAX_PANELS + 1))
    used = panel_edges(f_lo_hz, f_hi_hz, forced, np.ascontiguousarray(sing_hz), 0.5 * (rho + 1.0 / rho), out)
    return out[:, :used]


def panel_nodes(edges: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on the panels between sorted breakpoints.

    Parameters
    ----------
    edges : np.ndarray
        [Hz] breakpoints per design, ``(n, K)``, sorted, NaN after each row's last
    order : int
        [-] nodes per panel

    Returns
    -------
    f_hz, w_hz : np.ndarray
        ``(n, (K - 1) order)``, panel by panel (so sorted); unused panels have width
        zero: their nodes sit at the row's last breakpoint with weight 0.
    """
    top = np.nanmax(edges, axis=1, keepdims=True)
    e = np.where(np.isfinite(edges), edges, top)
    return _gauss(e[:, :-1], e[:, 1:], order)


@functools.cache
def gauss_legendre(order: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on ``[-1, 1]`` of ``order`` points (cached)."""
    return np.polynomial.legendre.leggauss(order)


def _gauss(lo: np.ndarray, hi: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = gauss_legendre(order)
    half = 0.5 * (hi - lo)
    f = (0.5 * (hi + lo))[..., None] + half[..., None] * x
    wt = half[..., None] * w
    return f.reshape(lo.shape[0], -1), wt.reshape(lo.shape[0], -1)


def ripple_error(t: np.ndarray, order: int) -> np.ndarray:
    """[-] Relative Gauss-Legendre error of the delay's oscillation ``cos(2 pi f tau + phi)``
    over a panel with ``tau h = t`` (worst phase; made non-decreasing in ``t``): the error a
    smooth integrand picks up from the ripple it carries."""
    x, w = gauss_legendre(order)
    k = 2 * np.pi * np.asarray(t, dtype=float)[..., None]
    exact_cos = np.where(k > 0, 2 * np.sin(k) / np.where(k > 0, k, 1.0), 2.0)[..., 0]
    err_cos = np.abs(np.sum(w * np.cos(k * x), axis=-1) - exact_cos)
    err_sin = np.abs(np.sum(w * np.sin(k * x), axis=-1))  # odd: exact integral 0
    return np.maximum.accumulate(0.5 * np.maximum(err_cos, err_sin), axis=-1)


_T_GRID = np.geomspace(1e-4, 1e2, 800)
"""[-] ``tau h`` values of the tabulated :func:`ripple_error`."""


@functools.cache
def _ripple_table(order: int) -> np.ndarray:
    return ripple_error(_T_GRID, order)


SPLIT_ORDER = 8
"""Gauss-Legendre nodes per part of a panel re-integrated for the delay ripple: an
oscillation is integrated to 1e-4 with about 3.2 nodes per unit of ``tau`` times width at
this order, against 5.5 at order 4 (:func:`ripple_error`)."""


def ripple_splits(half_width: np.ndarray, share: np.ndarray, tau: float, order: int, tolerance: float) -> np.ndarray:
    """Panels to integrate again for the delay ripple, ``(n, P)``: 0 where ``order`` nodes
    keep :func:`ripple_error` times the panel's ``share`` of the integral within
    ``tolerance``, else the number of equal parts of :data:`SPLIT_ORDER` nodes that do.

    Parameters
    ----------
    half_width : np.ndarray
        [Hz] panel half-widths
    share : np.ndarray
        [-] each panel's ``sum |w g| / |sum w g|`` (largest over the integrals)
    """
    allowed = np.log(tolerance / np.maximum(share, 1e-300))

    def longest(nodes: int) -> np.ndarray:  # [-] the largest tau h a part may have
        table = np.log(np.maximum(_ripple_table(nodes), 1e-300))
        return np.interp(allowed, table, _T_GRID, left=_T_GRID[0], right=np.inf)

    t = tau * half_width
    flagged = t > longest(order)
    parts = np.where(flagged, np.ceil(t / longest(SPLIT_ORDER)), 0.0)
    return np.clip(np.nan_to_num(parts, nan=0.0), 0, MAX_SPLIT).astype(np.int64)


def split_nodes(edges: np.ndarray, parts: np.ndarray, order: int = SPLIT_ORDER) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights of the panels with ``parts > 0``, each split into that
    many equal parts of ``order`` nodes.

    Returns ``(n, M)`` arrays, rows padded with weight-0 nodes at the row's last breakpoint.
    """
    n = edges.shape[0]
    top = np.nanmax(edges, axis=1)
    lo, hi = edges[:, :-1], edges[:, 1:]
    k = np.maximum(parts, 0)
    per_row = k.sum(axis=1)
    rows, cols = np.nonzero(k)
    kk = k[rows, cols]
    piece_row = np.repeat(rows, kk)
    piece = np.arange(kk.sum()) - np.repeat(np.cumsum(kk) - kk, kk)
    width = np.repeat((hi[rows, cols] - lo[rows, cols]) / kk, kk)
    p_lo = np.repeat(lo[rows, cols], kk) + piece * width
    slot = np.arange(piece_row.size) - np.repeat(np.cumsum(per_row) - per_row, per_row)
    m = int(per_row.max(initial=0))
    a = np.broadcast_to(top[:, None], (n, m)).copy()
    b = a.copy()
    a[piece_row, slot] = p_lo
    b[piece_row, slot] = np.where(piece == np.repeat(kk, kk) - 1, np.repeat(hi[rows, cols], kk), p_lo + width)
    return _gauss(a, b, order)


def peak_samples(poles: np.ndarray, f_lo_hz: float, f_hi_hz: float) -> np.ndarray:
    """[Hz] Where maxima may sit beyond the panels' nodes, ``(n, k + 2)``, sorted: the band
    limits and the damped frequency of every pole in the band (the upper limit for the
    others, so that repeats sit together)."""
    f_d = poles.imag / (2 * np.pi)
    f_d = np.where((f_d > f_lo_hz) & (f_d < f_hi_hz), f_d, f_hi_hz)
    n = poles.shape[0]
    return np.sort(np.concatenate([np.full((n, 1), f_lo_hz), np.full((n, 1), f_hi_hz), f_d], axis=1), axis=1)
