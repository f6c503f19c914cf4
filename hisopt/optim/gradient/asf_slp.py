"""The refinement's NLP solved for every start design at once: trust-region SLP on the evaluator.

``hisopt refine``'s default (``--method slp``); :mod:`hisopt.optim.gradient.refine` keeps the
CasADi/IPOPT solve of the same NLP as ``--method ipopt``. Every start design moves together,
as one batch of the vectorised evaluator per iteration and one sparse linear programme
(HiGHS, through scipy) holding every design's subproblem, so a design costs some hundred
evaluations (about 0.05 s), not an NLP built and solved on its own.

The NLP is the one of :mod:`hisopt.optim.gradient.refine`: in scaled variables ``u`` (the box
is [0, 1]) with gaps ``a_i(u) = w_i (log10 f_i(u) - r_i)`` against the start design's
recorded objectives ``r``, minimise the merit ``max_i a_i + rho sum_i a_i`` subject to the
problem's constraints and the box; a result counts only where every gap is at most 0 (it
weakly dominates the start). One iteration of an SLP start:

1. **Jacobian** of the gaps and of the normalised constraints (``value / limit - 1``) by
   forward differences, one evaluation per variable, stepping into the box.
2. **Step** from the linear programme: minimise ``s + rho sum_i (a_i + g_i . d)`` subject to
   ``a_i + g_i . d <= s`` (the ASF epigraph), ``c_j + h_j . d <= 0`` for every constraint,
   ``|d|_inf <= Delta`` and the box.
3. **Trust region**: the step is evaluated; it is taken if the design stays valid and
   feasible and the merit falls by at least a tenth of what the linear model promised.
   ``Delta`` doubles after a full step that delivered at least 3/4 of the promise and becomes
   a quarter of the step's length after a rejected one. The best design met whose gaps are
   all at most 0 is the start's result.

Like IPOPT, the path may leave the dominating set (a start is often not connected to the
designs that dominate it: a short run's front misses whole regions); unlike IPOPT's
restoration phase, several starts per design search for them (:func:`refine_designs`), one of
them kept inside the set for the small gains near the front.

A start stops when the model promises the merit a fall below ``min_gain``, ``Delta`` falls
below ``min_radius`` or after ``iterations``. Every result is judged by the evaluator's own
values; the linear model only proposes.

Forward-difference step: a band maximum is located off the frequency grid by a bracketing
search, so its value carries an error of about 1e-7 of itself (measured on the chamber
problem: gradients at steps of 1e-6 and 1e-5 differ by up to 0.2 where they are about 1), far
above the evaluator's rounding. A step ``h`` then errs by about 1e-7 / ``h`` from that noise
and by ``h`` times the curvature from truncation; ``fd_step`` = 1e-4 balances the two (errors
near 1e-3 of a gradient), and a wrong proposal costs only a rejected step.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from hisopt.errors import ConfigError

if TYPE_CHECKING:
    from hisopt.problem import Problem


@dataclass(frozen=True)
class SlpSettings:
    """Settings of the batched trust-region SLP (module docstring).

    Attributes
    ----------
    iterations : int
        [-] most iterations per design
    radius : float
        [-] first trust-region radius, infinity norm in scaled design units (box = [0, 1])
    min_radius : float
        [-] a design stops once its radius falls below this
    min_gain : float
        [-] a design stops once the linear model promises its merit a smaller fall
    fd_step : float
        [-] forward-difference step in scaled design units
    rho : float
        [-] merit augmentation: weight of the summed gaps beside the worst one
    starts : int
        [-] SLP starts per design, at least 2: the design itself kept dominating, the design
        itself free, and ``starts - 2`` others drawn around it (:func:`start_points`)
    start_spread : float
        [-] half-width of the box the other starts are drawn from, scaled design units
    chunk : int
        [-] designs refined together (one evaluator batch and one linear programme per
        iteration); a fixed size, so the result never depends on how many workers share them
    correction : bool
        [-] a step that breaks a constraint the linear model kept is corrected back onto it
        (:func:`corrected_steps`) and evaluated again, so that a design can slide along a
        curved constraint that binds (the epsilon-constraint NLP's handling limit)

    Notes
    -----
    The defaults were chosen on the paper's problem (40 designs of an NSGA-II 40 x 40 front
    and of an NSGA-III 100 x 50 one): 4 starts, 25 iterations and a spread of 0.5 gained
    +8.4 % and +3.9 % hypervolume at 0.05-0.09 s per design; 40 iterations cost 40 % more
    for under 0.2 % more; a spread of 0.35 or 0.75 gained less (docs/refine.md).
    """

    iterations: int = 25
    radius: float = 0.5
    min_radius: float = 1e-4
    min_gain: float = 1e-7
    fd_step: float = 1e-4
    rho: float = 0.05
    starts: int = 4
    start_spread: float = 0.5
    chunk: int = 25
    correction: bool = False

    def __post_init__(self) -> None:
        if self.starts < 2 or self.chunk < 1 or self.iterations < 0:
            raise ConfigError(
                f"expected SlpSettings with starts >= 2, chunk >= 1 and iterations >= 0, got starts={self.starts}, "
                f"chunk={self.chunk}, iterations={self.iterations}"
            )


@dataclass(frozen=True)
class SlpResult:
    """Where each start design ended.

    Attributes
    ----------
    x : np.ndarray
        [variable units] final designs (the start where no step was taken), ``(n, n_var)``
    quantities : dict[str, np.ndarray]
        [physical units] the evaluator's output at ``x``, each ``(n,)``
    merit : np.ndarray
        [-] final merit against the start's recorded objectives (0 where no step was taken;
        lower is better), ``(n,)``
    asf : np.ndarray
        [-] worst weighted log10 change of an objective against the start's recorded
        objectives (0 where no step was taken, else < 0), ``(n,)``
    steps : np.ndarray
        [-] steps taken per design, ``(n,)``
    iterations : np.ndarray
        [-] linear programmes solved per design, ``(n,)``
    evaluations : int
        [-] designs evaluated in all
    status : list[str]
        [-] why each design stopped: ``converged`` (the model promises the merit a fall below
        ``min_gain``), ``radius`` (below ``min_radius``), ``iterations``, ``start`` (the
        evaluator finds the start invalid or infeasible) or, from :func:`refine_designs`,
        ``none dominating`` (no start found a design dominating the recorded one)
    """

    x: np.ndarray
    quantities: dict[str, np.ndarray]
    merit: np.ndarray
    asf: np.ndarray
    steps: np.ndarray
    iterations: np.ndarray
    evaluations: int
    status: list[str]


def asf_merit(gap: np.ndarray, rho: float | np.ndarray) -> np.ndarray:
    """[-] The refinement NLP's objective at designs whose gaps are ``gap`` (``(..., k)``):
    ``max_i a_i + rho sum_i a_i``, the augmented achievement scalarising function (both
    methods judge designs by it)."""
    return np.max(gap, axis=-1) + rho * np.sum(gap, axis=-1)


def lp_steps(
    gap: np.ndarray,
    jac: np.ndarray,
    con: np.ndarray,
    con_jac: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    rho: np.ndarray,
    s_cap: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """[-] The linear programme's step ``d`` and its predicted merit for every design at once.

    One sparse LP (HiGHS) whose blocks are the designs' subproblems (module docstring, step 2).

    Parameters
    ----------
    gap : np.ndarray
        [-] ``(n, k)`` current gaps ``a``
    jac : np.ndarray
        [-] ``(n, k, m)`` their gradients
    con : np.ndarray
        [-] ``(n, c)`` normalised constraints (met when <= 0)
    con_jac : np.ndarray
        [-] ``(n, c, m)`` their gradients
    low, high : np.ndarray
        [-] ``(n, m)`` bounds of the step (trust region within the box)
    rho : np.ndarray
        [-] ``(n,)`` merit augmentation of each design's programme
    s_cap : np.ndarray
        [-] ``(n,)`` upper bound of each design's epigraph level ``s`` (``inf``: none)

    Returns
    -------
    tuple[np.ndarray, np.ndarray]
        ``d`` ``(n, m)`` and the predicted merit ``s + rho sum_i (a_i + g_i . d)`` ``(n,)``

    Raises
    ------
    RuntimeError
        HiGHS fails on a programme that ``d = 0`` always satisfies (not expected).
    """
    from scipy.optimize import linprog
    from scipy.sparse import coo_matrix

    n, k, m = jac.shape
    c_count = con.shape[1]
    width = m + 1  # d, then s
    # Objective: rho * sum_i g_i . d + s (constants dropped).
    cost = np.concatenate([rho[:, None] * jac.sum(axis=1), np.ones((n, 1))], axis=1).ravel()
    # Rows per design: k epigraph rows [g_i, -1] <= -a_i, then c constraint rows [h_j, 0] <= -c_j.
    rows_per = k + c_count
    block = np.zeros((n, rows_per, width))
    block[:, :k, :m] = jac
    block[:, :k, m] = -1.0
    block[:, k:, :m] = con_jac
    row = (np.arange(n)[:, None, None] * rows_per + np.arange(rows_per)[None, :, None]) + np.zeros((1, 1, width), dtype=int)
    col = (np.arange(n)[:, None, None] * width + np.arange(width)[None, None, :]) + np.zeros((1, rows_per, 1), dtype=int)
    a_ub = coo_matrix((block.ravel(), (row.ravel(), col.ravel())), shape=(n * rows_per, n * width)).tocsr()
    b_ub = np.concatenate([-gap, -con], axis=1).ravel()
    bounds_low = np.concatenate([low, np.full((n, 1), -np.inf)], axis=1).ravel()
    bounds_high = np.concatenate([high, s_cap[:, None]], axis=1).ravel()
    solution = linprog(cost, A_ub=a_ub, b_ub=b_ub, bounds=np.column_stack([bounds_low, bounds_high]), method="highs")
    if solution.status != 0:
        raise RuntimeError(f"the refinement's linear programme failed: {solution.message}")
    z = solution.x.reshape(n, width)
    d = z[:, :m]
    predicted = z[:, m] + rho * np.sum(gap + np.einsum("nkm,nm->nk", jac, d), axis=1)
    predicted = np.minimum(predicted, np.max(gap, axis=1) + rho * np.sum(gap, axis=1))  # d = 0 is always there
    return d, predicted


def solve_slp(
    problem: Problem,
    x0: np.ndarray,
    f0: np.ndarray,
    weights: np.ndarray,
    settings: SlpSettings | None = None,
    monotone: np.ndarray | None = None,
) -> SlpResult:
    """Refine every start design at once by trust-region SLP (module docstring).

    Parameters
    ----------
    problem : Problem
        the problem the designs belong to
    x0 : np.ndarray
        [variable units] start designs inside the box, ``(n, n_var)``
    f0 : np.ndarray
        [objective units] their objectives as the front records them, ``(n, n_obj)``
    weights : np.ndarray
        [1/decade] ASF weight of each objective's log10, ``(n_obj,)``
    settings : SlpSettings | None, optional
        trust-region and stopping settings (default :class:`SlpSettings`)
    monotone : np.ndarray | None, optional
        [-] ``(n,)`` starts that keep to the designs dominating theirs (default none): their
        programme minimises the worst gap alone (``rho`` = 0) and may not raise it, and a
        step is taken only if every gap stays at most 0. They find the small improvements
        of a design near the front, where the others trade objectives away from it.
    """
    from hisopt.optim.decision import log_objectives
    from hisopt.optim.pymoo_problem import HisoptPymooProblem

    settings = settings or SlpSettings()
    adapter, evaluate = HisoptPymooProblem(problem), problem.evaluator()
    lower, span = problem.lower, problem.upper - problem.lower
    x0 = np.atleast_2d(np.asarray(x0, dtype=float))
    n, m = x0.shape
    ref = weights * log_objectives(np.atleast_2d(np.asarray(f0, dtype=float)))
    count = [0]

    def at(x: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """Gaps against the starts ``rows``, normalised constraints, validity and the output."""
        count[0] += len(x)
        q = evaluate(x)
        f, g = adapter.f_and_g(q)
        valid = np.isfinite(f).all(axis=1) & (g[:, -1] <= 0.0)
        gap = np.where(valid[:, None], weights * log_objectives(np.where(valid[:, None], f, 1.0)) - ref[rows], np.inf)
        return gap, g[:, :-1], valid, q

    def merit(gap: np.ndarray, rho: float | np.ndarray = settings.rho) -> np.ndarray:
        return asf_merit(gap, rho)

    fixed = np.isin(np.arange(m), list(problem.choices))
    every = np.arange(n)
    gap, con, valid, q = at(x0, every)
    gap_start = gap.copy()
    quantities = {key: np.array(value, copy=True) for key, value in q.items()}
    u = np.clip((x0 - lower) / span, 0.0, 1.0)
    active = valid & np.all(con <= 0.0, axis=1)
    dominating = active & np.all(gap <= 0.0, axis=1)
    monotone = np.zeros(n, dtype=bool) if monotone is None else np.asarray(monotone, dtype=bool) & dominating
    path_rho = np.where(monotone, 0.0, settings.rho)  # the merit each start's path descends
    current = merit(gap, path_rho)
    # the result is judged by the full merit whatever merit the path descends
    best_u, best_gap, best = u.copy(), gap.copy(), np.where(dominating, merit(gap), np.inf)
    status = np.array(["iterations"] * n, dtype=object)
    status[~active] = "start"
    radius = np.full(n, settings.radius)
    steps, solved = np.zeros(n, dtype=int), np.zeros(n, dtype=int)
    h = settings.fd_step
    for _ in range(settings.iterations):
        rows = np.flatnonzero(active)
        if rows.size == 0:
            break
        ur = u[rows]
        # 1. forward differences into the box, one variable per evaluation
        sign = np.where(ur + h <= 1.0, 1.0, -1.0)
        probes = np.repeat(ur[:, None, :], m, axis=1)
        probes[:, np.arange(m), np.arange(m)] += sign * h
        gap_p, con_p, valid_p, _ = at((lower + span * probes).reshape(-1, m), np.repeat(rows, m))
        usable = valid_p.reshape(len(rows), m)
        scale = (sign * h)[:, :, None]
        jac = np.where(usable[:, :, None], (gap_p.reshape(len(rows), m, -1) - gap[rows][:, None, :]) / scale, 0.0)
        con_jac = np.where(usable[:, :, None], (con_p.reshape(len(rows), m, -1) - con[rows][:, None, :]) / scale, 0.0)
        # 2. every design's linear programme at once
        low = np.maximum(-radius[rows, None], -ur)
        high = np.minimum(radius[rows, None], 1.0 - ur)
        high[~usable] = low[~usable] = 0.0  # a variable whose probe failed stays where it is
        high[:, fixed] = low[:, fixed] = 0.0  # and a catalogue part stays the design's (docs/model.md §17)
        s_cap = np.where(monotone[rows], np.max(gap[rows], axis=1), np.inf)
        d, predicted = lp_steps(gap[rows], jac.transpose(0, 2, 1), con[rows], con_jac.transpose(0, 2, 1), low, high, path_rho[rows], s_cap)
        solved[rows] += 1
        promise = current[rows] - predicted
        done = promise < settings.min_gain
        status[rows[done]] = "converged"
        active[rows[done]] = False
        rows, ur, d, promise = rows[~done], ur[~done], d[~done], promise[~done]
        if rows.size == 0:
            continue
        # 3. evaluate the steps; keep those that deliver
        trial_u = np.clip(ur + d, 0.0, 1.0)
        gap_t, con_t, valid_t, q_t = at(lower + span * trial_u, rows)
        if settings.correction:
            broken = valid_t & np.any(con_t > 0.0, axis=1)
            if broken.any():
                moved = corrected_steps(trial_u[broken], con_t[broken], con_jac.transpose(0, 2, 1)[~done][broken], low[~done][broken] != high[~done][broken])
                gap_c, con_c, valid_c, q_c = at(lower + span * moved, rows[broken])
                trial_u[broken], gap_t[broken], con_t[broken], valid_t[broken] = moved, gap_c, con_c, valid_c
                q_t = {key: _with_rows(np.asarray(value), broken, np.asarray(q_c[key])) for key, value in q_t.items()}
        fall = current[rows] - merit(gap_t, path_rho[rows])
        good = valid_t & np.all(con_t <= 0.0, axis=1) & (fall >= 0.1 * promise)
        good &= ~monotone[rows] | np.all(gap_t <= 0.0, axis=1)
        taken = rows[good]
        u[taken], gap[taken], con[taken] = trial_u[good], gap_t[good], con_t[good]
        current[taken] = merit(gap_t[good], path_rho[taken])
        steps[taken] += 1
        better = good & np.all(gap_t <= 0.0, axis=1) & (merit(gap_t) < best[rows])
        kept = rows[better]
        best_u[kept], best_gap[kept], best[kept] = trial_u[better], gap_t[better], merit(gap_t[better])
        for key, value in q_t.items():
            quantities[key][kept] = np.asarray(value)[better]
        length = np.max(np.abs(d), axis=1)
        grow = good & (fall >= 0.75 * promise) & (length >= 0.99 * radius[rows])
        radius[rows[grow]] = np.minimum(2.0 * radius[rows[grow]], 1.0)
        radius[rows[~good]] = length[~good] / 4.0
        small = rows[~good][radius[rows[~good]] < settings.min_radius]
        status[small] = "radius"
        active[small] = False
    moved = best < np.where(dominating, merit(gap_start), np.inf)
    return SlpResult(
        x=np.where(moved[:, None], lower + span * best_u, x0),
        quantities=quantities,
        merit=np.where(moved, best, 0.0),
        asf=np.where(moved, np.max(best_gap, axis=1), 0.0),
        steps=steps,
        iterations=solved,
        evaluations=count[0],
        status=[str(s) for s in status],
    )


def _with_rows(values: np.ndarray, rows: np.ndarray, new: np.ndarray) -> np.ndarray:
    """``values`` with its entries at mask ``rows`` replaced by ``new`` (a copy)."""
    out = np.array(values, copy=True)
    out[rows] = new
    return out


def corrected_steps(u: np.ndarray, con: np.ndarray, con_jac: np.ndarray, free: np.ndarray) -> np.ndarray:
    """[-] Second-order correction: trial designs ``u`` ``(n, m)`` moved back across the
    constraints they break (``con > 0``, ``(n, c)``) by the least-norm step of their
    linearisation ``con + con_jac . d = -0.1 con`` (``con_jac`` ``(n, c, m)`` at the step's
    start), over the ``free`` variables ``(n, m)`` only, then clipped onto the box. Aiming a
    tenth beyond the limit leaves room for the curvature the linear model misses.
    """
    out = np.array(u, copy=True)
    for i in range(len(u)):
        broken = con[i] > 0.0
        a = np.where(free[i][None, :], con_jac[i][broken], 0.0)
        step = np.linalg.lstsq(a, -1.1 * con[i][broken], rcond=None)[0]
        out[i] = np.clip(u[i] + step, 0.0, 1.0)
    return out


def start_points(u0: np.ndarray, keys: np.ndarray, settings: SlpSettings) -> np.ndarray:
    """[-] SLP starts ``(n, starts, m)`` in scaled units: each design itself twice (the
    monotone start and the free one of :func:`refine_designs`), then ``starts - 2`` points
    drawn uniformly within ``start_spread`` of it and clipped onto the box (so some sit on its
    faces, where a third to a half of a front lies).

    The NLP's feasible set (designs dominating the start) is often not connected to the start:
    a front from a short run misses whole regions. The other starts reach the pieces nearby,
    as IPOPT's restoration phase does from the one start.

    Parameters
    ----------
    u0 : np.ndarray
        [-] ``(n, m)`` the designs, scaled to the box
    keys : np.ndarray
        [-] ``(n,)`` non-negative integers seeding each design's draws (its front row), so a
        design's starts do not depend on which others are refined with it
    """
    n, m = u0.shape
    out = np.empty((n, settings.starts, m))
    out[:, :2] = u0[:, None, :]
    for i in range(n):  # one generator per design: its draws are its own
        rng = np.random.default_rng([int(keys[i]), 28])
        offsets = settings.start_spread * (2.0 * rng.random((settings.starts - 2, m)) - 1.0)
        out[i, 2:] = np.clip(u0[i] + offsets, 0.0, 1.0)
    return out


def refine_designs(problem: Problem, x0: np.ndarray, f0: np.ndarray, keys: np.ndarray, weights: np.ndarray, settings: SlpSettings | None = None) -> SlpResult:
    """The best design found for each start design over its several SLP starts.

    Runs :func:`solve_slp` from the :func:`start_points` of every design (the first of them
    monotone) and keeps, per design, the dominating result of lowest merit (the design itself
    when none dominates it).

    Parameters
    ----------
    x0 : np.ndarray
        [variable units] start designs inside the box, ``(n, n_var)``
    f0 : np.ndarray
        [objective units] their recorded objectives, ``(n, n_obj)``
    keys : np.ndarray
        [-] ``(n,)`` seeds of the designs' other starts (:func:`start_points`)
    weights, settings
        as :func:`solve_slp`
    """
    settings = settings or SlpSettings()
    lower, span = problem.lower, problem.upper - problem.lower
    x0 = np.atleast_2d(np.asarray(x0, dtype=float))
    n, m = x0.shape
    s = settings.starts
    starts = lower + span * start_points(np.clip((x0 - lower) / span, 0.0, 1.0), keys, settings)
    starts[:, :2] = x0[:, None, :]  # the design itself, exactly: kept dominating, then free
    chosen = list(problem.choices)
    starts[:, :, chosen] = x0[:, None, chosen]  # its catalogue parts in every start
    owner = np.repeat(np.arange(n), s)
    monotone = np.tile(np.arange(s) == 0, n)
    all_runs = solve_slp(problem, starts.reshape(-1, m), np.asarray(f0, dtype=float)[owner], weights, settings, monotone)
    merit = np.where(all_runs.merit < 0.0, all_runs.merit, np.inf).reshape(n, s)
    pick = np.argmin(merit, axis=1)  # ties: the earliest start, the design itself first
    found = np.isfinite(merit[np.arange(n), pick])
    rows = np.arange(n) * s + np.where(found, pick, 0)
    return SlpResult(  # a design's own start keeps its output at x0 unless it found better
        x=np.where(found[:, None], all_runs.x[rows], x0),
        quantities={key: value[rows] for key, value in all_runs.quantities.items()},
        merit=np.where(found, all_runs.merit[rows], 0.0),
        asf=np.where(found, all_runs.asf[rows], 0.0),
        steps=np.where(found, all_runs.steps[rows], 0),
        iterations=all_runs.iterations.reshape(n, s).sum(axis=1),
        evaluations=all_runs.evaluations,
        status=[all_runs.status[r] if f else "none dominating" for r, f in zip(rows, found, strict=True)],
    )
