"""Compiled inner loop of the evaluator: output PSDs from poles and residues, fused.

Evaluating ``H(s) = sum_k rho_k / (s - lambda_k) + poly(s)`` for every design, node, channel,
axle and output with numpy builds arrays of designs x nodes x poles x inputs x outputs and
passes over them a dozen times; here one loop per design and node keeps everything in
registers (numba, compiled once and cached on disk). The road-channel arithmetic is
:func:`hisopt.evaluation.psd.channel_power` itself, compiled from its source, so the formula exists once.

The loops run in a fixed order and each design independently of the others: a design's
numbers are the same in any batch, on any number of threads.
"""

from __future__ import annotations

import math
import sys

import numpy as np


def _numba_without_cffi_or_blas() -> None:
    """Import numba with its optional cffi and BLAS support off, unless those modules are loaded
    already. On first use numba imports cffi and pycparser (0.1 s) only to type cffi functions,
    and scipy.linalg (0.08 s) only so that np.dot works inside compiled code; hisopt's kernels
    use neither, and the CLI's start-up is what pays. Both stay importable afterwards."""
    blocked = [name for name in ("cffi", "scipy.linalg") if name not in sys.modules]
    for name in blocked:
        sys.modules[name] = None  # type: ignore[assignment]  # makes "import name" fail in numba
    try:
        import numba.core.typing.cffi_utils  # noqa: F401
        import numba.np.arraymath  # noqa: F401  # decides once whether BLAS is available
    finally:
        for name in blocked:
            del sys.modules[name]


_numba_without_cffi_or_blas()

from numba import njit  # noqa: E402

from hisopt.evaluation.psd import channel_power  # noqa: E402

_channel_power = njit(cache=True, inline="always")(channel_power)


@njit(cache=True)
def _single_poles(w: float, lam_1: np.ndarray, r_re: np.ndarray, r_im: np.ndarray, h_re: np.ndarray, h_im: np.ndarray) -> None:
    """Adds ``sum rho / (j w - lambda)`` over single poles to every column."""
    for k in range(lam_1.shape[0]):
        a = -lam_1[k].real
        b = w - lam_1[k].imag
        inv = 1.0 / (a * a + b * b)
        c_re, c_im = a * inv, -b * inv
        for j in range(r_re.shape[1]):
            h_re[j] += c_re * r_re[k, j] - c_im * r_im[k, j]
            h_im[j] += c_re * r_im[k, j] + c_im * r_re[k, j]


@njit(cache=True, inline="always")
def _channel_frfs(w: float, lam_p: np.ndarray, alpha: np.ndarray, beta: np.ndarray, poly: np.ndarray, h_re: np.ndarray, h_im: np.ndarray) -> None:
    """``h_j`` of every column ``j`` (axle and output) of one channel at ``s = j w``:
    ``sum (alpha + s beta) / (s^2 - 2 s Re(lambda) + |lambda|^2)`` over the conjugate pairs
    plus ``sum s^m poly_m`` (:func:`hisopt.evaluation.pole_residue.conjugate_pairs`; the other poles:
    :func:`_single_poles`); the column loops are innermost, so they vectorise."""
    n_col = alpha.shape[1]
    if poly.shape[0] > 0:  # the constant term (road feedthrough) starts the sums
        for j in range(n_col):
            h_re[j] = poly[0, j]
            h_im[j] = 0.0
    else:
        for j in range(n_col):
            h_re[j] = 0.0
            h_im[j] = 0.0
    for k in range(lam_p.shape[0]):
        lr, li = lam_p[k].real, lam_p[k].imag
        d_re = lr * lr + li * li - w * w
        d_im = -2.0 * w * lr
        inv = 1.0 / (d_re * d_re + d_im * d_im)
        c_re, c_im = d_re * inv, -d_im * inv  # 1 / D
        wc_re, wc_im = w * c_re, w * c_im
        for j in range(n_col):
            h_re[j] += alpha[k, j] * c_re - beta[k, j] * wc_im
            h_im[j] += alpha[k, j] * c_im + beta[k, j] * wc_re
    if poly.shape[0] > 1:  # derivative terms: (j w)^m
        jw_re, jw_im = 0.0, w
        for m in range(1, poly.shape[0]):
            for j in range(n_col):
                h_re[j] += jw_re * poly[m, j]
                h_im[j] += jw_im * poly[m, j]
            jw_re, jw_im = -jw_im * w, jw_re * w


@njit(cache=True, inline="always")
def _roads_psd(
    w: float,
    f: float,
    i: int,
    q: int,
    first: int,
    last: int,
    tau: np.ndarray,
    coherence: np.ndarray,
    coherent: bool,
    road: np.ndarray,
    col_s: np.ndarray,
    col_a: np.ndarray,
    hs_re: np.ndarray,
    hs_im: np.ndarray,
    ha_re: np.ndarray,
    ha_im: np.ndarray,
    gather: np.ndarray,
    out: np.ndarray,
) -> None:
    """:func:`channel_psd` at one frequency on every road: the FRFs of each output gathered
    once (rows: sym front, sym rear, anti front, anti rear; re, im), then per road the same
    :func:`hisopt.evaluation.psd.channel_power` as one road gets."""
    for o in range(first, last):
        gather[0, o], gather[1, o] = hs_re[col_s[0, o]], hs_im[col_s[0, o]]
        gather[2, o], gather[3, o] = hs_re[col_s[1, o]], hs_im[col_s[1, o]]
        gather[4, o], gather[5, o] = ha_re[col_a[0, o]], ha_im[col_a[0, o]]
        gather[6, o], gather[7, o] = ha_re[col_a[1, o]], ha_im[col_a[1, o]]
    for r in range(tau.shape[0]):
        cos_t, sin_t = math.cos(w * tau[r]), math.sin(w * tau[r])
        g = coherence[r, i, q] if coherent else 0.0
        g1, exponent = road[r, 0], road[r, 1]
        road_psd = g1 / (f * f) if exponent == 2.0 else g1 * f**-exponent
        for o in range(first, last):
            out[r, o, i, q] = road_psd * _channel_power(
                ((gather[0, o], gather[1, o]), (gather[2, o], gather[3, o])),
                ((gather[4, o], gather[5, o]), (gather[6, o], gather[7, o])),
                cos_t,
                sin_t,
                g,
            )


@njit(cache=True)
def channel_psd(
    f_hz: np.ndarray,
    tau: np.ndarray,
    coherence: np.ndarray,
    sym: tuple[np.ndarray, ...],
    anti: tuple[np.ndarray, ...],
    output_of: np.ndarray,
    road: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out[r, o, i, q]``: output ``o``'s PSD at ``f_hz[i, q]`` [Hz] on road ``r``: the road
    PSD there, ``G_1 f^-w`` with ``road[r] = (G_1, w)``, times its PSD per unit road PSD. The
    FRFs are computed once per frequency for all the roads (load cases sharing a model).

    Parameters
    ----------
    f_hz : np.ndarray
        ``(n, F)`` frequencies per design (a node equal to the one before it is copied)
    tau : np.ndarray
        ``(R,)`` [s] rear-wheel delay on each road
    coherence : np.ndarray
        ``(R, n, F)`` left-right coherence, or ``(0, 0, 0)`` for independent tracks
    sym, anti : tuple[np.ndarray, ...]
        each road channel's ``(lam_pair, alpha, beta, lam_single, rho_single.real,
        rho_single.imag, poly, column)``: :func:`hisopt.evaluation.pole_residue.conjugate_pairs` of its
        ``C`` columns that are not zero by structure, polynomial terms ``(n, P, C)`` and
        ``column`` ``(2, O)``, the column of each (front or rear axle, output), ``C`` for
        none (a zero column)
    output_of : np.ndarray
        ``(F,)`` the one output wanted at each column (``-1``: all; the others are
        left as zeros)
    road : np.ndarray
        ``(R, 2)`` each road PSD's power law (:func:`hisopt.standards.iso_8608_2016.temporal_power_law`)
    out : np.ndarray
        ``(R, O, n, F)`` result, written in place
    """
    n, nf = f_hz.shape
    n_road, n_out = out.shape[0], out.shape[1]
    coherent = coherence.shape[0] > 0
    lp_s, al_s, be_s, l1_s, rr_s, ri_s, po_s, col_s = sym
    lp_a, al_a, be_a, l1_a, rr_a, ri_a, po_a, col_a = anti
    # One more column than the channel has, always 0: where a structural zero's -1 points.
    hs_re = np.zeros(al_s.shape[2] + 1)
    hs_im = np.zeros(al_s.shape[2] + 1)
    ha_re = np.zeros(al_a.shape[2] + 1)
    ha_im = np.zeros(al_a.shape[2] + 1)
    gather = np.zeros((8, n_out))
    out[:] = 0.0
    for i in range(n):
        # this design's terms, taken once (not per frequency)
        lps, als, bes, l1s, rrs, ris, pos = lp_s[i], al_s[i], be_s[i], l1_s[i], rr_s[i], ri_s[i], po_s[i]
        lpa, ala, bea, l1a, rra, ria, poa = lp_a[i], al_a[i], be_a[i], l1_a[i], rr_a[i], ri_a[i], po_a[i]
        for q in range(nf):
            if q > 0 and f_hz[i, q] == f_hz[i, q - 1] and output_of[q] == output_of[q - 1]:
                for r in range(n_road):
                    for o in range(n_out):
                        out[r, o, i, q] = out[r, o, i, q - 1]
                continue
            w = 2.0 * math.pi * f_hz[i, q]
            _channel_frfs(w, lps, als, bes, pos, hs_re, hs_im)
            _channel_frfs(w, lpa, ala, bea, poa, ha_re, ha_im)
            # real (or unpaired) poles, rare: apart, so the pairs' loops stay vectorised
            if l1s.shape[0] > 0:
                _single_poles(w, l1s, rrs, ris, hs_re, hs_im)
            if l1a.shape[0] > 0:
                _single_poles(w, l1a, rra, ria, ha_re, ha_im)
            f = f_hz[i, q]
            first, last = (0, n_out) if output_of[q] < 0 else (output_of[q], output_of[q] + 1)
            if n_road > 1:  # several roads: each output's FRFs gathered once, then a tight loop per road
                _roads_psd(w, f, i, q, first, last, tau, coherence, coherent, road, col_s, col_a, hs_re, hs_im, ha_re, ha_im, gather, out)
                continue
            for r in range(n_road):
                cos_t, sin_t = math.cos(w * tau[r]), math.sin(w * tau[r])
                g = coherence[r, i, q] if coherent else 0.0
                g1, exponent = road[r, 0], road[r, 1]
                road_psd = g1 / (f * f) if exponent == 2.0 else g1 * f**-exponent  # w = 2: ISO 8608's classes
                for o in range(first, last):
                    sf, sr, af, ar = col_s[0, o], col_s[1, o], col_a[0, o], col_a[1, o]
                    out[r, o, i, q] = road_psd * _channel_power(
                        ((hs_re[sf], hs_im[sf]), (hs_re[sr], hs_im[sr])),
                        ((ha_re[af], ha_im[af]), (ha_re[ar], ha_im[ar])),
                        cos_t,
                        sin_t,
                        g,
                    )


@njit(cache=True)
def panel_edges(f_lo: float, f_hi: float, forced: np.ndarray, singularities: np.ndarray, kappa: float, out: np.ndarray) -> int:
    """The fewest panels from ``f_lo`` to ``f_hi`` whose Bernstein ellipses (of the parameter
    ``rho`` with ``kappa = (rho + 1/rho) / 2``) hold no singularity (docs/model.md §10.3).

    Walking up from ``f_lo``, each panel ``[a, c]`` is as long as every singularity ``s``
    allows: the ellipse with foci ``a``, ``c`` and semi-major axis ``kappa (c - a) / 2``
    excludes ``s`` while ``|s - a| + |s - c| >= kappa (c - a)``, i.e. up to
    ``c = a + 2 (kappa |s - a| - Re(s - a)) / (kappa^2 - 1)``.

    Parameters
    ----------
    forced : np.ndarray
        [Hz] sorted breakpoints every design keeps (e.g. the comfort bands' edges)
    singularities : np.ndarray
        ``(n, S)`` [Hz] complex singularities of the integrand (NaN: unused)
    out : np.ndarray
        ``(n, E)`` breakpoints written in place, each row NaN after its last up to the
        longest row; a row needing more than ``E - 1`` panels ends with one wide last panel

    Returns
    -------
    int
        The most breakpoints of a row (the columns of ``out`` in use).
    """
    n, e = out.shape
    scale = 2.0 / (kappa * kappa - 1.0)
    s_re = singularities.real
    s_im = singularities.imag
    counts = np.empty(n, dtype=np.int64)
    for i in range(n):
        a = f_lo
        out[i, 0] = a
        k = 1
        nxt = 0
        while a < f_hi:
            while nxt < forced.shape[0] and forced[nxt] <= a:
                nxt += 1
            c = f_hi if nxt == forced.shape[0] else forced[nxt]
            for j in range(s_re.shape[1]):
                re = s_re[i, j] - a
                if re == re:  # not NaN
                    im = s_im[i, j]
                    c = min(c, a + scale * (kappa * math.sqrt(re * re + im * im) - re))
            c = max(c, a + 1e-9 * (f_hi - f_lo))  # a singularity on the band: no progress otherwise
            if k == e - 1 or c >= f_hi:
                c = f_hi
            out[i, k] = c
            k += 1
            a = c
        counts[i] = k
    # Loops, not counts.max() and slice assignment: numba's generic versions of those (an
    # empty-array check, a shape-mismatch message built from strings) cost seconds to compile.
    used = 0
    for i in range(n):
        used = max(used, counts[i])
    for i in range(n):
        for j in range(counts[i], used):
            out[i, j] = np.nan
    return used


@njit(cache=True)
def balance(a: np.ndarray, sweeps: int) -> np.ndarray:
    """Diagonal scaling ``d`` (powers of two, ``(n, m)``) making ``diag(d)^-1 A diag(d)``'s
    rows and columns of comparable norm: Osborne's iteration (1960), as LAPACK's gebal does
    it, over a batch ``a`` ``(n, m, m)``; each sweep rescales every state at once from the
    previous sweep's row and column sums (off-diagonal, absolute)."""
    n, m, _ = a.shape
    d = np.ones((n, m))
    f = np.empty(m)
    for i in range(n):
        for _ in range(sweeps):
            for r in range(m):
                row = 0.0
                col = 0.0
                for c in range(m):
                    if c != r:
                        row += abs(a[i, r, c]) * d[i, c] / d[i, r]
                        col += abs(a[i, c, r]) * d[i, r] / d[i, c]
                f[r] = 2.0 ** round(0.5 * math.log2(row / col)) if row > 0 and col > 0 else 1.0
            for r in range(m):
                d[i, r] *= f[r]
    return d


@njit(cache=True)
def weighted_sums(
    f_hz: np.ndarray,
    w_hz: np.ndarray,
    psd: np.ndarray,
    gains: np.ndarray,
    gain_num: np.ndarray,
    gain_den: np.ndarray,
    base: np.ndarray,
    power: np.ndarray,
    scale2: np.ndarray,
    gain_of: np.ndarray,
    panel_size: int,
    totals: np.ndarray,
    panel_abs: np.ndarray,
    panel_sum: np.ndarray,
) -> None:
    """The quadrature sums of every integral ``r`` over one batch's nodes, in node order.

    The integrand of ``r`` at a node is ``|W|^2 scale2 omega^(2 power) S_base`` (the
    weighting ``gain_of[r]``, none for -1; a derived output's PSD from its base's, as
    :meth:`hisopt.evaluation.evaluate.Evaluator._derive`).

    Parameters
    ----------
    f_hz, w_hz : np.ndarray
        ``(n, F)`` nodes and weights
    psd : np.ndarray
        ``(O, n, F)`` the base outputs' PSDs
    gains : np.ndarray
        ``(W, n, F)`` squared weightings at the nodes, used when ``gain_num`` has no rows
    gain_num, gain_den : np.ndarray
        ``(W, D)`` else the weightings as rational functions of ``f^2``
        (ascending coefficients, zero-padded: :func:`hisopt.standards.iso_2631_1_1997.weighting_gain_squared`)
    base, power, scale2, gain_of : np.ndarray
        ``(R,)`` each integral's base output, power of
        ``omega^2``, squared scale and weighting
    panel_size : int
        nodes per panel of the first ``panel_sum.shape[1] * panel_size`` nodes
    totals : np.ndarray
        ``(n, R)`` ``sum w g``, written in place
    panel_abs, panel_sum : np.ndarray
        ``(n, P, R)`` ``sum |w g|`` and ``sum w g`` per panel, written
    """
    n, nf = f_hz.shape
    n_int = base.shape[0]
    n_panel_nodes = panel_sum.shape[1] * panel_size
    rational = gain_num.shape[0] > 0
    n_gain = gain_num.shape[0] if rational else gains.shape[0]
    gain = np.empty(max(n_gain, 1))
    totals[:] = 0.0
    panel_abs[:] = 0.0
    panel_sum[:] = 0.0
    two_pi = 2.0 * math.pi
    for i in range(n):
        for q in range(nf):
            wq = w_hz[i, q]
            if wq == 0.0:
                continue
            f = f_hz[i, q]
            omega2 = (two_pi * f) ** 2
            for k in range(n_gain):
                if rational:
                    x = f * f
                    num, den = gain_num[k, -1], gain_den[k, -1]
                    for c in range(gain_num.shape[1] - 2, -1, -1):
                        num = num * x + gain_num[k, c]
                    for c in range(gain_den.shape[1] - 2, -1, -1):
                        den = den * x + gain_den[k, c]
                    gain[k] = num / den
                else:
                    gain[k] = gains[k, i, q]
            p = q // panel_size
            for r in range(n_int):
                g = wq * scale2[r] * psd[base[r], i, q]
                for _ in range(power[r]):
                    g *= omega2
                if gain_of[r] >= 0:
                    g *= gain[gain_of[r]]
                totals[i, r] += g
                if q < n_panel_nodes:
                    panel_abs[i, p, r] += abs(g)
                    panel_sum[i, p, r] += g


@njit(cache=True)
def modal_terms(
    lam: np.ndarray,
    vec: np.ndarray,
    w_inv: np.ndarray,
    bp: np.ndarray,
    pos: np.ndarray,
    c: np.ndarray,
    columns: np.ndarray,
    lam_p: np.ndarray,
    alpha: np.ndarray,
    beta: np.ndarray,
    lam_1: np.ndarray,
    r_re: np.ndarray,
    r_im: np.ndarray,
) -> None:
    """The residues of a channel's displacement outputs in the layout of :func:`channel_psd`,
    conjugate pairs summed (:func:`hisopt.evaluation.pole_residue.conjugate_pairs` does the same in
    numpy): ``rho_k = (c P v_k)(w_k B')`` for the columns ``(input, output)`` asked for.

    Parameters
    ----------
    lam, vec, w_inv : np.ndarray
        ``(n, k)`` poles, ``(n, k, k)`` right eigenvectors and their inverse
    bp, pos : np.ndarray
        ``(n, k, m)`` input map ``B'``, ``(n, W, k)`` the DOFs (and any accumulator volumes)
        from the states
    c : np.ndarray
        ``(O, W)`` each output's combination of them
    columns : np.ndarray
        ``(C, 2)`` the input and output of each column
    lam_p, alpha, beta, lam_1, r_re, r_im : np.ndarray
        results (pairs ``(n, P)``, ``(n, P, C)``;
        other poles ``(n, S)``, ``(n, S, C)``), padded with a pole at -1 of zero residue
    """
    n, k = lam.shape
    n_col = columns.shape[0]
    cv = np.empty((c.shape[0], k), dtype=np.complex128)
    wb = np.empty((k, bp.shape[2]), dtype=np.complex128)
    for i in range(n):
        upper = 0
        lower = 0
        for kk in range(k):
            if lam[i, kk].imag > 0:
                upper += 1
            elif lam[i, kk].imag < 0:
                lower += 1
        paired = upper == lower
        for o in range(c.shape[0]):
            for kk in range(k):
                acc = 0j
                for j in range(c.shape[1]):
                    if c[o, j] != 0.0:
                        v = 0j
                        for s in range(k):
                            v += pos[i, j, s] * vec[i, s, kk]
                        acc += c[o, j] * v
                cv[o, kk] = acc
        for kk in range(k):
            for a in range(bp.shape[2]):
                acc = 0j
                for s in range(k):
                    acc += w_inv[i, kk, s] * bp[i, s, a]
                wb[kk, a] = acc
        ip = 0
        i1 = 0
        for kk in range(k):
            li = lam[i, kk]
            if paired and li.imag < 0:
                continue
            if paired and li.imag > 0:
                lam_p[i, ip] = li
                for col in range(n_col):
                    rho = cv[columns[col, 1], kk] * wb[kk, columns[col, 0]]
                    alpha[i, ip, col] = -2.0 * (rho.real * li.real + rho.imag * li.imag)
                    beta[i, ip, col] = 2.0 * rho.real
                ip += 1
            else:
                lam_1[i, i1] = li
                for col in range(n_col):
                    rho = cv[columns[col, 1], kk] * wb[kk, columns[col, 0]]
                    r_re[i, i1, col] = rho.real
                    r_im[i, i1, col] = rho.imag
                i1 += 1
        for j in range(ip, lam_p.shape[1]):
            lam_p[i, j] = -1.0
            alpha[i, j, :] = 0.0
            beta[i, j, :] = 0.0
        for j in range(i1, lam_1.shape[1]):
            lam_1[i, j] = -1.0
            r_re[i, j, :] = 0.0
            r_im[i, j, :] = 0.0


@njit(cache=True)
def local_maxima(values: np.ndarray, share: float, out: np.ndarray) -> None:
    """Per row, the column of the highest sample and of the highest local maximum not next to
    it (its own column again where that one is below ``share`` of the highest); ``out`` is
    ``(n, 2)``, written in place."""
    n, size = values.shape
    for i in range(n):
        first = 0
        for q in range(1, size):
            if values[i, q] > values[i, first]:
                first = q
        second = first
        best = -np.inf
        for q in range(size):
            if abs(q - first) <= 1:
                continue
            v = values[i, q]
            if (q == 0 or v >= values[i, q - 1]) and (q == size - 1 or v >= values[i, q + 1]) and v > best:
                best, second = v, q
        if not best >= share * values[i, first]:
            second = first
        out[i, 0] = first
        out[i, 1] = second


@njit(cache=True)
def mirror_deviation(a: np.ndarray, image: np.ndarray, sign: np.ndarray, parity: float) -> float:
    """Largest ``|parity s_i s_j a[image_i, image_j] - a[i, j]|`` relative to the largest
    ``|a|`` of its design, over a batch ``a`` ``(n, r, c)``; the columns map to themselves
    with sign 1 when ``a`` is not square (an input map)."""
    n, rows, cols = a.shape
    square = rows == cols
    worst = 0.0
    for i in range(n):
        scale = 0.0
        for r in range(rows):
            for c in range(cols):
                scale = max(scale, abs(a[i, r, c]))
        if scale == 0.0:
            continue
        for r in range(rows):
            for c in range(cols):
                ic, sc = (image[c], sign[c]) if square else (c, 1.0)
                worst = max(worst, abs(parity * sign[r] * sc * a[i, image[r], ic] - a[i, r, c]) / scale)
    return worst


@njit(cache=True)
def lay_nodes(
    poles: np.ndarray,
    fixed: np.ndarray,
    forced: np.ndarray,
    f_lo: float,
    f_hi: float,
    kappa: float,
    gl_x: np.ndarray,
    gl_w: np.ndarray,
    max_panels: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every design's panels, their Gauss-Legendre nodes and the peak samples, in one pass
    (the steps of :mod:`hisopt.evaluation.quadrature`, compiled together).

    Parameters
    ----------
    poles : np.ndarray
        ``(n, k)`` [rad/s] the designs' poles (singularities at ``(Im - j Re) / 2 pi``,
        undamped ones moved off the axis by ``1e-9 |f|``; non-finite ones ignored)
    fixed : np.ndarray
        ``(S,)`` [Hz] singularities of every design (upper half plane)
    forced, f_lo, f_hi, kappa
        as :func:`panel_edges`
    gl_x, gl_w : np.ndarray
        Gauss-Legendre nodes and weights on [-1, 1]
    max_panels : int
        panels per design at most

    Returns
    -------
    tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
        edges ``(n, P + 1)`` (NaN after each row's last), nodes and weights ``(n, P order)``
        (unused panels: nodes at ``f_hi``, weight 0), peak samples ``(n, k + 2)`` (the band
        limits and every in-band damped frequency, ``f_hi`` for the others; sorted).
    """
    n, k = poles.shape
    sing = np.empty((n, k + fixed.shape[0]), dtype=np.complex128)
    peaks = np.empty((n, k + 2))
    for i in range(n):
        for j in range(k):
            lam = poles[i, j]
            fr, fi = lam.imag / (2 * math.pi), lam.real / (2 * math.pi)
            height = max(abs(fi), 1e-9 * math.sqrt(fr * fr + fi * fi))
            sing[i, j] = complex(fr, height)
            peaks[i, j + 2] = fr if f_lo < fr < f_hi else f_hi
        for j in range(fixed.shape[0]):
            sing[i, k + j] = fixed[j]
        peaks[i, 0], peaks[i, 1] = f_lo, f_hi
        # sorted by insertion (no NaN here): np.sort's quicksort and the copy back cost
        # seconds to compile, and the row is short
        for a in range(1, k + 2):
            v = peaks[i, a]
            b = a - 1
            while b >= 0 and peaks[i, b] > v:
                peaks[i, b + 1] = peaks[i, b]
                b -= 1
            peaks[i, b + 1] = v
    edges = np.empty((n, max_panels + 1))
    used = panel_edges(f_lo, f_hi, forced, sing, kappa, edges)
    edges = edges[:, :used]
    order = gl_x.shape[0]
    n_panels = used - 1
    f = np.empty((n, n_panels * order))
    w = np.empty((n, n_panels * order))
    for i in range(n):
        top = f_lo
        for p in range(used):
            if edges[i, p] == edges[i, p]:
                top = edges[i, p]
        for p in range(n_panels):
            lo, hi = edges[i, p], edges[i, p + 1]
            if not hi == hi:  # padding: zero-width panels at the last breakpoint
                lo = hi = top
            elif not lo == lo:
                lo = top
            half, mid = 0.5 * (hi - lo), 0.5 * (hi + lo)
            for q in range(order):
                f[i, p * order + q] = mid + half * gl_x[q]
                w[i, p * order + q] = half * gl_w[q]
    return edges, f, w, peaks
