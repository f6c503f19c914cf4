"""Front quality and decision support in log-scaled objective space.

The paper's objectives span orders of magnitude (PSD maxima near 1e-5, tyre-load PSD near
1e4 to 1e10 N^2/Hz), and a design that halves a PSD is as much better at 1e-5 as at 1e-3.
Every measure here therefore works on ``z = log10(F)`` (objectives are positive magnitudes;
values below 1e-300 are clipped to it):

- **Hypervolume** (pymoo ``HV``, computed by moocore; above :data:`SLAB_MIN_POINTS` points as
  a sum over slabs, :func:`slab_hypervolume`) of ``z`` with respect to a fixed
  reference point, unit decades^n_obj. The reference point depends on the problem only, so
  runs, seeds and methods are comparable (:func:`reference_point`): evaluate a full-factorial
  grid over the design box (``levels`` per variable, ``levels = max(2, floor(1000 **
  (1 / n_var)))``: 5^4 = 625 designs for the paper's problem), keep the feasible designs (all
  valid ones if none is feasible), take their non-dominated set, and add 10 % of its range
  (at least 0.01 decade) to its nadir. Designs beyond the reference point add no volume.
- **Normalisation** for decisions: ``z`` scaled to [0, 1] between the ideal and nadir of the
  front at hand.
- **Knee point** (:func:`knee_index`): the design farthest below the hyperplane through the
  front's extreme designs (each minimising one objective) in normalised space, i.e. the
  minimiser of ``w . z_norm`` with ``w`` the hyperplane's normal (equal weights when the
  extreme designs do not span a hyperplane with positive normal).
- **ASF pick** (:func:`asf_index`): the minimiser of the augmented achievement scalarising
  function ``max_i w_i (z_i - r_i) + rho sum_i w_i (z_i - r_i)`` in normalised space, with
  the reference (aspiration) point ``r`` in physical units (default: the front's ideal point)
  and weights ``w`` (default equal; a larger weight pulls that objective closer to ``r``).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from hisopt.errors import ConfigError, RunError, with_article
from hisopt.optim.archive import non_dominated_mask

if TYPE_CHECKING:
    from hisopt.problem import Problem

LOG_FLOOR = 1e-300
"""[objective units] values are clipped to this before the log."""

REFERENCE_MARGIN = 0.1
"""[-] share of the sample front's log range added to its nadir."""

MIN_MARGIN_DECADES = 0.01
"""[decades] least margin added to the nadir in each objective."""


def log_objectives(f: np.ndarray) -> np.ndarray:
    """[decades] ``log10`` of objectives ``f`` (n, k) (positive magnitudes)."""
    return np.log10(np.maximum(np.asarray(f, dtype=float), LOG_FLOOR))


def grid_designs(lower: np.ndarray, upper: np.ndarray, max_designs: int = 1000) -> np.ndarray:
    """[variable units] Full-factorial grid over the box, ``levels ** n_var`` rows.

    Parameters
    ----------
    lower, upper : np.ndarray
        [variable units] box bounds, shape ``(n_var,)``
    max_designs : int, optional
        [-] ``levels = max(2, floor(max_designs ** (1 / n_var)))``
    """
    n_var = len(lower)
    levels = max(2, int(np.floor(max_designs ** (1.0 / n_var) + 1e-9)))
    axes = [np.linspace(lo, hi, levels) for lo, hi in zip(lower, upper, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, n_var)


def reference_from_sample(f: np.ndarray) -> np.ndarray:
    """[decades] Hypervolume reference point from sample objectives ``f`` (n, k) (module rule)."""
    z = log_objectives(f)
    z = z[non_dominated_mask(z)]
    nadir, ideal = z.max(axis=0), z.min(axis=0)
    return nadir + np.maximum(REFERENCE_MARGIN * (nadir - ideal), MIN_MARGIN_DECADES)


def reference_point(problem: Problem) -> np.ndarray:
    """[decades] The problem's fixed hypervolume reference point in ``log10`` space, ``(n_obj,)``.

    Cached per problem specification (the grid evaluation costs a few hundred evaluations).

    Raises
    ------
    RunError
        No design of the grid sample can be evaluated.
    """
    key = problem.spec.model_dump_json()
    if key not in _REFERENCE_CACHE:
        if len(_REFERENCE_CACHE) >= 16:
            _REFERENCE_CACHE.pop(next(iter(_REFERENCE_CACHE)))
        _REFERENCE_CACHE[key] = _reference_point(problem)
    return _REFERENCE_CACHE[key].copy()


_REFERENCE_CACHE: dict[str, np.ndarray] = {}


def _reference_point(problem: Problem) -> np.ndarray:
    x = grid_designs(problem.lower, problem.upper)
    q = problem.evaluator()(x)
    f = np.column_stack([q[name] for name in problem.objective_names])
    return reference_from_sample(f[grid_sample_rows(problem, q, x)])


def grid_sample_rows(problem: Problem, q: Mapping[str, np.ndarray], x: np.ndarray) -> np.ndarray:
    """[-] The designs ``x`` of a grid over the box (:func:`grid_designs`, quantities ``q``)
    that place a reference: the feasible ones, or the valid ones if none is feasible.

    Raises
    ------
    RunError
        No design of the grid can be evaluated: one line with the commonest reasons
        (:func:`unevaluable_reasons`).
    """
    valid = np.asarray(q["valid"], dtype=bool)
    feasible = valid.copy()
    for c in problem.spec.constraints:
        feasible &= q[c.name] <= c.limit
    chosen = feasible if feasible.any() else valid
    if not chosen.any():
        grid = with_article(f"{len(valid)}-design")
        raise RunError(f"no design of {grid} grid over the box of {problem.name} can be evaluated: {unevaluable_reasons(problem, x, valid)}")
    return chosen


def unevaluable_reasons(problem: Problem, x: np.ndarray, valid: np.ndarray, shown: int = 3) -> str:
    """The ``shown`` commonest reasons why designs ``x`` are not ``valid``, each with its
    count: a rule a design breaks (:func:`hisopt.specification.validation.check_designs`,
    e.g. a rod not thinner than its bore) or the model's NaN results there
    (:func:`hisopt.evaluation.evaluate.failure_reason`)."""
    from hisopt.evaluation.results_frame import failure_reason
    from hisopt.specification.validation import check_designs

    check = check_designs(problem, x)
    failed = failure_reason(problem)
    reasons = Counter(str(check.detail[i]) if not check.evaluable[i] else failed for i in np.flatnonzero(~np.asarray(valid, dtype=bool)))
    top = reasons.most_common(shown)
    more = len(reasons) - len(top)
    tail = f"; and {more} more reason{'s' if more > 1 else ''}" if more else ""
    return "; ".join(f"{reason} ({count} design{'s' if count > 1 else ''})" for reason, count in top) + tail


def hypervolume(f: np.ndarray, reference_log: np.ndarray) -> float:
    """[decades^k] Hypervolume of objectives ``f`` (n, k) in ``log10`` space.

    Parameters
    ----------
    f : np.ndarray
        [objective units] objective vectors (any set; dominated ones add nothing)
    reference_log : np.ndarray
        [decades] reference point from :func:`reference_point`, ``(k,)``
    """
    if len(f) == 0:
        return 0.0
    from pymoo.indicators.hv import HV

    z = log_objectives(f)
    inside = np.all(z < reference_log, axis=1)
    if not inside.any():
        return 0.0
    if inside.sum() > SLAB_MIN_POINTS and z.shape[1] >= 3:
        return slab_hypervolume(z[inside], np.asarray(reference_log, dtype=float))
    return float(HV(ref_point=np.asarray(reference_log, dtype=float))(z[inside]))


SLAB_MIN_POINTS = 8192
"""[-] Above this many points :func:`hypervolume` sums slabs (:func:`slab_hypervolume`)."""


def slab_hypervolume(z: np.ndarray, reference: np.ndarray, slabs: int | None = None) -> float:
    """[units of z ^ k] Exact hypervolume of ``z`` (n, k >= 2), minimisation, as a sum over slabs
    of the first coordinate.

    Between cuts ``a < b`` of the first coordinate the dominated region's cross-section is
    that of the points with ``z_0 < b``; the points with ``z_0 < a`` enter it only through
    their projection on the other coordinates, of which only the non-dominated ones matter.
    Each slab is then moocore's hypervolume of its own points plus that projected front placed
    at ``z_0 = a``, with reference ``(b, r_1, ...)``. The projected front of a
    ``k``-objective front is much smaller than the front, so the slabs together cost far less
    than moocore's ``O(n^2)`` (4-D) on all points at once: about 8x less at 80,000 points.
    The same volume, up to rounding in the sum (relative ``~1e-15``).

    Parameters
    ----------
    z : np.ndarray
        [units of z] points, shape ``(n, k)``, each below ``reference`` in every coordinate
    reference : np.ndarray
        [units of z] reference point, ``(k,)``
    slabs : int or None
        [-] number of slabs (default about ``sqrt(n) / 6``, at most 64)
    """
    import moocore

    z = np.asarray(z, dtype=float)
    n, k = z.shape
    if n == 0:
        return 0.0
    if slabs is None:
        slabs = int(np.clip(round(np.sqrt(n) / 6.0), 1, 64))
    z = z[np.argsort(z[:, 0], kind="stable")]
    cuts = np.unique(z[np.linspace(0, n, slabs + 1, dtype=int)[1:-1], 0])
    edges = np.r_[z[0, 0], cuts[cuts > z[0, 0]], reference[0]]
    total = 0.0
    below = np.empty((0, k - 1))  # non-dominated projection of the points left of the slab
    start = 0
    for s in range(len(edges) - 1):
        a, b = edges[s], edges[s + 1]
        end = int(np.searchsorted(z[:, 0], b, side="left")) if s < len(edges) - 2 else n
        inside = z[start:end]
        pts = np.vstack([np.column_stack([np.full(len(below), a), below]), inside])
        ref = reference.copy()
        ref[0] = b
        total += float(moocore.hypervolume(pts, ref=ref))
        if len(inside):
            cand = np.vstack([below, inside[:, 1:]])
            below = cand[moocore.is_nondominated(cand, keep_weakly=False)]
        start = end
    return total


def normalised_log(f: np.ndarray, reference: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """Front ``f`` (n, k) and an optional point ``reference`` (k,) in normalised log space.

    ``0`` is the front's ideal and ``1`` its nadir in each objective (objectives with no
    spread map to 0).
    """
    z = log_objectives(f)
    ideal, span = log_scale(f)
    ref = None if reference is None else (log_objectives(np.asarray(reference, dtype=float)[None])[0] - ideal) / span
    return (z - ideal) / span, ref


def log_scale(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """[decades] ``(ideal, span)`` (k,) of the normalised log space of front ``f`` (n, k):
    a point ``t`` there is ``10 ** (ideal + t span)`` in objective units (an objective with
    no spread has span 1)."""
    z = log_objectives(f)
    ideal, nadir = z.min(axis=0), z.max(axis=0)
    return ideal, np.where(nadir > ideal, nadir - ideal, 1.0)


def knee_index(f: np.ndarray) -> int:
    """[-] Row of the knee design of front ``f`` (n, k) (module rule).

    Raises
    ------
    ValueError
        The front is empty.
    """
    if len(f) == 0:
        raise ValueError("the front is empty: no feasible design was found")
    z, _ = normalised_log(f)
    k = z.shape[1]
    w = np.ones(k)
    if k > 1 and len(z) >= k:
        extremes = z[np.argmin(z, axis=0)]
        try:
            normal = np.linalg.solve(extremes, np.ones(k))
        except np.linalg.LinAlgError:
            normal = None
        if normal is not None and np.all(np.isfinite(normal)) and np.all(normal > 0):
            w = normal
    return int(np.argmin(z @ w))


def asf_index(
    f: np.ndarray,
    reference: np.ndarray | None = None,
    weights: np.ndarray | None = None,
    rho: float = 1e-6,
) -> int:
    """[-] Row of front ``f`` (n, k) minimising the augmented ASF (module rule).

    Parameters
    ----------
    f : np.ndarray
        [objective units] front, shape ``(n, k)``
    reference : np.ndarray | None, optional
        [objective units] aspiration point, shape ``(k,)``; default the front's ideal
    weights : np.ndarray | None, optional
        [-] positive weights, shape ``(k,)``; default all 1
    rho : float, optional
        [-] augmentation factor (keeps the pick Pareto-optimal, not weakly)

    Raises
    ------
    ConfigError
        A reference value is not positive or a weight is not positive and finite.
    """
    if len(f) == 0:
        raise ValueError("the front is empty: no feasible design was found")
    k = np.shape(f)[1]
    w = np.ones(k) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != (k,) or not np.all(np.isfinite(w) & (w > 0)):
        raise ConfigError(f"expected {k} positive ASF weights, got {np.asarray(weights).tolist()}")
    if reference is not None:
        reference = np.asarray(reference, dtype=float)
        if reference.shape != (k,) or not np.all(np.isfinite(reference) & (reference > 0)):
            raise ConfigError(f"expected an ASF reference point of {k} positive objective values, got {reference.tolist()}")
    z, r = normalised_log(f, reference)
    d = w * (z - (np.zeros(k) if r is None else r))
    return int(np.argmin(d.max(axis=1) + rho * d.sum(axis=1)))


def front_design(problem: Any, path: Path, design: int | None = None) -> tuple[int, np.ndarray]:
    """``(row, design [SI])`` of the front file ``path`` (a run's ``front.csv``) of ``problem``:
    row ``design`` (from 0), or the front's knee (:func:`knee_index`) when None.

    Raises
    ------
    RunError
        The file is missing, lacks a variable or objective column, is empty, or has no such
        row (the message says which rows it has).
    """
    from hisopt.io import read_csv

    path = Path(path)
    if not path.is_file():
        raise RunError(f"{path}: missing; expected a run directory with a front (hisopt optimize --out DIR)")
    front = read_csv(path)
    missing = [n for n in (*problem.variable_names, *problem.objective_names) if n not in front.columns]
    if missing:
        raise RunError(f"{path}: no column {missing[0]!r}; expected a front of this problem's variables and objectives")
    if front.empty:
        raise RunError(f"{path}: the front is empty; expected at least one feasible design")
    if design is None:
        design = knee_index(front[list(problem.objective_names)].to_numpy(dtype=float))
    elif not 0 <= design < len(front):
        raise RunError(f"--design {design}: not in the run; {path} has designs 0 to {len(front) - 1} (its rows, from 0)")
    return design, front.iloc[design][list(problem.variable_names)].to_numpy(dtype=float)
