"""The refinement's NLP: the nodes it is built on and one solve around a design.

The achievement-scalarising NLP of :mod:`hisopt.optim.gradient.refine` (see its docstring for the
formulation and the trust region), over one or several load cases (docs/model.md §14.5):
each load case's model on its own pole-aware nodes, the objectives aggregated as the
evaluator aggregates them, every limit a constraint.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from hisopt.metrics import METRICS

if TYPE_CHECKING:
    from hisopt.optim.gradient.casadi_model import CasadiModel, FrequencySet
    from hisopt.problem import Problem


# --- settings and results --------------------------------------------------------------------
@dataclass(frozen=True)
class RefineSettings:
    """Settings of the refinement (the :mod:`hisopt.optim.gradient.refine` docstring).

    Attributes
    ----------
    trust_radius : float
        [-] initial trust-region radius in scaled design units (bounds = [0, 1])
    min_radius : float
        [-] stop once the radius falls below this
    rounds : int
        [-] most NLP solves per start design
    rho : float
        [-] ASF augmentation: weight of the summed improvement beside the worst one
    margin : float
        [-] initial least improvement demanded of every objective (weighted log10)
    min_gain : float
        [-] stop once a round lowers the merit by less than this
    peak_share : float
        [-] local PSD peaks at least this share of the maximum get a node cluster
    node_share : float
        [-] a maximum's epigraph also uses nodes with PSD at least this share of it
    cluster_offsets : tuple[float, ...]
        [-] cluster nodes each side of a peak, in half-power half-widths
    max_iter : int
        [-] IPOPT iterations per solve
    tol : float
        [-] IPOPT convergence tolerance
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


# --- frequency nodes -------------------------------------------------------------------------
@dataclass(frozen=True)
class NodePlan:
    """Frequency nodes of one NLP.

    Attributes
    ----------
    fs : FrequencySet
        the frequency set (quadrature weights, per-node parameters)
    max_nodes : dict[str, np.ndarray]
        node indices of each band-maximum quantity's epigraph
    """

    fs: FrequencySet
    max_nodes: dict[str, np.ndarray]


def peak_locations(frf: Any, ev: Any, outputs: np.ndarray, lo_hz: np.ndarray, hi_hz: np.ndarray, steps: int = 12, points: int = 9) -> np.ndarray:
    """[Hz] Location of the PSD maximum of output ``outputs[i]`` in ``[lo_hz[i], hi_hz[i]]``
    for every bracket ``i`` at once, from ``points`` samples each refined by
    :func:`hisopt.evaluation.peaks.refine_maximum` (``steps`` new samples each).

    All brackets are sampled in one FRF call per step (the FRF of one design is frequency by
    frequency, so a bracket's numbers do not depend on the others').

    Parameters
    ----------
    frf : Any
        output FRF function of one design, as :class:`hisopt.evaluation.channels.DirectOutputs`
    ev : Any
        the problem's evaluator (for its road spectra)
    outputs : np.ndarray
        [-] output index of each bracket, ``(n,)``
    lo_hz, hi_hz : np.ndarray
        [Hz] bracket limits, ``(n,)``
    """
    from hisopt.evaluation.peaks import refine_maximum

    outputs = np.asarray(outputs, dtype=int)
    if outputs.size == 0:
        return np.zeros(0)
    rows = np.arange(outputs.size)[:, None]

    def values_at(pts: np.ndarray) -> np.ndarray:
        flat = pts.reshape(1, -1)
        psd = ev.spectra(flat, frf(2 * np.pi * flat))[0].reshape(*pts.shape, -1)  # (n, m, n_out)
        return psd[rows, np.arange(pts.shape[1])[None, :], outputs[:, None]]

    f = np.linspace(np.asarray(lo_hz, dtype=float), np.asarray(hi_hz, dtype=float), points, axis=1)
    return refine_maximum(values_at, f, values_at(f), steps)[0]


def node_plan(problem: Problem, model: CasadiModel, x: np.ndarray, settings: RefineSettings) -> NodePlan:
    """Nodes of the NLP at design ``x`` [variable units], ``(n_var,)`` (module docstring)."""
    from hisopt.evaluation.channels import DirectOutputs
    from hisopt.evaluation.evaluate import Evaluator, poles

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
    owner: list[str] = []  # the band-maximum quantity of each peak bracket
    output: list[int] = []
    peak: list[int] = []
    for m in model.metrics:
        if m.kind != "max":
            continue
        j = model.output_index[m.signal]
        y = psd[:, j]
        is_peak = np.r_[y[0] > y[1], (y[1:-1] >= y[:-2]) & (y[1:-1] >= y[2:]), y[-1] > y[-2]]
        found = np.flatnonzero(is_peak & (y >= settings.peak_share * y.max()))
        owner += [m.name] * found.size
        output += [j] * found.size
        peak += found.tolist()
    k = np.array(peak, dtype=int)
    f_pk = peak_locations(frf, ev, np.array(output, dtype=int), f[np.maximum(k - 1, 0)], f[np.minimum(k + 1, f.size - 1)])
    clusters: dict[str, list[np.ndarray]] = {m.name: [] for m in model.metrics if m.kind == "max"}
    for name, fp in zip(owner, f_pk.tolist(), strict=True):
        nearest = upper[np.argmin(np.abs(upper.imag / (2 * np.pi) - fp))] if upper.size else 0j
        half_width = max(abs(nearest.real) / (2 * np.pi), 1e-3 * fp)
        c = fp + half_width * offsets
        clusters[name].append(c[(c >= ev.f_lo) & (c <= ev.f_hi)])
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
    u : np.ndarray
        [-] scaled design found, ``(n_var,)``
    status : str
        [-] IPOPT return status
    iterations : int
        [-] IPOPT iterations
    gap : np.ndarray
        [-] the model's weighted log10 change of each objective against the reference
    """

    u: np.ndarray
    status: str
    iterations: int
    gap: np.ndarray


SOFT_MAXIMUM_DECADES = 1e-3
"""[decades] Temperature of the soft maximum ``tau ln sum exp(log10 S_k / tau)`` of a band
maximum under a spread statistic: above the nodes' maximum by at most ``tau ln(n)`` decades,
0.007 (1.6 %) for 1000 nodes (the evaluator, which keeps a design only if it is no worse, has
the last word)."""


@dataclass(frozen=True)
class Part:
    """One load case of the NLP: its single-case problem, CasADi model and nodes (the problem
    itself, scenario ``None``, for a problem without ``[[scenarios]]``)."""

    scenario: str | None
    problem: Problem
    model: CasadiModel
    plan: NodePlan | None = None
    shift: np.ndarray | None = None  # a sample's design map x_s = shift + scale x (hisopt.optim.gradient.sample_parts)
    scale: np.ndarray | None = None
    road: float = 1.0  # a sample's factor on the road PSD

    def design(self, x: np.ndarray) -> np.ndarray:
        """[variable units] The design this part evaluates for design ``x`` (a sample's moved one)."""
        return x if self.shift is None or self.scale is None else self.shift + self.scale * x

    def bounds(self, lower: np.ndarray, span: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """[variable units] ``(lower, span)`` that map the scaled design ``u`` to this part's design."""
        return (lower, span) if self.shift is None or self.scale is None else (self.shift + self.scale * lower, self.scale * span)


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
    parts : list[Part]
        the load cases with their nodes at ``u_c`` (one for a single-case problem)
    u_c : np.ndarray
        [-] current design scaled to [0, 1] over the bounds, ``(n_var,)``
    ref_log : np.ndarray
        [decades] reference point, ``log10`` of the start's objectives, ``(n_obj,)``
    weights : np.ndarray
        [1/decade] ASF weights, ``(n_obj,)``
    radius : float
        [-] trust-region radius in scaled units
    margin : np.ndarray
        [-] least weighted log10 improvement demanded of each objective, ``(n_obj,)``
    """
    import casadi as ca

    from hisopt.optim.gradient.casadi_model import SpectraCallback
    from hisopt.optim.gradient.sample_parts import road_shift, sample_constraints, sample_objectives, uses_samples
    from hisopt.optim.gradient.transient_callback import TransientCallback

    lower, upper = problem.lower, problem.upper
    n_var = lower.size
    objectives = problem.objective_names

    def log10(e: Any) -> Any:
        return ca.log(e) / np.log(10.0)

    # ---- decision variables -------------------------------------------------------------------
    u = ca.MX.sym("u", n_var)  # design scaled to [0, 1] over its bounds
    s = ca.MX.sym("s")  # ASF level
    levels: list[Any] = []  # log10 epigraph level of each band maximum in each part
    g: list[Any] = []

    # ---- each load case's model on its fixed nodes ----------------------------------------------
    z_of: list[dict[str, Any]] = []
    soft = uses_samples(problem) and problem.spec.robust.statistic == "mean_plus_k_sigma"
    callbacks: list[Any] = []  # CasADi keeps no reference to a Python callback: these must outlive the solve
    for part in parts:
        assert part.plan is not None
        low, width = part.bounds(lower, upper - lower)
        callbacks.append(SpectraCallback(part.model, part.plan.fs, low, width))
        psd = callbacks[-1](u)
        steps = [m.name for m in part.model.metrics if m.kind == "transient"]
        transient = None
        if steps:  # from the numpy code through a callback (hisopt.optim.gradient.transient_callback)
            callbacks.append(TransientCallback(part.problem, steps, low, width))
            values = callbacks[-1](u)
            transient = {name: values[k] for k, name in enumerate(steps)}.__getitem__
        x_part = ca.DM(low) + ca.DM(width) * u
        z = {name: log10(value) + road_shift(name, part.road) for name, value in part.model.integrals(x_part, part.plan.fs, psd, transient).items()}
        for name, nodes in part.plan.max_nodes.items():
            shifted = log10(psd[part.model.output_index[METRICS[name].signal], [int(k) for k in nodes]].T) + road_shift(name, part.road)
            if soft:  # a spread statistic is not monotone in an epigraph level: a soft maximum instead
                z[name] = SOFT_MAXIMUM_DECADES * ca.logsumexp(shifted / SOFT_MAXIMUM_DECADES)
                continue
            t = ca.MX.sym(f"t_{name}_{len(levels)}")
            levels.append(t)
            g.append(shifted - t)  # epigraph of the maximum
            z[name] = t
        z_of.append(z)
    if uses_samples(problem):  # statistics over common random samples (hisopt.optim.gradient.sample_parts)
        z_obj = sample_objectives(problem, z_of, ref_log)
        extra, g_agg = sample_constraints(problem, z_of)
    else:
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
    for c in problem.spec.constraints if not uses_samples(problem) else ():  # a sample set's are in g_agg
        where = problem.constraint_scenarios(c.name) if problem.spec.scenarios else (None,)
        g += [z[c.name] - np.log10(c.limit) for part, z in zip(parts, z_of, strict=True) if part.scenario in where]

    # ---- objective ------------------------------------------------------------------------------
    objective = s + settings.rho * ca.sum1(gap)

    # ---- initial values and bounds --------------------------------------------------------------
    gap_fn = ca.Function("gap", [u, lv], [gap])
    s0 = float(np.max(np.array(gap_fn(u_c, start))))
    n_free = 1 + len(levels)
    fixed = np.isin(np.arange(u_c.size), list(problem.choices))  # a catalogue part stays the design's (docs/model.md §17)
    lbx = np.r_[np.where(fixed, u_c, np.maximum(0.0, u_c - radius)), -np.inf, floor]
    ubx = np.r_[np.where(fixed, u_c, np.minimum(1.0, u_c + radius)), np.full(n_free, np.inf)]

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
