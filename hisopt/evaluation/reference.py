"""The reference evaluator: direct solve on a given frequency grid (docs/model.md §10.7).

:func:`grid_quantities` is the evaluator stripped of every shortcut: the dynamic stiffness
solved at each grid frequency (any pipe model), trapezoid integrals, sample maxima. On
:func:`converged_grid` (a fine log grid plus points clustered around every mode, the modes
found by Newton's method on ``det K_dyn``, independent of the state space) it is the
converged reference the tests and ``benchmarks/bench_evaluate.py`` compare with; on a plain
grid it shows what sampling misses. Same road, comfort method and metric dispatch as the
evaluator (:mod:`hisopt.evaluation.psd`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from hisopt.coupled.operating_point import accumulator_rooms
from hisopt.evaluation.channels import DirectOutputs
from hisopt.evaluation.evaluate import Evaluator, static_quantity
from hisopt.evaluation.psd import comfort_gain_squared, reduce_metrics
from hisopt.evaluation.transient import transient_quantities

if TYPE_CHECKING:
    from hisopt.coupled.model import CoupledModel
    from hisopt.specification.design_space import DesignSpace


def _grid_chunk(ev: Evaluator, model: CoupledModel, f: np.ndarray) -> dict[str, np.ndarray]:
    """:func:`grid_quantities` of one chunk of designs on their grids ``f`` (n, F)."""
    spec = ev.problem.spec
    psd = ev.spectra(f, DirectOutputs(model, ev.outputs)(2 * np.pi * f))
    spectra = {name: psd[..., j] for name, j in ev.output_index.items()}

    wanted = [m.name for m in ev.metrics if m.kind == "transient"]
    transient = transient_quantities(model, model.car, wanted, spec.handling.step_g, spec.handling.gravity_moment) if wanted else {}

    def integral(output: str, weighting: str | None) -> np.ndarray:
        gain = 1.0 if weighting is None else comfort_gain_squared(f, weighting, spec.comfort, ev.f_lo, ev.f_hi)
        return np.trapezoid(gain * spectra[output], f, axis=1)

    return reduce_metrics(
        ev.metrics,
        spec.comfort,
        lambda name: ev.outputs[name].weighting,  # type: ignore[arg-type,return-value]
        integral,
        lambda output: spectra[output].max(axis=1),
        lambda name: static_quantity(model, name, spec.handling.gravity_moment),
        transient.__getitem__,
        lambda: accumulator_rooms(model.his) if model.his is not None else [],
    )


def grid_quantities(problem: DesignSpace, designs: Any, f_hz: np.ndarray, chunk_size: int = 32) -> dict[str, np.ndarray]:
    """Every quantity by direct solve on a grid, trapezoid integrals and sample maxima.

    Parameters
    ----------
    f_hz : np.ndarray
        [Hz] grid, shape ``(F,)`` shared by all designs or ``(n, F)`` per design, sorted
    """
    ev = Evaluator(problem)
    x = problem.design_matrix(designs)
    f_all = np.broadcast_to(np.asarray(f_hz, dtype=float), (len(x), np.shape(f_hz)[-1]))
    parts = [_grid_chunk(ev, problem.model(x[i : i + chunk_size]), f_all[i : i + chunk_size]) for i in range(0, len(x), chunk_size)]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def converged_grid(problem: DesignSpace, design: Any, log_points: int = 20_001, per_mode: int = 2_001) -> np.ndarray:
    """[Hz] A grid on which :func:`grid_quantities` of ``design`` converges to ~1e-6: a log
    grid over the band plus ``per_mode`` points ``f_d + b tan(theta)`` around every mode
    (Lorentzian peaks become flat in ``theta``). The modes are the roots of ``det K_dyn``
    (Newton's method from the lumped state space's eigenvalues), so the grid is right even
    where the state matrix's eigenvalues are not (pipes of micrometres)."""
    from hisopt.coupled.modal import refine_roots
    from hisopt.coupled.model import CoupledModel

    band = problem.spec.band
    x = problem.design_matrix(design)[:1]
    model = problem.model(x)
    lumped = model if model.pipe_model == "lumped" else CoupledModel(model.vehicle, model.his.lumped() if model.his else None)
    groups = lumped.groups()
    lam = np.linalg.eigvals(groups[0][1].state_space().a[0])
    lam = lam[(lam.imag > 0) & (np.abs(lam) < 2 * np.pi * 10 * band.f_max_hz)]
    with np.errstate(all="ignore"):
        try:
            modes = np.r_[lam, refine_roots(model, lam)]
        except np.linalg.LinAlgError:
            modes = lam
    parts = [np.geomspace(band.f_min_hz, band.f_max_hz, log_points)]
    theta = np.linspace(-np.pi / 2, np.pi / 2, per_mode + 2)[1:-1]
    for pole in modes[np.isfinite(modes) & (modes.imag > 0)]:
        f_d, b = pole.imag / (2 * np.pi), max(-pole.real / (2 * np.pi), 1e-9 * abs(pole) / (2 * np.pi))
        parts.append(f_d + b * np.tan(theta))
    f = np.concatenate(parts)
    return np.unique(f[(f >= band.f_min_hz) & (f <= band.f_max_hz)])
