"""Output FRFs from poles and residues: exact for the lumped model (docs/model.md §10.1).

For a (sub)system ``dx/dt = A x + B' u`` whose DOFs are ``X = P x`` (``P`` the position
map: the first seven states, or a half's rows of the symmetric basis), an output
``y = sum_p s^p (c_p . X + d_p . u)`` has

    H_y(s) = sum_k rho_k / (s - lambda_k) + sum_m s^m D_m

with residues ``rho_k = sum_p lambda_k^p (c_p P v_k)(w_k B')`` (``v_k``, ``w_k`` right and left
eigenvectors) and exact Markov terms ``D_m`` from ``c_p P A^j B'`` (``s^p / (s - lambda) =
lambda^p / (s - lambda) + sum_j s^(p-1-j) lambda^j``).

The state matrix is balanced first (a diagonal similarity by powers of two, Osborne's
iteration, batched), so that a network whose states span many decades (pressures in Pa next
to displacements in m) still gives accurate eigenvectors; :attr:`PoleResidue.conditioning`
estimates what is left.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np

from hisopt.coupled.response import Output

BALANCE_SWEEPS = 2
"""Osborne sweeps (two bring the rows and columns of the coupled model within a factor of a
few; more change no result measurably, docs/model.md §10.1)."""


def balance(a: np.ndarray, sweeps: int = BALANCE_SWEEPS) -> np.ndarray:
    """Diagonal scaling ``d`` (powers of two, ``(n, m)``) making ``diag(d)^-1 A diag(d)``'s
    rows and columns of comparable norm (Osborne 1960; as LAPACK's gebal, batched:
    :func:`hisopt.evaluation.kernels.balance`).

    Parameters
    ----------
    a : np.ndarray
        ``(n, m, m)`` state matrices
    """
    from hisopt.evaluation.kernels import balance as compiled

    return compiled(np.ascontiguousarray(a, dtype=float), sweeps)


class PoleResidue:
    """FRFs of outputs of one (sub)system with ``m`` inputs, from its poles and residues.

    Parameters
    ----------
    a : np.ndarray
        ``(n, k, k)`` state matrix (batched over ``n`` designs)
    inputs : np.ndarray
        ``(n, k, m)`` input map ``B' = B0 + A B1`` of the inputs
    positions : np.ndarray
        ``(7, k)`` or ``(n, 7, k)``: the DOFs ``X = P x``, or ``(n, 7 + E, k)`` with the
        accumulators' oil volumes after them (outputs with ``7 + E`` columns)
    outputs : Sequence[Output]
        the outputs (their road feedthrough ``d`` already mapped to the ``m`` inputs)
    feedthrough : Sequence[np.ndarray]
        per output, ``(P, m)`` road terms ``d_p`` on the ``m`` inputs
    """

    def __init__(self, a: np.ndarray, inputs: np.ndarray, positions: np.ndarray, outputs: Sequence[Output], feedthrough: Sequence[np.ndarray]):
        n, k, m = inputs.shape
        d = balance(a)
        self._ab = a * (d[:, None, :] / d[:, :, None])
        lam, vec = np.linalg.eig(self._ab)
        w_inv = np.linalg.inv(vec)
        self.lam, self._vec, self._w_inv = lam, vec, w_inv
        # Eigenvalue condition numbers ||v_k|| ||w_k|| (columns of v have unit norm).
        self.conditioning = np.max(np.linalg.norm(w_inv, axis=-1), axis=-1)
        self._bp = inputs / d[:, :, None]  # balanced coordinates: x = diag(d) x'
        width = positions.shape[-2]  # 7, or 7 + E with the accumulators' oil volumes
        self._pos = np.broadcast_to(positions * d[:, None, :], (n, width, k))  # (n, W, k)
        self._positions = positions
        n_pow = max(o.c.shape[0] for o in outputs)
        c = np.zeros((n_pow, len(outputs), width))  # c_p of every output, (P, O, W)
        feed = np.zeros((n_pow, len(outputs), m))
        for i, (o, dd) in enumerate(zip(outputs, feedthrough, strict=True)):
            c[: o.c.shape[0], i, : o.c.shape[1]] = o.c
            feed[: dd.shape[0], i] = dd
        used = np.flatnonzero(np.any(c != 0, axis=(1, 2)) | np.any(feed != 0, axis=(1, 2)))
        n_pow = int(used[-1]) + 1 if used.size else 1  # the highest power with a term
        self._c, self._feed = c[:n_pow], feed[:n_pow]
        self.n_inputs, self.n_out = m, len(outputs)

    @functools.cached_property
    def _terms(self) -> tuple[np.ndarray, np.ndarray]:
        """``(residues (n, k, m, n_out), poly (n, n_pow, m, n_out))`` (numpy)."""
        lam, vec, pos, bp, c = self.lam, self._vec, self._pos, self._bp, self._c
        n, n_pow = len(lam), c.shape[0]
        wb = self._w_inv @ bp  # (n, k, m), complex
        pv = pos @ vec  # (n, W, k), complex
        weight = c[0] @ pv  # sum_p lambda^p c_p P v_k, (n, O, k)
        lam_p = np.ones_like(lam)
        powers = [pos @ bp]  # c-free Markov parameters P A^j B' (balanced), (n, W, m)
        for p in range(1, n_pow):
            lam_p = lam_p * lam
            weight = weight + lam_p[:, None, :] * (c[p] @ pv)
            if p < n_pow - 1:
                powers.append(pos @ np.linalg.matrix_power(self._ab, p) @ bp)
        terms = np.broadcast_to(self._feed, (n,) + self._feed.shape).copy()  # (n, P, O, m)
        for p in range(1, n_pow):  # s^p / (s - lambda) = lambda^p / (s - lambda) + sum_j s^(p-1-j) lambda^j
            for j in range(p):
                terms[:, p - 1 - j] += c[p] @ powers[j]
        residues = np.ascontiguousarray((weight[..., None] * wb[:, None]).transpose(0, 2, 3, 1))  # (n, k, m, n_out)
        return residues, np.ascontiguousarray(terms.transpose(0, 1, 3, 2))  # (n, n_pow, m, n_out)

    @property
    def residues(self) -> np.ndarray:
        """``(n, k, m, n_out)``: residue of each pole, input and output."""
        return self._terms[0]

    @property
    def poly(self) -> np.ndarray:
        """``(n, n_pow, m, n_out)``: the polynomial (Markov and road feedthrough) terms."""
        return self._terms[1]

    def kernel_terms(self, inputs: Sequence[int]) -> tuple[np.ndarray, ...]:
        """This form's terms for :func:`hisopt.evaluation.kernels.channel_psd`, the ``inputs`` (front
        axle, rear axle) of one road channel: ``(lam_pair, alpha, beta, lam_single,
        rho_single.real, rho_single.imag, poly, column)`` over the (axle, output) columns
        that are not zero by structure (``column`` ``(2, n_out)``, the zero column ``C``
        where one is)."""
        n, k = self.lam.shape
        inputs = list(inputs)
        pattern = np.abs(self._positions) if self._positions.ndim == 2 else np.any(self._positions != 0, axis=0).astype(float)
        seen = np.any(np.abs(self._c) @ pattern > 0, axis=(0, 2))  # the outputs the states reach
        driven = np.any(self._bp[:, :, inputs] != 0, axis=(0, 1))  # inputs that reach the states
        feed = self._feed[:, :, inputs]  # (P, O, 2)
        nonzero = (driven[:, None] & seen[None, :]) | np.any(feed != 0, axis=0).T  # (axle, output)
        column = np.where(nonzero.ravel(), np.cumsum(nonzero.ravel()) - 1, nonzero.sum()).reshape(nonzero.shape)
        axle, output = np.nonzero(nonzero)
        if self._c.shape[0] > 1:  # outputs with derivatives: the numpy route
            rho = self.residues[:, :, inputs][..., axle, output] if axle.size else np.zeros((n, k, 0))
            lam_p, alpha, beta, lam_1, rho_1 = conjugate_pairs(self.lam, rho.reshape(n, k, -1))
            poly = self.poly[:, :, inputs][..., axle, output]
            # contiguous copies of the real and imaginary views: the types the kernel is compiled for
            re, im = np.ascontiguousarray(rho_1.real), np.ascontiguousarray(rho_1.imag)
            return (lam_p, alpha, beta, lam_1, re, im, np.ascontiguousarray(poly), column.astype(np.int64))
        from hisopt.evaluation.kernels import modal_terms

        upper, lower = np.sum(self.lam.imag > 0, axis=1), np.sum(self.lam.imag < 0, axis=1)
        paired = upper == lower
        n_pair = int(np.max(np.where(paired, upper, 0), initial=0))
        n_single = int(np.max(np.where(paired, k - upper - lower, k), initial=0))
        cols = np.stack([np.asarray(inputs)[axle], output], axis=1).astype(np.int64)
        lam_p, lam_1 = np.empty((n, n_pair), complex), np.empty((n, n_single), complex)
        alpha, beta = np.empty((n, n_pair, len(cols))), np.empty((n, n_pair, len(cols)))
        r_re, r_im = np.empty((n, n_single, len(cols))), np.empty((n, n_single, len(cols)))
        # C-contiguous and writable (a copy of the read-only broadcast view), the one type compiled
        pos = np.require(self._pos, float, ["C", "W"])
        modal_terms(self.lam, self._vec, self._w_inv, self._bp, pos, self._c[0], cols, lam_p, alpha, beta, lam_1, r_re, r_im)
        # a copy, writable: a broadcast view of one design is read-only, a second type to compile
        poly = np.array(np.broadcast_to(feed[0][output, axle], (n, 1, len(cols))), order="C")
        return (lam_p, alpha, beta, lam_1, r_re, r_im, poly, column.astype(np.int64))

    def __call__(self, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """FRFs at ``s = j omega`` [rad/s] (``(n, F)``) as (real, imag), each ``(n, F, m, n_out)``
        (numpy; the evaluator's compiled kernel computes the same sums, :mod:`hisopt.evaluation.kernels`)."""
        s = 1j * omega
        h = np.einsum("nfk,nkmo->nfmo", 1.0 / (s[..., None] - self.lam[:, None, :]), self.residues)
        for m in range(self.poly.shape[1]):
            h = h + s[..., None, None] ** m * self.poly[:, None, m]
        return h.real, h.imag


def conjugate_pairs(lam: np.ndarray, rho: np.ndarray) -> tuple[np.ndarray, ...]:
    """The pole-residue form of a real system with each conjugate pair summed in real terms:
    ``rho / (s - lambda) + conj(rho) / (s - conj(lambda)) = (alpha + s beta) / (s^2 - 2 s
    Re(lambda) + |lambda|^2)`` with ``alpha = -2 Re(rho conj(lambda))``, ``beta = 2 Re(rho)``
    (half the divisions and products per frequency).

    Parameters
    ----------
    lam : np.ndarray
        ``(n, k)`` poles, real ones with imaginary part exactly 0 (as LAPACK returns them)
    rho : np.ndarray
        ``(n, k, C)`` residues

    Returns
    -------
    lam_pair, alpha, beta : tuple[np.ndarray, ...]
        ``(n, P)`` one pole of each pair (``Im > 0``) and ``(n, P, C)``
        its terms; lam_single, rho_single : ``(n, S)``, ``(n, S, C)`` the other poles (real,
        or left unpaired) as they are. Rows are padded with a pole at -1 of zero residue.
    """
    upper, lower = lam.imag > 0, lam.imag < 0
    paired = upper & (upper.sum(axis=1) == lower.sum(axis=1))[:, None]
    single = ~paired & ~(lower & paired.any(axis=1)[:, None])
    out = []
    for mask, pair in ((paired, True), (single, False)):
        count = mask.sum(axis=1)
        width = int(count.max(initial=0))
        order = np.argsort(~mask, axis=1, kind="stable")[:, :width]  # the mask's poles first
        used = np.arange(width) < count[:, None]
        poles = np.where(used, np.take_along_axis(lam, order, 1), -1.0)
        r = np.where(used[..., None], np.take_along_axis(rho, order[..., None], 1), 0.0)
        if pair:
            out += [poles, -2.0 * (r * np.conj(poles)[..., None]).real, 2.0 * r.real]
        else:
            out += [poles, r]
    return tuple(out)
