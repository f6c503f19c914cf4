"""Rounding-error budgets of the tests that compare two computational paths (docs/model.md §10.7).

Two paths that compute the same quantity by different arithmetic (two half-size
eigendecompositions against one full one, poles and residues against a direct solve, numpy
against CasADi) agree to the rounding each makes, amplified by the design's conditioning. That
amplification varies by orders of magnitude over a design box: a nearly undamped roll mode at a
corner makes a PSD peak ten thousand times more sensitive to rounding than a well damped one.
A fixed tolerance is then too loose for most designs and too tight for a few, and which few
fail depends on how the CPU's BLAS kernel rounds. Each budget here is a first-order bound
computed from the design's own matrices, times :data:`SAFETY`.

**Eigenvalues** (pole-residue paths). LAPACK's nonsymmetric eigensolver (``geev``, after its
own balancing ``gebal``) returns the exact eigenvalues of ``Ã + E`` with
``||E||_2 <= p(n) eps ||Ã||_2``, ``Ã`` the balanced matrix and ``p(n)`` a modest function of its
size (Golub and Van Loan, Matrix Computations, §7.5.6; here ``p(n) = n``). To first order each
eigenvalue then moves by ``|dλ_k| <= p(n) eps ||Ã||_2 κ_k`` with ``κ_k = ||x_k|| ||y_k|| /
|y_k^H x_k|`` (right and left eigenvectors; Wilkinson's condition number), and by ``geev``'s
balancing these are the numbers of ``Ã``, not of the raw state matrix, whose pressures in Pa
next to displacements in m would inflate both. A response near a pole is ``ρ / (jω - λ)``: a
pole shift changes it relatively by ``|dλ| / |jω - λ|``, at most ``|dλ| / d_k`` over a band,
``d_k`` the distance from ``λ_k`` to the band's segment ``j 2π [f_lo, f_hi]`` of the imaginary
axis (``|Re λ|`` for a pole in the band: lightly damped peaks are sharp), and a PSD ``|H|^2``
by twice that. The residues' errors are of the same first order (those of two nearly equal
poles cancel in their sum) and are left to :data:`SAFETY`. Integrals are sums of PSDs with
positive weights and maxima are maxima of PSDs, so a quantity's relative error is at most
its PSDs': the budget of a design is ``SAFETY * sum over paths of max_k 2 |dλ_k| / d_k``.

**Direct solves.** A path solves the HIS network ``M(jω)`` circuit by circuit for the stroke
dynamic stiffness ``D``, then the car's ``K_dyn H = F`` (``K_dyn = s^2 M + s C + K + G^T D G``,
or its stroke form). Entries assembled as sums are wrong by ``eps`` times their terms' size,
and LU with partial pivoting leaves a componentwise backward error of that order on these
matrices; to first order ``H`` then moves by ``eps |K_dyn^-1| (terms |H| + |F|)``, Skeel's
bound, which no choice of units changes (:func:`solve_budget`). ``D`` carries the network
solve's error: :func:`network_condition`, componentwise for numpy's LU (Skeel's condition of
the port impedance), normwise in the row- and column-equilibrated matrix for CasADi's solves
(its symbolic QR and its scaled LU; LAPACK's ``geequ`` rule). A state-space path instead
solves ``(jω I - A) x = B`` of the realisation, each entry of ``A`` a sum of up to ``k`` terms
(``k`` states; :func:`state_space_budget`). All are taken relative to each input's largest DOF
response, a PSD's error twice that, a quantity's the largest over its nodes.

**Safety.** :data:`SAFETY` covers what the first-order bounds leave out (the constants, the
residues, the quadrature's sums) and nothing else: on this machine's kernels (OpenBLAS
Haswell, Zen and Prescott, numba's generic CPU) the paths differ by at most 0.26 of their
budgets. The budgets stay below a real error: :func:`assert_discriminating` checks that a
path wrong by :data:`BUG` relative would fail on nearly every design of a test.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import scipy.linalg

EPS = float(np.finfo(float).eps)
"""[-] Machine epsilon of IEEE double precision (2.2e-16, twice the unit roundoff)."""

SAFETY = 10.0
"""[-] Factor on every first-order bound (module docstring)."""

BUG = 1e-6
"""[-] A relative error a budget must not hide (a wrong formula shows far above it)."""


def eigen_errors(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues ``(n, k)`` [rad/s] of the state matrices ``a`` ``(n, k, k)`` and the first-order
    bound ``n eps ||Ã||_2 κ_k`` [rad/s] on their rounding errors (module docstring)."""
    a = np.asarray(a, dtype=float)
    size = a.shape[-1]
    flat = a.reshape(-1, size, size)
    lam = np.empty(flat.shape[:2], dtype=complex)
    err = np.empty(flat.shape[:2])
    for i, m in enumerate(flat):
        balanced = scipy.linalg.matrix_balance(m, permute=True, separate=False)[0]  # as geev balances
        lam[i], x = np.linalg.eig(balanced)
        y = np.linalg.inv(x)  # rows: left eigenvectors with y_k x_k = 1
        kappa = np.linalg.norm(x, axis=0) * np.linalg.norm(y, axis=1)
        err[i] = size * EPS * np.linalg.norm(balanced, 2) * kappa
    return lam.reshape(a.shape[:-1]), err.reshape(a.shape[:-1])


def band_distance(lam: np.ndarray, f_lo: float, f_hi: float) -> np.ndarray:
    """[rad/s] Distance from each pole to the segment ``j 2π [f_lo, f_hi]`` [Hz] of the imaginary
    axis (poles come in conjugate pairs: the nearer of ``±`` the segment)."""
    w = np.abs(np.imag(lam))
    return np.hypot(np.real(lam), np.clip(w, 2 * np.pi * f_lo, 2 * np.pi * f_hi) - w)


def pole_budget(matrices: Iterable[np.ndarray], f_lo: float, f_hi: float, power: int = 2) -> np.ndarray:
    """[-] Relative budget ``(n,)`` of a response from poles and residues over ``[f_lo, f_hi]`` [Hz]
    against another path, each design's ``SAFETY * sum over matrices of max_k power |dλ_k| / d_k``.

    Parameters
    ----------
    matrices : the state matrices ``(n, k, k)`` both paths decompose (e.g. the full one and the
        two halves of the symmetric split; a direct solve adds none)
    power : 1 for FRFs, 2 for PSDs and the quantities from them
    """
    total = 0.0
    for a in matrices:
        lam, err = eigen_errors(a)
        with np.errstate(divide="ignore"):
            total = total + np.max(power * err / band_distance(lam, f_lo, f_hi), axis=-1)
    return SAFETY * np.asarray(total)


def equilibrated_condition(m: np.ndarray) -> np.ndarray:
    """[-] 2-norm condition number of ``m`` (``(..., n, n)``) after scaling its rows, then its
    columns, to a largest entry of 1 (LAPACK's ``geequ``): the condition that bounds an LU
    solve's relative error on a matrix whose unknowns have different units."""
    rows = m / np.abs(m).max(axis=-1, keepdims=True)
    return np.linalg.cond(rows / np.abs(rows).max(axis=-2, keepdims=True))


def network_condition(model, s: np.ndarray, backward: str = "componentwise") -> np.ndarray:
    """[-] Condition number of the HIS's port impedance ``P^T M(s)^-1 P`` (each circuit's network
    matrix ``M``, :func:`hisopt.hydraulics.network.network_matrix`) per design and ``s``, ``(n, F)``,
    for the backward error of the solve that computes it.

    ``"componentwise"``: each entry of ``M`` wrong by ``eps`` relative, as numpy's LU with partial
    pivoting leaves it (no growth on these matrices) and as rounding the entries does; Skeel's
    ``|| |P^T| |M^-1| |M| |X| || / ||P^T X||`` per port (``X = M^-1 P``), which no scaling of
    the rows or columns changes. ``"normwise"``: ``M`` wrong by ``eps`` times its norm after
    row and column equilibration, as CasADi's solves leave it (:func:`equilibrated_condition`).
    """
    from hisopt.hydraulics.network import network_matrix

    net = model.his.network
    m = network_matrix(net, model.his.values, s)
    worst = np.zeros(m.shape[:-2])
    for c in range(net.n_circuits):
        rows = net.circuit_rows(c)
        sub = m[..., rows[:, None], rows[None, :]]
        if backward == "normwise":
            worst = np.maximum(worst, equilibrated_condition(sub))
            continue
        p = net.injection[np.ix_(rows, np.flatnonzero(net.port_circuit == c))]
        x = np.linalg.solve(sub, np.broadcast_to(p, sub.shape[:-2] + p.shape))
        spread = np.abs(p.T) @ (np.abs(np.linalg.inv(sub)) @ (np.abs(sub) @ np.abs(x)))
        worst = np.maximum(worst, np.max(spread.max(axis=-2) / np.abs(p.T @ x).max(axis=-2), axis=-1))
    return worst


def solve_budget(model, f_hz: np.ndarray, power: int = 2, backward: tuple[str, ...] = ("componentwise",)) -> np.ndarray:
    """[-] Relative budget ``(n,)`` of the response by direct solves at ``f_hz`` [Hz] (``(F,)``) for
    each design of ``model``.

    ``K_dyn = s^2 M + s C + K + G^T D G`` is assembled with each entry wrong by ``eps`` times the
    sum of its terms' magnitudes, ``D`` by ``cond_net`` (:func:`network_condition`, summed over
    the paths' ``backward`` kinds) times ``eps |D|``, and the 7 x 7 solve by a componentwise
    ``eps |K_dyn|``; to first order ``H`` moves by ``eps |K_dyn^-1| ((terms + cond_net |G^T||D||G|) |H|
    + |F|)`` (Skeel's bound), taken relative to the largest DOF's response to each input. The
    budget: ``SAFETY * power`` times its largest value over ``f``."""
    from hisopt.vehicle import damping_matrix, mass_matrix, stiffness_matrix, stroke_matrix

    s = 2j * np.pi * np.asarray(f_hz, dtype=float)
    v = model.vehicle
    k = model.dynamic_stiffness(s)  # (n, F, 7, 7) (or (F, 7, 7) without a batch)
    road = np.broadcast_to(model.road_input(s), k.shape[:-1] + (4,))
    h = np.abs(np.linalg.solve(k, road))
    size = lambda a: np.abs(np.asarray(a))  # noqa: E731
    terms = size(s**2)[:, None, None] * size(mass_matrix(v)) + size(s)[:, None, None] * size(damping_matrix(v)) + size(stiffness_matrix(v))
    if model.his is not None:
        cond_net = sum(network_condition(model, s, kind) for kind in backward)
        g = size(stroke_matrix(model.vehicle))
        his = g.T @ size(model.his.stroke_impedance(s)) @ g
        terms = terms + (1 + cond_net[..., None, None]) * his
    spread = np.abs(np.linalg.inv(k)) @ (terms @ h + np.abs(road))
    ratio = spread.max(axis=-2) / h.max(axis=-2)
    return SAFETY * power * EPS * np.atleast_2d(ratio.max(axis=-1)).max(axis=-1)


def equilibrated_solve(m: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``m^-1 b`` by LU with partial pivoting on ``m`` with its rows, then its columns, scaled by
    powers of two (exact) to a largest entry near 1, so that the pivots do not depend on the
    unknowns' units. Unscaled, partial pivoting on a state matrix with displacements in m next
    to pressures in Pa picks pivots by unit and loses up to 1e-12 (a twin-accumulator design at
    140 Hz: the realised matrix exact to 6e-19, its scaled solve to 1e-16)."""
    rows = 2.0 ** -np.floor(np.log2(np.abs(m).max(axis=-1, keepdims=True)))
    scaled = m * rows
    cols = 2.0 ** -np.floor(np.log2(np.abs(scaled).max(axis=-2, keepdims=True)))
    return np.swapaxes(cols, -1, -2) * np.linalg.solve(scaled * cols, rows * b)


def state_space_frf_states(ss, s: np.ndarray) -> np.ndarray:
    """Every state's response ``(n, F, k, 4)`` at ``s = jω`` [rad/s] (``(F,)``), by
    :func:`equilibrated_solve` of ``(s I - A) x = B0 + s B1``."""
    lhs = s[:, None, None] * np.eye(ss.a.shape[-1]) - ss.a[..., None, :, :]
    rhs = ss.b0[..., None, :, :] + s[:, None, None] * ss.b1[..., None, :, :]
    return equilibrated_solve(lhs, np.broadcast_to(rhs, lhs.shape[:-1] + rhs.shape[-1:]))


def state_space_frf(ss, f_hz: np.ndarray) -> np.ndarray:
    """``X / z_g`` ``(n, F, 7, 4)`` of a :class:`hisopt.coupled.model.StateSpace` at ``f_hz`` [Hz]
    (:func:`state_space_frf_states`)."""
    return state_space_frf_states(ss, 2j * np.pi * np.asarray(f_hz, dtype=float))[..., :7, :]


def realisation_terms(model, ss) -> np.ndarray:
    """``(n, k, k)``: for each entry of the realised state matrix ``ss.a``, the sum of the
    magnitudes of the terms the realisation adds up to compute it (docs/model.md §3.8:
    ``A = (A_kd + A_ka S) / e_k @ T``, the algebraic elimination ``S`` and the invariants'
    ``T``); ``|A|`` for a model without HIS, whose matrix is assembled as it is."""
    r = ss.realisation
    if r is None:
        return np.abs(ss.a)
    d = model.descriptor()
    kept, dyn, alg = r.kept, r.dynamic_index, r.algebraic_index
    terms = np.abs(d.a[..., kept[:, None], dyn[None, :]])
    if alg.size:
        terms = terms + np.abs(d.a[..., kept[:, None], alg[None, :]]) @ np.abs(r.recover)
    return terms / d.e[..., kept][..., None] @ np.abs(r.expand)


def state_space_budget(model, f_hz: np.ndarray, power: int = 1, inputs: np.ndarray | None = None) -> np.ndarray:
    """[-] Relative budget ``(n,)`` of :func:`state_space_frf` of ``model``'s realisation at
    ``f_hz`` [Hz] (``k`` states; ``inputs`` ``(n, k, m)``: other input columns than the road's
    ``B0 + jω B1``).

    Each entry of ``A`` is a sum of at most ``k`` terms, wrong by up to ``k eps`` times
    :func:`realisation_terms` (Higham, Accuracy and Stability of Numerical Algorithms, §3.1),
    and the equilibrated solve adds errors of that order in each entry of ``jω I - A`` and
    ``B``; to first order ``x`` moves by ``k eps |(jω I - A)^-1| ((|ω| I + terms) |x| + |B|)``
    (Skeel's componentwise bound, which no scaling of the states changes), taken relative to
    the largest DOF's response to each input. The budget: ``SAFETY * power`` times the
    largest of these over ``f``."""
    ss = model.state_space()
    s = 2j * np.pi * np.asarray(f_hz, dtype=float)
    k = ss.a.shape[-1]
    lhs = s[:, None, None] * np.eye(k) - ss.a[..., None, :, :]
    if inputs is None:
        b = np.abs(ss.b0[..., None, :, :]) + np.abs(s)[:, None, None] * np.abs(ss.b1[..., None, :, :])
        x = np.abs(state_space_frf_states(ss, s))
    else:
        b = np.abs(inputs[..., None, :, :])
        x = np.abs(equilibrated_solve(lhs, np.broadcast_to(inputs[..., None, :, :], lhs.shape[:-1] + inputs.shape[-1:])))
    terms = np.abs(s)[:, None, None] * np.eye(k) + realisation_terms(model, ss)[..., None, :, :]
    spread = np.abs(np.linalg.inv(lhs)) @ (terms @ x + b)
    ratio = spread[..., :7, :].max(axis=-2) / x[..., :7, :].max(axis=-2)
    return SAFETY * power * k * EPS * np.atleast_1d(ratio.max(axis=(-2, -1)))


def relative_excess(actual: np.ndarray, desired: np.ndarray, budget: np.ndarray) -> np.ndarray:
    """``|actual / desired - 1| / budget`` per design (NaN where both are NaN: 0)."""
    actual, desired = np.asarray(actual), np.asarray(desired)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.abs(actual - desired) / (np.abs(desired) * budget)
    return np.where(np.isnan(actual) & np.isnan(desired), 0.0, ratio)


def assert_within(actual: np.ndarray, desired: np.ndarray, budget: np.ndarray, what: str = "") -> None:
    """Assert ``|actual / desired - 1| <= budget`` design by design (both NaN counts as equal)."""
    excess = relative_excess(actual, desired, budget)
    if not np.all(excess <= 1.0):  # NaN fails too
        i = int(np.nanargmax(np.where(np.isnan(excess), np.inf, excess)))
        where = np.unravel_index(i, excess.shape)
        a, d, b = (np.broadcast_to(v, excess.shape)[where] for v in (actual, desired, budget))
        raise AssertionError(f"{what}: {abs(a / d - 1):.3g} relative at {where}, over its budget {b:.3g} ({int(np.sum(~(excess <= 1)))} over)")


def assert_discriminating(budget: np.ndarray, bug: float = BUG, share: float = 0.9) -> None:
    """Assert that a path wrong by ``bug`` relative would fail on at least ``share`` of the
    designs (their budgets lie below it): the budget is not so wide as to hide a real error."""
    caught = float(np.mean(np.asarray(budget) < bug))
    assert caught >= share, f"a {bug:g} relative error would pass on {1 - caught:.0%} of the designs (budgets up to {np.max(budget):.3g})"


def assert_frf_within(actual: np.ndarray, desired: np.ndarray, budget: np.ndarray, what: str = "") -> None:
    """Assert FRFs ``(n, F, dofs, inputs)`` agree within each design's ``budget`` relative to
    the response of each input at each frequency (the largest over the DOFs: the bounds above
    are normwise in the solution)."""
    scale = np.abs(desired).max(axis=-2, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        excess = (np.abs(actual - desired) / scale).max(axis=(1, 2, 3)) / budget
    if not np.all(excess <= 1.0):
        i = int(np.nanargmax(np.where(np.isnan(excess), np.inf, excess)))
        raise AssertionError(f"{what}: design {i} differs by {excess[i] * budget[i]:.3g} relative, over its budget {budget[i]:.3g}")
