"""The evaluator as it was before the speed work (issue 17), frozen: the "before" of
``benchmarks/bench_evaluate.py``, which runs it side by side with today's.

Algorithm: one eigendecomposition of the full 14-state matrix per design, pole-residue
FRFs by batched real matrix products, PSDs by numpy over arrays of designs x nodes x
outputs, fixed panels (8 log + 8 linear over the band) plus geometric clusters around every
pole, 4 Gauss-Legendre nodes per panel, peaks by five 7-point zoom steps. Copied from
hisopt/evaluation/evaluate.py and hisopt/evaluation/quadrature.py at commit 5653c0c (with
the two helpers that moved since, ``track_power`` and ``zoom_maximum``, inlined).

Frozen: it imports nothing from hisopt at run time. The helpers it used to import (linear
algebra, outputs, quantity registry, ISO 2631-1 weightings, ISO 8608 road PSD, coherence,
the metric dispatch, the parameter-rule check) are copied into ``legacy_helpers.py`` as they
were at commit abd5bcd. What it still takes from today's hisopt is its input, the same input
the new evaluator takes: the problem (its settings, ``design_matrix``, ``parameter_rule``)
and the coupled models ``problem.model(x)`` builds (``state_space()``, ``stiffness()`` and,
for distributed pipes, ``frequency_response(s)``). A change to the model moves both sides of
the benchmark alike; a change to the evaluator's numerics moves only the new side.
Not part of the package.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from legacy_helpers import (
    COMFORT_OUTPUTS,
    METRICS,
    Output,
    bmm,
    cbmm,
    class_gd_n0,
    cmul,
    comfort_gain_squared,
    isotropic_coherence,
    one_blas_thread,
    reduce_metrics,
    split,
    standard_outputs,
    temporal_psd,
    third_octave_bands,
)
from legacy_helpers import roll_gradient as roll_gradient_of_stiffness

if TYPE_CHECKING:  # the inputs: today's problem and its models (see the module docstring)
    from hisopt.coupled.model import CoupledModel
    from hisopt.specification.design_space import DesignSpace

FrfFn = Callable[..., Any]
"""``frf(s, output=None)``: output FRFs (n, F, 4 inputs, n_out) at ``s`` (n, F), or one output;
complex, or as (real, imag) parts (both accepted by :meth:`Evaluator.spectra`)."""


class Evaluator:
    """Objective/constraint evaluator of one problem, reusable across many calls.

    Parameters
    ----------
    problem : the problem (vehicle, HIS, road, band, comfort, objectives, constraints)
    chunk_size : designs per vectorised batch (bounds memory for any number of designs)
    order : Gauss-Legendre nodes per panel
    zoom_iterations : refinement steps of each PSD maximum (each shrinks the bracket 3x)
    base_panels : log- and linearly spaced panels over the band (each)
    pole_ratio : growth of the panel breakpoints' distance from each resonance

    The defaults keep every quantity within 1e-3 of a converged reference over the whole
    design box (tests check 0.5 %); ``benchmarks/bench_evaluate.py`` prints the errors.
    """

    def __init__(
        self,
        problem: DesignSpace,
        chunk_size: int = 256,
        order: int = 4,
        zoom_iterations: int = 5,
        base_panels: int = 8,
        pole_ratio: float = 5.0,
    ):
        spec = problem.spec
        self.problem = problem
        self.chunk_size = chunk_size
        self.order = order
        self.zoom_iterations = zoom_iterations
        self.names = tuple(dict.fromkeys(problem.objective_names + problem.constraint_names))
        self.metrics = [METRICS[n] for n in self.names]
        self.all_outputs = standard_outputs(spec.vehicle)
        wanted: list[str] = []
        for m in self.metrics:
            if m.kind == "comfort":
                wanted += list(COMFORT_OUTPUTS.values())
            elif m.output is not None:
                wanted.append(m.output)
        self.outputs: dict[str, Output] = {n: self.all_outputs[n] for n in dict.fromkeys(wanted)}
        self.output_index = {name: i for i, name in enumerate(self.outputs)}
        self.bases, self.derived = _share_outputs(self.outputs)
        self.base_index = {name: i for i, name in enumerate(self.bases)}
        self.f_lo, self.f_hi = spec.band.f_min_hz, spec.band.f_max_hz
        self.gd_n0 = class_gd_n0(spec.road.road_class)
        self.speed = spec.road.speed
        self.tau = spec.vehicle.wheelbase / self.speed
        extra = None
        if spec.comfort.method == "band":
            bands = third_octave_bands(self.f_lo, self.f_hi)
            extra = np.r_[bands.lower_hz, bands.upper_hz]
        self.base_edges = base_edges(self.f_lo, self.f_hi, base_panels, base_panels, extra_hz=extra)
        self.pole_ratio = pole_ratio

    # --- public ------------------------------------------------------------------------
    def __call__(self, designs: Any) -> dict[str, np.ndarray]:
        """Quantities by name, each shape ``(n,)``, plus ``"valid"`` (finite, stable model)."""
        x = self.problem.design_matrix(designs)
        with one_blas_thread():
            results = [self._chunk(x[i : i + self.chunk_size]) for i in range(0, max(len(x), 1), self.chunk_size)]
        return {k: np.concatenate([r[k] for r in results]) for k in results[0]}

    # --- internals -----------------------------------------------------------------------
    def _chunk(self, x: np.ndarray) -> dict[str, np.ndarray]:
        n = len(x)
        out = {name: np.full(n, np.nan) for name in self.names}
        valid = admissible(self.problem, x)  # finite and within every parameter's rule
        if not valid.any():
            return out | {"valid": valid}
        idx = np.flatnonzero(valid)
        with np.errstate(all="ignore"):
            for rows, model in self.problem.model(x[valid]).groups():
                try:
                    values, ok = self._solve(model)
                except (np.linalg.LinAlgError, ValueError):  # hisopt's ModelError is a ValueError
                    values, ok = self._one_by_one(x[valid][rows])
                for name in self.names:
                    out[name][idx[rows]] = np.where(ok, values[name], np.nan)
                valid[idx[rows]] = ok
        return out | {"valid": valid}

    def _one_by_one(self, x: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:
        values = {name: np.full(len(x), np.nan) for name in self.names}
        ok = np.zeros(len(x), dtype=bool)
        for i, row in enumerate(x):
            try:
                ((_, model),) = self.problem.model(row[None, :]).groups()
                v, good = self._solve(model)
            except (np.linalg.LinAlgError, ValueError):
                continue
            for name in self.names:
                values[name][i] = v[name][0]
            ok[i] = good[0]
        return values, ok

    def _solve(self, model: CoupledModel) -> tuple[dict[str, np.ndarray], np.ndarray]:
        ss = model.state_space()
        lam, vec = np.linalg.eig(ss.a)
        scale = np.abs(lam).max(axis=1)
        stable = np.all(lam.real <= 1e-9 * scale[:, None], axis=1) & np.all(np.isfinite(lam), axis=1)
        if model.pipe_model == "distributed":
            frf: FrfFn = DirectOutputs(model, self.bases)
        else:
            fast = PoleResidueOutputs(ss, lam, vec, self.bases)
            # Near-defective eigenvector bases make residues inaccurate: solve those directly.
            frf = fast
            if np.any(fast.conditioning > 1e8):
                frf = _mixed_frf(fast, DirectOutputs(model, self.bases), fast.conditioning > 1e8)
        values = self.quantities(lam, frf, model)
        ok = stable & np.all([np.isfinite(v) for v in values.values()], axis=0)
        return values, ok

    def nodes(self, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Quadrature nodes and weights per design (plus zero-weight band limits), sorted."""
        n = lam.shape[0]
        edges = np.concatenate([np.broadcast_to(self.base_edges, (n, self.base_edges.size)), pole_edges(lam, self.f_lo, self.f_hi, self.pole_ratio)], axis=1)
        f, w = panel_nodes(edges, self.order)
        f = np.concatenate([np.full((n, 1), self.f_lo), f, np.full((n, 1), self.f_hi)], axis=1)
        w = np.concatenate([np.zeros((n, 1)), w, np.zeros((n, 1))], axis=1)
        order = np.argsort(f, axis=1)
        return np.take_along_axis(f, order, 1), np.take_along_axis(w, order, 1)

    def spectra(self, f_hz: np.ndarray, h_out: np.ndarray | tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        """One-sided PSDs of the outputs at ``f_hz`` (n, F) from their FRFs (n, F, 4, n_out),
        complex or as (real, imag) parts.

        Returns shape ``(n, F, n_out)`` (paper Eq. 24, :func:`track_power`).
        """
        re, im = h_out if isinstance(h_out, tuple) else split(h_out)
        phase = 2 * np.pi * f_hz * self.tau
        cos, sin = np.cos(phase)[..., None], np.sin(phase)[..., None]
        coherence = None
        if self.problem.spec.road.coherence == "isotropic":
            v = self.problem.spec.vehicle
            coherence = isotropic_coherence(f_hz / self.speed, v.t_f + v.t_r)[..., None]
        fl, fr, rl, rr = ((re[..., k, :], im[..., k, :]) for k in range(4))
        power = track_power(fl, fr, rl, rr, cos, sin, coherence)
        return temporal_psd(f_hz, self.gd_n0, self.speed)[..., None] * power

    def quantities(self, lam: np.ndarray, frf: FrfFn, model: CoupledModel) -> dict[str, np.ndarray]:
        """All requested metrics from poles (for the nodes) and an FRF function of the bases."""
        f, w = self.nodes(lam)
        psd = self.spectra(f, frf(2j * np.pi * f))
        spectra = {name: self._derive(name, f, psd[..., self.base_index[base]]) for name, (base, _, _) in self.derived.items()}
        spec = self.problem.spec
        gains: dict[str, np.ndarray] = {}

        def integral(output: str, weighting: str | None) -> np.ndarray:
            if weighting is None:
                return _total(w * spectra[output])
            if weighting not in gains:
                gains[weighting] = comfort_gain_squared(f, weighting, spec.comfort, self.f_lo, self.f_hi)
            return _total(w * gains[weighting] * spectra[output])

        return reduce_metrics(
            self.metrics,
            spec.comfort,
            lambda name: self.outputs[name].weighting,  # type: ignore[arg-type,return-value]
            integral,
            lambda output: self._refined_max(output, f, spectra[output], frf),
            lambda name: roll_gradient(model),
        )

    def _derive(self, name: str, f_hz: np.ndarray, base_psd: np.ndarray) -> np.ndarray:
        """PSD of output ``name`` from its base: ``scale^2 omega^(2p) S_base``."""
        _, scale, power = self.derived[name]
        if power == 0 and scale == 1.0:
            return base_psd
        return scale**2 * (2 * np.pi * f_hz) ** (2 * power) * base_psd

    def _refined_max(self, name: str, f: np.ndarray, psd: np.ndarray, frf: FrfFn) -> np.ndarray:
        """Continuous maximum of output ``name``'s PSD (:func:`zoom_maximum`)."""
        base = self.derived[name][0]

        def values_at(pts: np.ndarray) -> np.ndarray:
            return self._derive(name, pts, self.spectra(pts, frf(2j * np.pi * pts, self.base_index[base]))[..., 0])

        return zoom_maximum(values_at, f, psd, self.zoom_iterations)[1]


class PoleResidueOutputs:
    """Output FRFs from poles and residues (exact for the lumped model).

    ``H_X(s) = C (sI - A)^-1 (B0 + s B1)``; with ``B' = B0 + A B1`` and displacement rows ``C``
    (``C B1 = 0``) this is ``C (sI - A)^-1 B'``. For an output ``sum_p s^p (c_p X + d_p z_g)``,
    ``s^p / (s - lam) = lam^p / (s - lam) + sum_j s^(p-1-j) lam^j`` gives
    ``H_y(s) = sum_k rho_k / (s - lam_k) + sum_m s^m D_m``: residues
    ``rho_k = sum_p lam_k^p (c_p v_k)(w_k B')`` and exact Markov terms ``D_m`` from ``C A^j B'``.
    """

    def __init__(self, ss: Any, lam: np.ndarray, vec: np.ndarray, outputs: dict[str, Output]):
        # Complex arithmetic on (real, imag) pairs: the products below are real gemm calls.
        self.names = tuple(outputs)
        self.lam = lam
        lam_c = split(lam)
        bp = ss.b0 + bmm(ss.a, ss.b1)
        w_inv = np.linalg.inv(vec)
        wb = cbmm(split(w_inv), (bp, np.zeros_like(bp)))  # (n, ns, 4)
        # Condition estimate of the eigenvector basis (columns of unit norm).
        self.conditioning = np.max(np.abs(w_inv), axis=(1, 2)) * np.sqrt(vec.shape[1])
        n_pow = max(o.c.shape[0] for o in outputs.values())
        powers = [bp]  # A^j B', for the Markov terms C A^j B'
        for _ in range(n_pow - 2):
            powers.append(bmm(ss.a, powers[-1]))
        markov = [pw[:, :7, :] for pw in powers]
        lam_pow = [(np.ones_like(lam_c[0]), np.zeros_like(lam_c[0]))]
        for _ in range(n_pow - 1):
            lam_pow.append(cmul(lam_pow[-1], lam_c))
        vec7 = split(vec[:, :7, :])
        rho_re, rho_im, poly = [], [], []
        for o in outputs.values():
            weight: tuple[Any, Any] = (0.0, 0.0)
            for p_ in range(o.c.shape[0]):
                cv = (bmm(o.c[p_][None, :], vec7[0])[:, 0, :], bmm(o.c[p_][None, :], vec7[1])[:, 0, :])  # (n, ns)
                term = cmul(cv, lam_pow[p_])
                weight = (weight[0] + term[0], weight[1] + term[1])
            r = cmul((weight[0][:, :, None], weight[1][:, :, None]), wb)
            rho_re.append(r[0])
            rho_im.append(r[1])
            d = np.zeros((len(lam), n_pow, 4))
            d[:, : o.d.shape[0], :] += o.d
            for p_ in range(o.c.shape[0]):
                for j in range(p_):
                    d[:, p_ - 1 - j, :] += bmm(o.c[p_][None, :], markov[j])[:, 0, :]
            poly.append(d)
        # Columns ordered input-major (4 inputs x n_out outputs) so that the front inputs
        # (FL, FR) and the rear inputs (RL, RR) are contiguous blocks for the track sums.
        n_out = len(rho_re)
        order = lambda parts: np.stack(parts, axis=3).reshape(len(lam), -1, 4 * n_out)  # noqa: E731
        self.rho = (order(rho_re), order(rho_im))  # (n, ns, 4 * n_out)
        self.n_out = n_out
        # [Re P, Im P] @ [[Re rho, Im rho], [-Im rho, Re rho]] = [Re h, Im h]: one real gemm.
        self.rho_block = _complex_block(*self.rho)
        self.poly = np.stack(poly, axis=3)  # (n, n_pow, 4, n_out), real

    def __call__(self, s: np.ndarray, output: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Output FRFs at ``s = j omega`` (n, F), as (real, imag) parts each (n, F, 4, n_out)
        (inputs FL, FR, RL, RR, then outputs; (n, F, 4, 1) for one ``output``)."""
        rho, poly = self.rho_block, self.poly
        if output is not None:
            cols = np.arange(4) * self.n_out + output
            rho = _complex_block(self.rho[0][:, :, cols], self.rho[1][:, :, cols])
            poly = poly[..., output : output + 1]
        omega = np.asarray(s).imag
        # 1 / (j omega - lam) in real arithmetic, real and imaginary parts side by side.
        ns = self.lam.shape[1]
        a = -self.lam.real[:, None, :]
        b = omega[..., None] - self.lam.imag[:, None, :]
        inv = 1.0 / (a * a + b * b)
        p = np.empty(omega.shape + (2 * ns,))
        np.multiply(a, inv, out=p[..., :ns])
        np.multiply(-b, inv, out=p[..., ns:])
        h = bmm(p, rho)
        half = h.shape[-1] // 2
        shape = omega.shape + poly.shape[2:]
        h_re, h_im = h[..., :half].reshape(shape), h[..., half:].reshape(shape)
        for m in range(poly.shape[1]):
            if np.any(poly[:, m]):
                # (j omega)^m is real for even m, imaginary for odd m.
                w_m = (omega**m * (-1.0) ** (m // 2))[..., None, None]
                term = w_m * poly[:, None, m]
                if m % 2 == 0:
                    h_re = h_re + term
                else:
                    h_im = h_im + term
        return h_re, h_im


class DirectOutputs:
    """Output FRFs by direct solve of the dynamic stiffness (any pipe model; reference path)."""

    def __init__(self, model: CoupledModel, outputs: dict[str, Output]):
        self.model = model
        self.outputs = outputs
        self.names = tuple(outputs)

    def __call__(self, s: np.ndarray, output: int | None = None) -> np.ndarray:
        """Complex output FRFs (n, F, 4, n_out), as :class:`PoleResidueOutputs`."""
        h_x = self.model.frequency_response(s)
        outputs = list(self.outputs.values())
        chosen = outputs if output is None else [outputs[output]]
        return np.stack([o.frf(h_x, s) for o in chosen], axis=-1)


def admissible(problem: DesignSpace, x: np.ndarray) -> np.ndarray:
    """[-] Rows whose every value is finite and obeys its parameter's rule, ``(n,)``
    (``hisopt/specification/validation.py`` at abd5bcd; the rules are the problem's)."""
    x = np.asarray(x, dtype=float)
    ok = np.ones(x.shape[0], dtype=bool)
    for j, name in enumerate(problem.variable_names):
        ok &= problem.parameter_rule(name).holds(x[:, j])
    return ok


def _total(terms: np.ndarray) -> np.ndarray:
    """Row sums in sequential order (zero-weight padding nodes add exact zeros)."""
    return np.cumsum(terms, axis=1)[:, -1]


def _share_outputs(outputs: dict[str, Output]) -> tuple[dict[str, Output], dict[str, tuple[str, float, int]]]:
    """Evaluate fewer FRFs: an output ``s^p (c . X)`` is a multiple of a displacement output.

    Returns the base outputs to evaluate and, per output, ``(base, scale, p)`` with
    ``S_y = scale^2 omega^(2p) S_base`` (e.g. ``acc_y = -h_0s phi''`` from ``roll``).
    """
    bases: dict[str, Output] = {}
    derived: dict[str, tuple[str, float, int]] = {}
    pure: dict[str, np.ndarray] = {}  # base name -> displacement vector of a pure (p = 0, no road term) base
    for name, out in outputs.items():
        rows = np.flatnonzero(np.any(out.c != 0, axis=1))
        if len(rows) != 1 or np.any(out.d):
            bases[name], derived[name] = out, (name, 1.0, 0)
            continue
        p, vec = int(rows[0]), out.c[rows[0]]
        k = int(np.flatnonzero(vec)[0])
        for bname, bvec in pure.items():
            if np.allclose(vec * bvec[k], bvec * vec[k], rtol=0, atol=0):
                derived[name] = (bname, float(vec[k] / bvec[k]), p)
                break
        else:
            bases[name] = Output(name, out.unit, vec[None, :], np.zeros((1, 4)), out.weighting)
            pure[name] = vec
            derived[name] = (name, 1.0, p)
    return bases, derived


def _complex_block(re: np.ndarray, im: np.ndarray) -> np.ndarray:
    """``[[re, im], [-im, re]]`` along the last two axes (real form of a complex right factor)."""
    return np.concatenate([np.concatenate([re, im], axis=-1), np.concatenate([-im, re], axis=-1)], axis=-2)


def _mixed_frf(fast: FrfFn, slow: FrfFn, use_slow: np.ndarray) -> FrfFn:
    """FRF from ``fast`` except for the designs flagged in ``use_slow``."""

    def frf(s: np.ndarray, output: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        re, im = fast(s, output)
        exact = slow(s, output)[use_slow]
        re[use_slow], im[use_slow] = exact.real, exact.imag
        return re, im

    return frf


def poles(model: CoupledModel) -> np.ndarray:
    """[rad/s] Eigenvalues of the model's (lumped) state space, ``(n, n_states)``, computed as
    the evaluator computes them (with eigenvectors: the same LAPACK path), so nodes placed
    from them are the evaluator's own."""
    return np.linalg.eig(model.state_space().a)[0]


def roll_gradient(model: CoupledModel) -> np.ndarray:
    """[rad/g] Static roll angle per 1 g of a batch of models, shape (n,) (:func:`legacy_helpers.roll_gradient`)."""
    return roll_gradient_of_stiffness(model.stiffness(), model.vehicle)


def track_power(fl, fr, rl, rr, cos_t, sin_t, coherence=None):
    l_re = fl[0] + cos_t * rl[0] + sin_t * rl[1]
    l_im = fl[1] + cos_t * rl[1] - sin_t * rl[0]
    r_re = fr[0] + cos_t * rr[0] + sin_t * rr[1]
    r_im = fr[1] + cos_t * rr[1] - sin_t * rr[0]
    power = l_re * l_re + l_im * l_im + r_re * r_re + r_im * r_im
    if coherence is not None:
        power = power + 2.0 * coherence * (l_re * r_re + l_im * r_im)
    return power


def zoom_maximum(
    values_at: Callable[[np.ndarray], np.ndarray],
    f_hz: np.ndarray,
    values: np.ndarray,
    steps: int,
    points: int = 7,
) -> tuple[np.ndarray, np.ndarray]:
    """[Hz], [value] Continuous maximum of a function sampled at sorted nodes, per row.

    The bracket of the best node (its neighbours) holds the peak when the nodes resolve
    every resonance (pole-aware panels do); each step samples ``points`` evenly in the
    bracket and keeps the neighbours of the best, shrinking it by ``2 / (points - 1)``.

    Parameters
    ----------
    values_at : the function at frequencies ``(n, points)`` [Hz] -> ``(n, points)``
    f_hz, values : nodes and values, ``(n, F)`` (a node of value ``-inf`` is never chosen)
    steps : zoom steps
    """
    rows = np.arange(len(f_hz))
    i = np.argmax(values, axis=1)
    best, f_best = values[rows, i], f_hz[rows, i]
    lo = f_hz[rows, np.maximum(i - 1, 0)]
    hi = f_hz[rows, np.minimum(i + 1, f_hz.shape[1] - 1)]
    t = np.linspace(0.0, 1.0, points)
    for _ in range(steps):
        pts = lo[:, None] + (hi - lo)[:, None] * t
        vals = values_at(pts)
        j = np.argmax(vals, axis=1)
        better = vals[rows, j] > best
        best = np.where(better, vals[rows, j], best)
        f_best = np.where(better, pts[rows, j], f_best)
        lo = pts[rows, np.maximum(j - 1, 0)]
        hi = pts[rows, np.minimum(j + 1, points - 1)]
    return f_best, best


# --- hisopt/evaluation/quadrature.py at 5653c0c --------------------------------------------------


def base_edges(f_lo_hz: float, f_hi_hz: float, n_log: int = 24, n_lin: int = 24, extra_hz: np.ndarray | None = None) -> np.ndarray:
    """[Hz] Fixed panel breakpoints: log- and linearly spaced over the band, plus ``extra_hz``."""
    edges = np.r_[np.geomspace(f_lo_hz, f_hi_hz, n_log + 1), np.linspace(f_lo_hz, f_hi_hz, n_lin + 1)]
    if extra_hz is not None:
        extra = np.asarray(extra_hz, dtype=float)
        edges = np.r_[edges, extra[(extra > f_lo_hz) & (extra < f_hi_hz)]]
    return np.unique(edges)


def pole_edges(poles: np.ndarray, f_lo_hz: float, f_hi_hz: float, ratio: float = 3.0, levels: int = 8, reach: float = 0.5) -> np.ndarray:
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
