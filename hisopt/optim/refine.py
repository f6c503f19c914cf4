"""Gradient refinement of a Pareto front with CasADi and IPOPT.

An evolutionary front (NSGA, :mod:`hisopt.optim.run`) is close to the Pareto front but not on
it. From each of up to ``max_points`` designs spread evenly over the front, an
achievement-scalarising NLP moves the design towards the Pareto front with exact gradients
(:mod:`hisopt.optim.casadi_model`); the standard evaluator then decides what to keep.

The NLP of one start design (reference ``r`` = the start's objectives; ``z = log10`` of the
objectives; ``w`` = 1 / the front's log10 range per objective, so every objective counts in
units of the front's spread; decision variables ``u`` = the design scaled to [0, 1] over its
bounds, the ASF level ``s`` and a log10 epigraph level ``t_j`` per band-maximum quantity)::

    minimise    s + rho * sum_i w_i (z_i(u) - r_i)
    subject to  w_i (z_i(u) - r_i) <= s                  every objective i   (ASF epigraph)
                w_i (z_i(u) - r_i) <= -m_i               every objective i   (none worse)
                log10 S_j(f_k; u) <= t_j                 maxima j, their nodes k
                z_c(u) <= log10(limit_c)                 every problem constraint c
                max(0, u_c - Delta) <= u <= min(1, u_c + Delta)

``z`` of a band maximum is its level ``t_j``; integrals (``sigma_aw``, ``rms_*``) are sums
over Gauss-Legendre nodes. The nodes are the evaluator's pole-aware nodes at the current
design ``u_c`` (:meth:`hisopt.evaluate.Evaluator.nodes`), fixed during a solve, plus a
cluster around every local PSD peak within ``peak_share`` of a maximum (offsets
``cluster_offsets`` in half-power half-widths of the nearest mode; the continuous peak itself
is a node, so the model equals the evaluator at ``u_c``). A maximum's epigraph uses its
clusters and the nodes where the PSD is at least ``node_share`` of the maximum. The margins
``m`` start tiny (IPOPT's tolerance) and grow when the evaluator finds an objective worse
than the model promised.

Trust region: the NLP is solved in rounds. Each solution is re-evaluated with the standard
evaluator (continuous maxima, its own nodes); if it weakly dominates the start and lowers the
NLP's objective it becomes the new centre ``u_c`` (nodes rebuilt there), otherwise ``Delta``
shrinks. A refined design is kept only if, re-evaluated, it weakly dominates its start and
is strictly better in at least one objective (in fact the rounds demand a lower ASF merit).

Starting points: the best design in each objective, then farthest-point sampling in the
front's normalised log10 objective space (deterministic).

Output: the refined front, i.e. the kept refined designs plus every original design none of
them dominates, with the columns of ``front.csv`` plus ``source_index`` (the ``front.csv``
row a design started from; an unrefined design's own row). Hypervolumes are those of
:func:`hisopt.optim.decision.hypervolume` (log10 objectives, the problem's fixed reference
point, or the one a run directory recorded).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.errors import ConfigError, RunError
from hisopt.metrics import METRICS
from hisopt.optim.archive import non_dominated_mask
from hisopt.optim.rundir import FRONT_REFINED_CSV, REFINE_JSON

if TYPE_CHECKING:
    from hisopt.optim.casadi_model import CasadiModel, FrequencySet
    from hisopt.parallel import Backend
    from hisopt.problem import Problem



# --- settings and results --------------------------------------------------------------------
@dataclass(frozen=True)
class RefineSettings:
    """Settings of the refinement (module docstring).

    Attributes
    ----------
    trust_radius : [-] initial trust-region radius in scaled design units (bounds = [0, 1])
    min_radius : [-] stop once the radius falls below this
    rounds : [-] most NLP solves per start design
    rho : [-] ASF augmentation: weight of the summed improvement beside the worst one
    margin : [-] initial least improvement demanded of every objective (weighted log10)
    min_gain : [-] stop once a round lowers the merit by less than this
    peak_share : [-] local PSD peaks at least this share of the maximum get a node cluster
    node_share : [-] a maximum's epigraph also uses nodes with PSD at least this share of it
    cluster_offsets : [-] cluster nodes each side of a peak, in half-power half-widths
    max_iter : [-] IPOPT iterations per solve
    tol : [-] IPOPT convergence tolerance
    """

    trust_radius: float = 0.5
    min_radius: float = 0.01
    rounds: int = 3
    rho: float = 0.05
    margin: float = 1e-7
    min_gain: float = 1e-5
    peak_share: float = 0.1
    node_share: float = 0.3
    cluster_offsets: tuple[float, ...] = (0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0, 1.4, 2.0)
    max_iter: int = 50
    tol: float = 1e-6


@dataclass(frozen=True)
class PointResult:
    """Outcome of refining one front design.

    Attributes
    ----------
    source_index : [-] row of the front the refinement started from
    x : [variable units] final design (the start when nothing better was found), ``(n_var,)``
    quantities : [physical units] the final design's objectives and constraints (evaluator)
    accepted : [-] the final design weakly dominates the start and is better somewhere
    asf : [-] worst weighted log10 change of an objective against the start (<= 0)
    merit : [-] the NLP objective of the final design (0 for the start)
    rounds : [-] NLP solves performed
    iterations : [-] IPOPT iterations over all rounds
    seconds : [s] wall time of this point
    status : [-] IPOPT return status of the last solve
    """

    source_index: int
    x: np.ndarray
    quantities: dict[str, float]
    accepted: bool
    asf: float
    merit: float
    rounds: int
    iterations: int
    seconds: float
    status: str


@dataclass
class RefineResult:
    """Refined front and per-point records.

    Attributes
    ----------
    front : [physical units] the refined front (module docstring)
    points : one row per start design: ``source_index``, ``accepted``, ``asf``, ``merit``,
        ``rounds``, ``iterations``, ``seconds``, ``status``, the final variables and quantities
    hypervolume_before, hypervolume_after : [decades^n_obj] of the input and refined fronts
    reference_point : [decades] hypervolume reference point (log10 of the objectives)
    wall_time_s : [s] wall time of the whole refinement (worker start-up included)
    """

    front: pd.DataFrame
    points: pd.DataFrame
    hypervolume_before: float
    hypervolume_after: float
    reference_point: np.ndarray
    wall_time_s: float

    @property
    def hypervolume_gain(self) -> float:
        """[-] Relative hypervolume gain ``after / before - 1``."""
        if self.hypervolume_before <= 0:
            return 0.0 if self.hypervolume_after <= 0 else np.inf
        return self.hypervolume_after / self.hypervolume_before - 1.0

    @property
    def seconds_per_point(self) -> float:
        """[s] Wall time per start design."""
        return self.wall_time_s / max(len(self.points), 1)

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary (what ``refine.json`` holds besides the settings)."""
        return {
            "points": int(len(self.points)),
            "accepted": int(self.points["accepted"].sum()) if len(self.points) else 0,
            "front_size": int(len(self.front)),
            "hypervolume_before": self.hypervolume_before,
            "hypervolume_after": self.hypervolume_after,
            "hypervolume_gain": self.hypervolume_gain,
            "hypervolume_reference_log10": self.reference_point.tolist(),
            "wall_time_s": self.wall_time_s,
            "seconds_per_point": self.seconds_per_point,
        }


# --- choosing the starting points ------------------------------------------------------------
def select_points(f: np.ndarray, max_points: int) -> np.ndarray:
    """[-] Rows of front ``f`` (n, k) spread evenly over it, at most ``max_points``, sorted.

    The best design in each objective first, then repeatedly the design farthest (Euclidean,
    normalised log10 objectives) from those chosen.

    Raises
    ------
    ConfigError
        ``max_points`` is below 1.
    """
    from hisopt.optim.decision import normalised_log

    if max_points < 1:
        raise ConfigError(f"expected at least 1 point to refine, got {max_points}", key="--max-points")
    n = len(f)
    if n <= max_points:
        return np.arange(n)
    z, _ = normalised_log(f)
    chosen = list(dict.fromkeys(int(i) for i in np.argmin(z, axis=0)))[:max_points]
    dist = np.min(np.linalg.norm(z[:, None, :] - z[None, chosen, :], axis=2), axis=1)
    while len(chosen) < max_points:
        i = int(np.argmax(dist))
        chosen.append(i)
        dist = np.minimum(dist, np.linalg.norm(z - z[i], axis=1))
    return np.sort(np.array(chosen))


def asf_weights(f: np.ndarray) -> np.ndarray:
    """[1/decade] ASF weights: reciprocal log10 range of each objective over the front ``f``.

    An objective with no spread gets the largest other weight (1 when none spreads).
    """
    from hisopt.optim.decision import log_objectives

    z = log_objectives(f)
    span = z.max(axis=0) - z.min(axis=0)
    spread = span > 0
    w = np.where(spread, 1.0 / np.where(spread, span, 1.0), 0.0)
    return np.where(spread, w, w.max() if spread.any() else 1.0)


# --- frequency nodes -------------------------------------------------------------------------
@dataclass(frozen=True)
class NodePlan:
    """Frequency nodes of one NLP.

    Attributes
    ----------
    fs : the frequency set (quadrature weights, per-node parameters)
    max_nodes : node indices of each band-maximum quantity's epigraph
    """

    fs: FrequencySet
    max_nodes: dict[str, np.ndarray]


def peak_location(frf: Any, ev: Any, output: int, lo_hz: float, hi_hz: float, steps: int = 12, points: int = 9) -> float:
    """[Hz] Location of the PSD maximum of ``output`` in ``[lo_hz, hi_hz]``, from ``points``
    samples refined by :func:`hisopt.peaks.refine_maximum` (``steps`` new samples).

    Parameters
    ----------
    frf : output FRF function of one design, as :class:`hisopt.evaluate.DirectOutputs`
    ev : the problem's evaluator (for its road spectra)
    """
    from hisopt.peaks import refine_maximum

    def values_at(pts: np.ndarray) -> np.ndarray:
        return ev.spectra(pts, frf(2 * np.pi * pts, output))[..., 0]

    f = np.linspace(lo_hz, hi_hz, points)[None, :]
    return float(refine_maximum(values_at, f, values_at(f), steps)[0][0])


def node_plan(problem: Problem, model: CasadiModel, x: np.ndarray, settings: RefineSettings) -> NodePlan:
    """Nodes of the NLP at design ``x`` [variable units], ``(n_var,)`` (module docstring)."""
    from hisopt.evaluate import DirectOutputs, Evaluator, poles

    ev = problem.evaluator()
    assert isinstance(ev, Evaluator), "a node plan is of a single-case problem (a scenario's)"
    coupled = problem.model(np.asarray(x, dtype=float)[None, :])
    lam = poles(coupled)
    frf = DirectOutputs(coupled, ev.outputs)
    f, w = ev.nodes(lam, coupled)
    f, inverse = np.unique(f[0], return_inverse=True)  # padding repeats the band limit
    w = np.bincount(inverse, weights=w[0], minlength=f.size)
    psd = ev.spectra(f[None], frf(2 * np.pi * f[None]))[0]
    upper = lam[0][lam[0].imag > 0]  # one of each conjugate pair
    offsets = np.array(settings.cluster_offsets)
    offsets = np.r_[-offsets[::-1], 0.0, offsets]
    clusters: dict[str, list[np.ndarray]] = {}
    for m in model.metrics:
        if m.kind != "max":
            continue
        j = model.output_index[m.signal]
        y = psd[:, j]
        is_peak = np.r_[y[0] > y[1], (y[1:-1] >= y[:-2]) & (y[1:-1] >= y[2:]), y[-1] > y[-2]]
        clusters[m.name] = []
        for k in (int(i) for i in np.flatnonzero(is_peak & (y >= settings.peak_share * y.max()))):
            f_pk = peak_location(frf, ev, j, f[max(k - 1, 0)], f[min(k + 1, f.size - 1)])
            nearest = upper[np.argmin(np.abs(upper.imag / (2 * np.pi) - f_pk))] if upper.size else 0j
            half_width = max(abs(nearest.real) / (2 * np.pi), 1e-3 * f_pk)
            c = f_pk + half_width * offsets
            clusters[m.name].append(c[(c >= ev.f_lo) & (c <= ev.f_hi)])
    extra = [c for cs in clusters.values() for c in cs]
    f_all, inverse = np.unique(np.concatenate([f, *extra]), return_inverse=True)
    w_all = np.bincount(inverse[: f.size], weights=w, minlength=f_all.size)
    psd_all = ev.spectra(f_all[None], frf(2 * np.pi * f_all[None]))[0]
    max_nodes = {}
    for name, cs in clusters.items():
        y = psd_all[:, model.output_index[METRICS[name].signal]]
        in_cluster = np.isin(f_all, np.concatenate(cs)) if cs else np.zeros(f_all.size, dtype=bool)
        max_nodes[name] = np.flatnonzero(in_cluster | (y >= settings.node_share * y.max()))
    return NodePlan(model.frequency_set(f_all, w_all), max_nodes)


# --- the NLP ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class SolveOutcome:
    """One NLP solve.

    Attributes
    ----------
    u : [-] scaled design found, ``(n_var,)``
    status : [-] IPOPT return status
    iterations : [-] IPOPT iterations
    gap : [-] the model's weighted log10 change of each objective against the reference
    """

    u: np.ndarray
    status: str
    iterations: int
    gap: np.ndarray


@dataclass(frozen=True)
class Part:
    """One load case of the NLP: its single-case problem, CasADi model and nodes (the problem
    itself, scenario ``None``, for a problem without ``[[scenarios]]``)."""

    scenario: str | None
    problem: Problem
    model: CasadiModel
    plan: NodePlan | None = None


def solve_asf(
    problem: Problem,
    parts: list[Part],
    u_c: np.ndarray,
    ref_log: np.ndarray,
    weights: np.ndarray,
    radius: float,
    settings: RefineSettings,
    margin: np.ndarray,
) -> SolveOutcome:
    """One ASF solve around the scaled design ``u_c`` (module docstring).

    Parameters
    ----------
    parts : the load cases with their nodes at ``u_c`` (one for a single-case problem)
    u_c : [-] current design scaled to [0, 1] over the bounds, ``(n_var,)``
    ref_log : [decades] reference point, ``log10`` of the start's objectives, ``(n_obj,)``
    weights : [1/decade] ASF weights, ``(n_obj,)``
    radius : [-] trust-region radius in scaled units
    margin : [-] least weighted log10 improvement demanded of each objective, ``(n_obj,)``
    """
    import casadi as ca

    from hisopt.optim.casadi_model import SpectraCallback
    from hisopt.optim.transient_callback import TransientCallback

    lower, upper = problem.lower, problem.upper
    n_var = lower.size
    objectives = problem.objective_names

    def log10(e: Any) -> Any:
        return ca.log(e) / np.log(10.0)

    # ---- decision variables -------------------------------------------------------------------
    u = ca.MX.sym("u", n_var)  # design scaled to [0, 1] over its bounds
    s = ca.MX.sym("s")  # ASF level
    x = ca.DM(lower) + ca.DM(upper - lower) * u
    levels: list[Any] = []  # log10 epigraph level of each band maximum in each part
    g: list[Any] = []

    # ---- each load case's model on its fixed nodes ----------------------------------------------
    z_of: list[dict[str, Any]] = []
    callbacks: list[Any] = []  # CasADi keeps no reference to a Python callback: these must outlive the solve
    for part in parts:
        assert part.plan is not None
        callbacks.append(SpectraCallback(part.model, part.plan.fs, lower, upper - lower))
        psd = callbacks[-1](u)
        steps = [m.name for m in part.model.metrics if m.kind == "transient"]
        transient = None
        if steps:  # from the numpy code through a callback (hisopt.optim.transient_callback)
            callbacks.append(TransientCallback(part.problem, steps, lower, upper - lower))
            values = callbacks[-1](u)
            transient = {name: values[k] for k, name in enumerate(steps)}.__getitem__
        z = {name: log10(value) for name, value in part.model.integrals(x, part.plan.fs, psd, transient).items()}
        for name, nodes in part.plan.max_nodes.items():
            t = ca.MX.sym(f"t_{name}_{len(levels)}")
            levels.append(t)
            row = part.model.output_index[METRICS[name].signal]
            g.append(log10(psd[row, [int(k) for k in nodes]].T) - t)  # epigraph of the maximum
            z[name] = t
        z_of.append(z)
    z_obj, extra, g_agg = _aggregated(problem, parts, z_of, ref_log)
    floor = np.r_[np.full(len(levels), -np.inf), [b for _, b in extra]]
    levels += [v for v, _ in extra]
    g += g_agg
    lv = ca.vertcat(*levels) if levels else ca.MX(0, 1)
    start = np.maximum(_start_levels(u, lv, g, u_c), floor)  # before any constraint involving s
    gap = ca.vertcat(*[weights[i] * (z_obj[name] - ref_log[i]) for i, name in enumerate(objectives)])

    # ---- constraints ----------------------------------------------------------------------------
    g.append(gap - s)  # ASF epigraph
    g.append(gap + ca.DM(margin))  # no objective worse than the start
    for c in problem.spec.constraints:
        where = problem.constraint_scenarios(c.name) if problem.spec.scenarios else (None,)
        g += [z[c.name] - np.log10(c.limit) for part, z in zip(parts, z_of, strict=True) if part.scenario in where]

    # ---- objective ------------------------------------------------------------------------------
    objective = s + settings.rho * ca.sum1(gap)

    # ---- initial values and bounds --------------------------------------------------------------
    gap_fn = ca.Function("gap", [u, lv], [gap])
    s0 = float(np.max(np.array(gap_fn(u_c, start))))
    n_free = 1 + len(levels)
    lbx = np.r_[np.maximum(0.0, u_c - radius), -np.inf, floor]
    ubx = np.r_[np.minimum(1.0, u_c + radius), np.full(n_free, np.inf)]

    # ---- solve NLP ------------------------------------------------------------------------------
    options: dict[str, Any] = {
        "print_time": False,
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "ipopt.max_iter": settings.max_iter,
        "ipopt.tol": settings.tol,
        "ipopt.bound_relax_factor": 0.0,
        # Quasi-Newton (the spectra callback has first derivatives only); a small constant
        # initial Hessian lets the first steps reach the trust-region bounds.
        "ipopt.hessian_approximation": "limited-memory",
        "ipopt.limited_memory_initialization": "constant",
        "ipopt.limited_memory_init_val": 1e-3,
    }
    nlp: dict[str, Any] = {"x": ca.vertcat(u, s, lv), "f": objective, "g": ca.vertcat(*g)}
    solver = ca.nlpsol("asf", "ipopt", nlp, options)
    sol = solver(x0=np.r_[u_c, s0, start], lbx=lbx, ubx=ubx, lbg=-np.inf, ubg=0.0)
    stats = solver.stats()
    opt = np.array(sol["x"]).ravel()
    u_opt = np.clip(opt[:n_var], 0.0, 1.0)
    gap_opt = np.array(gap_fn(u_opt, opt[n_var + 1 :])).ravel()
    del callbacks
    return SolveOutcome(u_opt, str(stats["return_status"]), int(stats["iter_count"]), gap_opt)


def _aggregated(
    problem: Problem, parts: list[Part], z_of: list[dict[str, Any]], ref_log: np.ndarray
) -> tuple[dict[str, Any], list[tuple[Any, float]], list[Any]]:
    """The objectives' log10 expressions over the load cases (docs/model.md §14.5), with any
    new epigraph variables (and their lower bounds) and their constraints ``<= 0``.

    ``worst``: a level ``tau_q`` above every scenario's ``z_q,s``. ``expected``: ``log10`` of
    the weighted sum of the values. ``cvar``: Rockafellar and Uryasev's epigraph
    ``eta + sum_s w_s u_s / (1 - alpha)``, ``u_s >= v_s - eta``, ``u_s >= 0``, in values scaled
    by the start's (so IPOPT sees numbers near 1). ``per_scenario``: each pair as it is.
    """
    import casadi as ca

    from hisopt.robust import normalised, scenario_column

    spec = problem.spec
    if not spec.scenarios:
        return z_of[0], [], []
    how = spec.robust.aggregate
    if how == "per_scenario":
        return {scenario_column(q, p.scenario or ""): z[q] for q in spec.objectives for p, z in zip(parts, z_of, strict=True)}, [], []
    w = normalised([sc.weight for sc in spec.scenarios])
    names = problem.objective_names
    out: dict[str, Any] = {}
    extra: list[Any] = []
    bounds: list[float] = []
    g: list[Any] = []
    for i, q in enumerate(names):
        zs = [z[q] for z in z_of]
        if len(zs) == 1:
            out[q] = zs[0]
        elif how == "worst":
            tau = ca.MX.sym(f"tau_{q}")
            extra.append(tau)
            bounds.append(-np.inf)
            g += [zq - tau for zq in zs]
            out[q] = tau
        elif how == "expected":
            out[q] = ref_log[i] + ca.log(sum(float(wk) * 10 ** (zq - ref_log[i]) for wk, zq in zip(w, zs, strict=True))) / np.log(10.0)
        else:
            eta, slack = ca.MX.sym(f"eta_{q}"), [ca.MX.sym(f"u_{q}_{k}") for k in range(len(zs))]
            extra += [eta, *slack]  # bounded below as variables: the values are positive, so is the
            # optimal eta, and the bound keeps log10 defined where IPOPT's iterates break constraints
            bounds += [CVAR_FLOOR] + [0.0] * len(slack)
            g += [10 ** (zq - ref_log[i]) - eta - uk for zq, uk in zip(zs, slack, strict=True)]
            value = eta + sum(float(wk) * uk for wk, uk in zip(w, slack, strict=True)) / (1.0 - spec.robust.alpha)
            out[q] = ref_log[i] + ca.log(value) / np.log(10.0)
    return out, list(zip(extra, bounds, strict=True)), g


CVAR_FLOOR = 1e-6
"""[-] Least threshold ``eta`` of the CVaR epigraph, in units of the start design's values."""


def _start_levels(u: Any, levels: Any, g: list[Any], u_c: np.ndarray) -> np.ndarray:
    """Starting values of the epigraph variables at ``u_c``: each the least value every
    constraint bounding it from below allows (tight epigraphs; a few passes, as levels feed
    later ones)."""
    import casadi as ca

    n = levels.shape[0]
    if n == 0:
        return np.zeros(0)
    start = np.zeros(n)
    gs = ca.vertcat(*g)
    g_fn = ca.Function("g", [u, levels], [gs, ca.jacobian(gs, levels)])
    for _ in range(4):  # epigraph chains are at most three deep (maximum, aggregate, slack)
        value, jac = (np.array(a) for a in g_fn(u_c, start))
        value = value.ravel()
        for k in range(n):  # a constraint g = ... - level_k (Jacobian -1) bounds level_k below
            rows = np.flatnonzero((jac[:, k] < 0) & np.isfinite(value))
            if rows.size:
                start[k] += float(np.max(value[rows] / -jac[rows, k]))
    return start


# --- one start design: trust-region rounds -----------------------------------------------------
def _merit(gap: np.ndarray, rho: float) -> float:
    """[-] The NLP objective at a design whose weighted log10 changes are ``gap``."""
    return float(np.max(gap) + rho * np.sum(gap))


def _evaluate(problem: Problem, x: np.ndarray) -> dict[str, float]:
    q = problem.evaluator()(np.asarray(x, dtype=float)[None, :])
    return {k: float(v[0]) for k, v in q.items()}


def _feasible(problem: Problem, q: dict[str, float]) -> bool:
    return bool(q["valid"]) and all(q[c.name] <= c.limit for c in problem.spec.constraints)


def refine_point(
    problem: Problem,
    parts: list[Part],
    source_index: int,
    x0: np.ndarray,
    f0: np.ndarray,
    weights: np.ndarray,
    settings: RefineSettings,
) -> PointResult:
    """Refine one front design by trust-region rounds of the ASF NLP (module docstring).

    Parameters
    ----------
    source_index : [-] the design's row in the front (recorded only)
    x0 : [variable units] start design, ``(n_var,)``
    f0 : [objective units] the start's objectives as the front records them, ``(n_obj,)``
    weights : [1/decade] ASF weights, ``(n_obj,)``
    """
    from hisopt.optim.decision import log_objectives

    started = time.perf_counter()
    lower, span = problem.lower, problem.upper - problem.lower
    names = problem.objective_names
    ref = log_objectives(np.asarray(f0, dtype=float)[None, :])[0]
    u_c = np.clip((np.asarray(x0, dtype=float) - lower) / span, 0.0, 1.0)
    best_x, best_q, best_merit, best_asf = np.asarray(x0, dtype=float), None, 0.0, 0.0
    margin = np.full(len(names), settings.margin)
    radius, rounds, iterations, status = settings.trust_radius, 0, 0, "not_started"
    while rounds < settings.rounds and radius >= settings.min_radius:
        planned = [Part(p.scenario, p.problem, p.model, node_plan(p.problem, p.model, lower + span * u_c, settings)) for p in parts]
        outcome = solve_asf(problem, planned, u_c, ref, weights, radius, settings, margin)
        rounds, iterations, status = rounds + 1, iterations + outcome.iterations, outcome.status
        x_new = lower + span * outcome.u
        q = _evaluate(problem, x_new)
        gap = weights * (log_objectives(np.array([[q[n] for n in names]]))[0] - ref)
        merit = _merit(gap, settings.rho)
        if _feasible(problem, q) and np.all(gap <= 0.0) and merit < best_merit:
            gain = best_merit - merit
            u_c, best_x, best_q, best_merit, best_asf = outcome.u, x_new, q, merit, float(np.max(gap))
            if gain < settings.min_gain:  # converged: the model offers nothing more here
                break
        elif np.all(outcome.gap <= -margin + 1e-12) and np.any(gap > 0.0):
            # The model promised no loss but the evaluator sees one: demand that much more.
            margin = margin + 2.0 * np.maximum(gap - outcome.gap, 0.0)
            radius /= 2.0
        else:
            radius /= 4.0
    if best_q is None:
        best_q = _evaluate(problem, best_x)
    return PointResult(
        source_index=int(source_index),
        x=best_x,
        quantities={k: v for k, v in best_q.items() if k != "valid"},
        accepted=best_merit < 0.0,
        asf=best_asf,
        merit=best_merit,
        rounds=rounds,
        iterations=iterations,
        seconds=time.perf_counter() - started,
        status=status,
    )


# --- one quantity under limits (epsilon-constraint) -------------------------------------------
def constrained_problem(problem: Problem, objective: str, limits: dict[str, float]) -> Problem:
    """``problem`` with the single objective ``objective`` and ``limits`` as constraints
    (a limit on an already constrained quantity keeps the tighter of the two).

    Parameters
    ----------
    objective : [-] quantity to minimise, e.g. ``"sigma_aw"``
    limits : [quantity units] upper limit per quantity, e.g. ``{"roll_gradient": 0.03}``
    """
    from hisopt.problem import problem_from_dict

    data = problem.spec.model_dump(by_alias=True)
    constraints = {c["name"]: dict(c) for c in data["constraints"]}
    for name, limit in limits.items():
        old = constraints.get(name, {}).get("limit", np.inf)
        # a constraint keeps the scenarios it holds in (docs/model.md §14.1)
        constraints[name] = constraints.get(name, {"name": name}) | {"limit": float(min(limit, old))}
    data["objectives"] = [objective]
    data["constraints"] = list(constraints.values())
    if data["scenarios"] and data["robust"]["aggregate"] == "per_scenario":  # one objective: its worst case
        data["robust"]["aggregate"] = "worst"
    return problem_from_dict(data, f"{problem.name} ({objective} under limits)")


def refine_constrained(
    problem: Problem, x0: np.ndarray, objective: str, limits: dict[str, float], settings: RefineSettings | None = None
) -> PointResult:
    """Minimise ``objective`` subject to the problem's constraints and ``limits`` from ``x0``.

    The epsilon-constraint form of the refinement: :func:`refine_point` on
    :func:`constrained_problem` (one objective, so the ASF NLP minimises ``log10`` of it with
    every limit as a constraint, inside the trust region). The result is kept
    (``accepted``) only if the evaluator finds it feasible, every limit met exactly, and
    strictly better than ``x0``; otherwise ``x`` is ``x0``.

    Parameters
    ----------
    x0 : [variable units] a start design meeting every limit, ``(n_var,)``
    objective, limits : as :func:`constrained_problem`
    """
    sub = constrained_problem(problem, objective, limits)
    # The CasADi model does not depend on the limits (they enter the NLP's bounds): one per
    # problem and set of constrained quantities, whatever their limits.
    parts = _worker_parts(_limits_one(sub))
    x0 = np.asarray(x0, dtype=float)
    start = _evaluate(sub, x0)
    return refine_point(sub, parts, 0, x0, np.array([start[objective]]), np.ones(1), settings or RefineSettings())


def _limits_one(problem: Problem) -> Problem:
    """``problem`` with every constraint limit 1 (a cache key that ignores the limits)."""
    from hisopt.problem import problem_from_dict

    data = problem.spec.model_dump(by_alias=True)
    data["constraints"] = [c | {"limit": 1.0} for c in data["constraints"]]
    return problem_from_dict(data, problem.name)


# --- many start designs, in parallel --------------------------------------------------------
_WORKER: dict[str, Any] = {}
"""Per-process cache: the problem and its CasADi model (built once per worker)."""


def model_parts(problem: Problem) -> list[Part]:
    """The load cases of ``problem`` with their CasADi models (one part without scenarios)."""
    from hisopt.optim.casadi_model import CasadiModel

    if not problem.spec.scenarios:
        return [Part(None, problem, CasadiModel(problem))]
    spaces = [(name, problem.scenario_space(name)) for name in problem.scenario_names]
    return [Part(name, space, CasadiModel(space)) for name, space in spaces]  # type: ignore[arg-type]


def _worker_parts(problem: Problem) -> list[Part]:
    key = problem.spec.model_dump_json()
    if _WORKER.get("key") != key:
        _WORKER.update(key=key, problem=problem, parts=model_parts(problem))
    return _WORKER["parts"]


def _refine_task(task: tuple[int, np.ndarray, np.ndarray], problem: Problem, weights: np.ndarray, settings: RefineSettings) -> PointResult:
    """Refine one ``(source_index, x0, f0)`` in whichever process runs it."""
    parts = _worker_parts(problem)
    return refine_point(_WORKER["problem"], parts, task[0], task[1], task[2], weights, settings)


def refine_front(
    problem: Problem,
    front: pd.DataFrame,
    max_points: int = 40,
    *,
    settings: RefineSettings | None = None,
    backend: Backend | None = None,
    reference_log: np.ndarray | None = None,
    progress: Callable[[PointResult], None] | None = None,
    source: str = "front",
) -> RefineResult:
    """Refine up to ``max_points`` designs spread over ``front`` (module docstring).

    Parameters
    ----------
    problem : the problem the front belongs to
    front : [physical units] the front: the variable columns and objective columns (and any
        constraint columns), one row per design, as ``front.csv``
    max_points : [-] most start designs
    settings : refinement settings (default :class:`RefineSettings`)
    backend : where the NLPs run: this process (default) or a Dask cluster
        (:func:`hisopt.parallel.open_backend`), one task per start design
    reference_log : [decades] hypervolume reference point; default the problem's
        (:func:`hisopt.optim.decision.reference_point`)
    progress : called with each finished :class:`PointResult` (in completion order)
    source : [-] where the front comes from (named in errors), e.g. its file

    Raises
    ------
    ConfigError
        ``max_points < 1``, the front lacks a variable or objective column, or a row is not a valid start
        (:func:`start_designs`).
    """
    from hisopt.optim.decision import hypervolume, reference_point
    from hisopt.parallel import Backend

    started = time.perf_counter()
    settings = settings or RefineSettings()
    names = list(problem.objective_names)
    var_names = list(problem.variable_names)
    missing = [c for c in var_names + names if c not in front.columns]
    if missing:
        raise ConfigError(f"the front lacks the column {missing[0]!r}; expected columns {', '.join(var_names + names)}")
    front = front.reset_index(drop=True)
    x, f = start_designs(problem, front, source)
    reference = reference_point(problem) if reference_log is None else np.asarray(reference_log, dtype=float)
    chosen = select_points(f, max_points) if len(front) else np.zeros(0, dtype=int)
    weights = asf_weights(f) if len(front) else np.ones(len(names))
    tasks = [(int(i), x[i], f[i]) for i in chosen]
    backend = backend or Backend()
    report = None if progress is None else (lambda _, result: progress(result))
    results = backend.map(_refine_task, tasks, problem, weights, settings, on_result=report)

    from hisopt.units import attach_units

    points = attach_units(_points_frame(problem, results), problem)
    refined = attach_units(_refined_front(problem, front, results), problem)
    return RefineResult(
        front=refined,
        points=points,
        hypervolume_before=hypervolume(f, reference),
        hypervolume_after=hypervolume(refined[names].to_numpy(dtype=float), reference),
        reference_point=reference,
        wall_time_s=time.perf_counter() - started,
    )


def start_designs(problem: Problem, front: pd.DataFrame, source: str = "front") -> tuple[np.ndarray, np.ndarray]:
    """Start designs ``x`` (n, n_var) and their objectives ``f`` (n, n_obj) from a front, checked
    by the same rules as every design (:mod:`hisopt.validation`).

    Raises
    ------
    ConfigError
        A row breaks a parameter's rule, lies outside the box, or has a non-finite objective
        (the row, counted from 1, is named).
    """
    from hisopt.validation import check_designs, design_matrix

    x = design_matrix(problem, front[list(problem.variable_names)], source)
    f = front[list(problem.objective_names)].to_numpy(dtype=float)
    check = check_designs(problem, x)
    bad = np.flatnonzero(~check.ok)
    if len(bad):
        i = int(bad[0])
        raise ConfigError(f"row {i + 1}: {check.detail[i]}; expected start designs inside the box", file=source)
    bad = np.flatnonzero(~np.all(np.isfinite(f), axis=1))
    if len(bad):
        i = int(bad[0])
        raise ConfigError(f"row {i + 1}: expected finite objective values, got {dict(zip(problem.objective_names, f[i].tolist(), strict=True))}", file=source)
    return x, f


def _points_frame(problem: Problem, results: list[PointResult]) -> pd.DataFrame:
    rows = []
    for r in results:
        row = {
            "source_index": r.source_index,
            "accepted": r.accepted,
            "asf": r.asf,
            "merit": r.merit,
            "rounds": r.rounds,
            "iterations": r.iterations,
            "seconds": r.seconds,
            "status": r.status,
        }
        row |= dict(zip(problem.variable_names, r.x.tolist(), strict=True))
        row |= r.quantities
        rows.append(row)
    return pd.DataFrame(rows)


def _refined_front(problem: Problem, front: pd.DataFrame, results: list[PointResult]) -> pd.DataFrame:
    """The kept refined designs plus the original designs none of them dominates."""
    original = front.copy()
    original["source_index"] = np.arange(len(front))
    rows = []
    for r in results:
        if not r.accepted:
            continue
        row = {c: np.nan for c in front.columns}
        row |= dict(zip(problem.variable_names, r.x.tolist(), strict=True))
        row |= {k: v for k, v in r.quantities.items() if k in front.columns}
        row["source_index"] = r.source_index
        rows.append(row)
    merged = pd.concat([original, pd.DataFrame(rows, columns=original.columns)], ignore_index=True) if rows else original
    f = merged[list(problem.objective_names)].to_numpy(dtype=float)
    keep = non_dominated_mask(f) if len(f) else np.zeros(0, dtype=bool)
    out = merged[keep].sort_values("source_index", kind="stable").reset_index(drop=True)
    out["source_index"] = out["source_index"].astype(np.int64)
    return out


# --- run directories -------------------------------------------------------------------------
def refine_run(
    run_dir: str | Path,
    max_points: int = 40,
    *,
    settings: RefineSettings | None = None,
    backend: Backend | None = None,
    progress: Callable[[PointResult], None] | None = None,
) -> RefineResult:
    """Refine a run directory's ``front.csv``; write ``front_refined.csv`` and ``refine.json``.

    Parameters
    ----------
    run_dir : [-] a directory written by :func:`hisopt.optim.run.optimize` (``out=``)
    max_points, settings, backend, progress : as :func:`refine_front`

    Raises
    ------
    RunError
        Not a run directory, no or unreadable ``front.csv``, or the problem copy was edited.
    ConfigError
        A front row is not a valid start design.
    """
    from hisopt.io import ensure_writable_dir, write_csv
    from hisopt.optim import rundir

    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise RunError(f"{run_dir}: run directory not found; expected the --out directory of `hisopt optimize`")
    problem, reference = rundir.run_problem(run_dir)
    front = rundir.read_front(run_dir / rundir.FRONT_CSV)
    ensure_writable_dir(run_dir)
    settings = settings or RefineSettings()
    result = refine_front(
        problem, front, max_points, settings=settings, backend=backend, reference_log=reference, progress=progress,
        source=str(run_dir / rundir.FRONT_CSV),
    )
    write_csv(result.front, run_dir / FRONT_REFINED_CSV)
    summary = result.summary() | {"max_points": max_points, "settings": asdict(settings)}
    summary["per_point"] = json.loads(result.points.to_json(orient="records"))
    rundir.atomic_write_json(run_dir / REFINE_JSON, summary)
    return result
