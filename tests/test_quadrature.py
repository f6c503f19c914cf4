"""Error-controlled quadrature, peak search and the compiled kernels (docs/model.md §10.3-§10.4)."""

import numpy as np
import pytest

from hisopt.evaluation import kernels, quadrature
from hisopt.evaluation.channels import DirectOutputs, ModalChannels, frf_power
from hisopt.evaluation.peaks import refine_maximum
from hisopt.evaluation.quadrature import POLE_MARGIN, design_rho, panel_nodes, panels, ripple_error, ripple_splits, singularities
from hisopt.evaluation.symmetry import split, state_mirror
from tests.conftest import random_designs
from tests.error_budget import EPS, SAFETY, assert_discriminating, pole_budget, solve_budget


def ellipse_rho(lo: np.ndarray, hi: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Bernstein-ellipse parameter of panel [lo, hi] through s, from the foci distances."""
    kappa = (np.abs(s - lo) + np.abs(s - hi)) / (hi - lo)  # semi-major axis / half-width
    return kappa + np.sqrt(kappa**2 - 1)


def test_panels_keep_every_singularity_outside_their_ellipse_and_are_maximal(problem, rng):
    ev = problem.evaluator()
    x = random_designs(problem, 6, rng)
    lam = np.linalg.eigvals(problem.model(x).state_space().a)
    sing = singularities(lam, ev.fixed_singularities)
    rho = design_rho(ev.order, ev.tolerance / POLE_MARGIN)
    edges = panels(ev.f_lo, ev.f_hi, ev.forced_edges, sing, ev.order, ev.tolerance)
    for row, e in zip(sing, edges, strict=True):
        e = e[np.isfinite(e)]
        assert e[0] == ev.f_lo and e[-1] == ev.f_hi and np.all(np.diff(e) > 0)
        each = np.array([ellipse_rho(a, b, row).min() for a, b in zip(e[:-1], e[1:], strict=True)])
        assert np.all(each >= rho * (1 - 1e-9))
        # and no breakpoint could be dropped: the merged panel would hold a singularity
        merged = np.array([ellipse_rho(a, b, row).min() for a, b in zip(e[:-2], e[2:], strict=True)])
        assert np.all(merged < rho * (1 + 1e-9))


@pytest.mark.parametrize("half_width", [1e-4, 1e-2, 0.3])
def test_gauss_nodes_integrate_a_resonance_to_the_tolerance(half_width):
    """A Lorentzian at 3 Hz over the band, against its closed form: the error follows the
    tolerance (within a small factor: the bound's constant is not known exactly)."""
    f0, b = 3.0, half_width
    sing = np.array([[f0 + 1j * b, -f0 + 1j * b, 0j]])
    exact = np.arctan((80 - f0) / b) - np.arctan((0.5 - f0) / b)
    for tolerance in (1e-3, 1e-5, 1e-8):
        f, w = panel_nodes(panels(0.5, 80.0, np.empty(0), sing, 4, tolerance), 4)
        value = np.sum(w * b / ((f - f0) ** 2 + b**2))
        assert abs(value / exact - 1) < 3 * tolerance, tolerance


def test_ripple_error_is_the_gauss_error_of_an_oscillation():
    x, w = np.polynomial.legendre.leggauss(4)
    for t in (0.05, 0.3, 0.8):
        k = 2 * np.pi * t
        err = abs(np.sum(w * np.cos(k * x)) - 2 * np.sin(k) / k) / 2
        assert ripple_error(np.array([t]), 4)[0] >= err * (1 - 1e-12)
    table = ripple_error(np.geomspace(1e-3, 10, 200), 4)
    assert np.all(np.diff(table) >= 0)


def test_ripple_splits_follow_the_speed():
    """Parts are shorter in tau h as needed, so slower (longer tau) needs more of them."""
    half = np.array([[1.0, 4.0, 10.0]])
    share = np.array([[0.3, 0.3, 0.01]])
    slow = ripple_splits(half, share, 2.6 / 5.0, 4, 1e-4)
    fast = ripple_splits(half, share, 2.6 / 33.0, 4, 1e-4)
    assert np.all(slow >= fast) and slow.sum() > fast.sum()
    tau = 2.6 / 5.0
    parts = slow[slow > 0]
    widths = (tau * half[slow > 0]) / parts
    assert np.all(ripple_error(widths, quadrature.SPLIT_ORDER) * share[slow > 0] <= 1e-4 * (1 + 1e-9))


def test_parabolic_peak_search_is_exact_for_a_lorentzian():
    f0, b = 4.2371, 0.0123
    lorentz = lambda f: 1.0 / ((f - f0) ** 2 + b**2)  # noqa: E731
    f = np.linspace(4.2, 4.3, 9)[None, :]
    where, best = refine_maximum(lorentz, f, lorentz(f), 1)
    assert where[0] == pytest.approx(f0, rel=1e-12) and best[0] == pytest.approx(1 / b**2, rel=1e-12)


@pytest.mark.parametrize("coherence", [False, True])
def test_compiled_kernel_equals_numpy_channel_power(problem, rng, coherence):
    ev = problem.evaluator()
    x = random_designs(problem, 10, rng)
    model = problem.model(x)
    modal = ModalChannels(model, model.state_space(), ev.bases)
    f = np.sort(rng.uniform(0.5, 80, (len(x), 40)), axis=1)
    g = rng.uniform(0, 1, f.shape) if coherence else None
    tau = ev.tau
    numpy_power = np.moveaxis(frf_power(modal(2 * np.pi * f), f, tau, g), -1, 0)
    direct = DirectOutputs(model, ev.bases).power(f, tau, g)
    compiled = modal.power(f, tau, g)
    # the same pole-residue sums in another order: each term's rounding, eps per operation on
    # sums of a few dozen terms (tests/error_budget.py: SAFETY times k eps, k the poles)
    k = modal.lam.shape[1]
    np.testing.assert_allclose(compiled, numpy_power, rtol=SAFETY * k * EPS, atol=SAFETY * k * EPS * np.abs(numpy_power).max())
    # against the direct solve: the eigendecompositions' and the solve's rounding, per design
    ss = model.state_space()
    halves = split(ss, state_mirror(model, ss))
    budget = pole_budget([h.a for h in halves.values()], 0.5, 80.0) + solve_budget(model, np.unique(f))
    assert_discriminating(budget)
    scale = np.abs(direct).max(axis=(0, 2), keepdims=True)  # per design: PSDs near a zero of one output
    error = np.max(np.abs(compiled - direct) / (np.abs(direct) + SAFETY * k * EPS * scale), axis=(0, 2))
    assert np.all(error <= budget), float(np.max(error / budget))
    one = np.full(f.shape[1], 3)  # only output 3 asked for: the others stay zero
    only = modal.power(f, tau, g, one)
    np.testing.assert_allclose(only[3], compiled[3], rtol=1e-14)
    assert not np.any(np.delete(only, 3, axis=0))


@pytest.mark.parametrize("rational", [False, True])
def test_weighted_sums_equal_numpy_sums(rng, rational):
    from hisopt.standards.iso_2631_1_1997 import weighting_gain_polynomials, weighting_gain_squared

    n, nf, order = 5, 12, 4
    f = np.sort(rng.uniform(0.5, 80, (n, nf)), axis=1)
    w = rng.uniform(0, 1, (n, nf))
    psd = rng.uniform(0, 1, (3, n, nf))
    if rational:  # the ISO weightings' own polynomials, evaluated in the loop
        (nk, dk), (nd, dd) = weighting_gain_polynomials("Wk"), weighting_gain_polynomials("Wd")
        width_n, width_d = max(len(nk), len(nd)), max(len(dk), len(dd))
        num = np.array([np.pad(nk, (0, width_n - len(nk))), np.pad(nd, (0, width_n - len(nd)))])
        den = np.array([np.pad(dk, (0, width_d - len(dk))), np.pad(dd, (0, width_d - len(dd)))])
        gains, table = np.empty((0, 0, 0)), np.stack([weighting_gain_squared(f, "Wk"), weighting_gain_squared(f, "Wd")])
    else:
        num = den = np.empty((0, 1))
        gains = table = rng.uniform(0, 1, (2, n, nf))
    base, power, scale2, gain_of = np.array([0, 2, 1]), np.array([0, 2, 1]), np.array([1.0, 4.0, 0.5]), np.array([-1, 0, 1])
    totals, panel_abs, panel_sum = np.empty((n, 3)), np.empty((n, nf // order, 3)), np.empty((n, nf // order, 3))
    kernels.weighted_sums(f, w, psd, gains, num, den, base, power, scale2, gain_of, order, totals, panel_abs, panel_sum)
    omega2 = (2 * np.pi * f) ** 2
    # the rounding budget (tests/error_budget.py): sums of nf positive products of up to 9
    # factors, and each path's |W|^2 by Horner's rule in f^2, 2 deg eps times the polynomials'
    # condition sum |a_i x^i| / |sum a_i x^i| (Higham §5.1)
    x2 = f.ravel() ** 2
    condition = max(np.max((np.abs(c) * x2[:, None] ** np.arange(len(c))).sum(1) / np.abs(np.polyval(c[::-1], x2))) for c in (*num, *den)) if rational else 0.0
    rtol = SAFETY * EPS * (nf + 9 + 2 * 2 * max(num.shape[1], den.shape[1]) * condition)
    for r in range(3):
        g = w * scale2[r] * omega2 ** power[r] * psd[base[r]] * (table[gain_of[r]] if gain_of[r] >= 0 else 1.0)
        np.testing.assert_allclose(totals[:, r], g.sum(axis=1), rtol=rtol)
        np.testing.assert_allclose(panel_sum[:, :, r], g.reshape(n, -1, order).sum(axis=2), rtol=rtol)
        np.testing.assert_allclose(panel_abs[:, :, r], np.abs(g).reshape(n, -1, order).sum(axis=2), rtol=rtol)


def test_balancing_evens_rows_and_columns():
    rng = np.random.default_rng(3)
    a = rng.standard_normal((4, 6, 6)) * np.logspace(-6, 6, 6)[None, :, None]  # rows of very different size
    d = kernels.balance(a, 6)
    b = a * (d[:, None, :] / d[:, :, None])
    off = ~np.eye(6, dtype=bool)
    ratio = lambda m: np.abs(m)[:, off].reshape(4, 6, 5).sum(2) / np.abs(np.swapaxes(m, 1, 2))[:, off].reshape(4, 6, 5).sum(2)  # noqa: E731
    assert np.max(np.abs(np.log2(ratio(b)))) < np.max(np.abs(np.log2(ratio(a))))
    assert np.all(np.log2(d) == np.round(np.log2(d)))  # powers of two: exact similarity
