"""Which inputs matter and how a design spreads: Sobol indices and Monte Carlo tolerance
studies over the ``[[uncertain]]`` inputs (docs/model.md §18).

- :func:`sensitivity`: first- and total-order Sobol indices of every quantity with respect
  to the uncertain inputs around one design, or to the design variables and the uncertain
  inputs over the whole box. Saltelli's sample and the estimators with their bootstrap
  intervals are SALib's (:func:`hisopt.studies.sobol.sobol_indices`, which takes any
  function, so an analytical one checks the same path); the base samples double until every
  interval is narrow, and a quantity spanning decades is taken as ``log10``.
- :func:`tolerance`: one design at ``N`` Monte Carlo samples: each quantity's mean, standard
  deviation and percentiles, and each constraint's probability of violation with its Wilson
  interval.

Sample sets come from a seed (:func:`monte_carlo_variates`), so the same seed gives the same
numbers on one process or on Dask (within rounding, 1e-12).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from scipy import stats

from hisopt.arguments import integer, problem_argument
from hisopt.errors import ConfigError
from hisopt.evaluation.uncertain import UncertainEvaluator, monte_carlo_variates
from hisopt.metrics import METRICS
from hisopt.robust import quantity_of
from hisopt.specification.uncertain import resolve_uncertain
from hisopt.studies.sobol import CONFIDENCE, MAX_EVALUATIONS, TARGET_HALF_WIDTH, check_convergence_settings, check_n_base, sobol_indices

if TYPE_CHECKING:
    from hisopt.evaluation.parallel import Backend
    from hisopt.specification.design_space import DesignSpace

PERCENTILES = (1.0, 5.0, 50.0, 95.0, 99.0)


def quantity_unit(name: str) -> str:
    """[-] SI unit of a quantity column (``"sigma_aw@city"`` as ``sigma_aw``)."""
    return METRICS[quantity_of(name)].unit


# --- tolerance: Monte Carlo of one design --------------------------------------------------------
@dataclass(frozen=True)
class ToleranceResult:
    """A design's quantities over the sample set.

    Attributes
    ----------
    values : pd.DataFrame
        [quantity units] one row per sample: the inputs' values, then every quantity (NaN where
        the model failed or a drawn input is impossible), ``valid``
    summary : pd.DataFrame
        [quantity units] per quantity: nominal, mean, sd, mean's half-width, percentiles
    violations : pd.DataFrame
        [-] per constraint: limit, probability of violation and its interval
    seed : int
        [-] the sample set's seed
    """

    values: pd.DataFrame
    summary: pd.DataFrame
    violations: pd.DataFrame
    seed: int


def tolerance(space: DesignSpace, design: np.ndarray, n_samples: int = 100_000, seed: int = 0, backend: Backend | None = None) -> ToleranceResult:
    """Monte Carlo of ``design`` (one row) over the problem's uncertain inputs.

    A sample where the model fails (unstable, or an input drawn beyond its rule) counts as a
    violation of every constraint: what cannot be evaluated is not shown to hold.
    """
    check_tolerance(space, n_samples, "n_samples")
    integer(seed, "seed", minimum=0)
    evaluator = UncertainEvaluator(space)
    x = space.design_matrix(design)
    if len(x) != 1 or not np.isfinite(x).all():
        raise ConfigError(f"expected one design of finite values, got {len(x)} rows{'' if np.isfinite(x).all() else ' with NaN or inf'}", key="design")
    u = monte_carlo_variates(n_samples, len(evaluator.inputs), seed)
    got = evaluator(x, u, backend)
    inputs = evaluator.values(np.repeat(x, len(u), axis=0), u)
    nominal = {k: float(v[0]) for k, v in space_nominal(space, x).items()}
    frame = pd.DataFrame(inputs | {k: got[k][0] for k in evaluator.names} | {"valid": got["valid"][0]})
    return ToleranceResult(frame, summarise(frame, evaluator.names, nominal), violations(space, frame), seed)


def check_tolerance(space: DesignSpace, n_samples: int, key: str, source: str | None = None) -> None:
    """Refuse a tolerance study that cannot say anything: fewer than 2 samples (a spread of
    one sample is NaN) or a problem without ``[[uncertain]]`` inputs; ``key`` names the sample
    count as the caller knows it (``n_samples``, ``--samples``), ``source`` the problem file."""
    problem_argument(space, "space")
    integer(n_samples, key, minimum=2, what="samples")
    if not space.spec.uncertain:
        raise ConfigError("the problem has no [[uncertain]] inputs; add them (docs/model.md §18)", file=source or str(space.path or space.name))


def check_sensitivity(space: DesignSpace, design: object, source: str | None = None) -> None:
    """Refuse a sensitivity study in which nothing varies: a design given (so only the
    uncertain inputs vary around it) to a problem without ``[[uncertain]]`` inputs; ``source``
    names the problem file."""
    problem_argument(space, "space")
    if design is not None and not space.spec.uncertain:
        raise ConfigError(
            "the problem has no [[uncertain]] inputs, so nothing varies around a design; add them (docs/model.md §18)",
            file=source or str(space.path or space.name),
        )


def space_nominal(space: DesignSpace, x: np.ndarray) -> dict[str, np.ndarray]:
    """The quantities of designs ``x`` with every input at its nominal value."""
    from hisopt.evaluation.scenarios import case_evaluator_for

    return case_evaluator_for(space)(x)


def summarise(frame: pd.DataFrame, names: Sequence[str], nominal: Mapping[str, float]) -> pd.DataFrame:
    """Per quantity over the valid samples: nominal, mean (and its half-width at
    :data:`CONFIDENCE`), sd, :data:`PERCENTILES`, how many samples failed."""
    rows = []
    z = stats.norm.ppf(0.5 + CONFIDENCE / 2)
    for name in names:
        v = frame[name].to_numpy()
        ok = v[np.isfinite(v)]
        sd = float(np.std(ok, ddof=1)) if ok.size > 1 else np.nan
        row = {"quantity": name, "unit": quantity_unit(name), "nominal": nominal.get(name, np.nan), "mean": float(np.mean(ok)) if ok.size else np.nan}
        row |= {"mean_half_width": z * sd / np.sqrt(max(ok.size, 1)), "sd": sd}
        row |= {f"p{p:g}": float(np.percentile(ok, p)) if ok.size else np.nan for p in PERCENTILES}
        row |= {"failed": int(v.size - ok.size), "samples": int(v.size)}
        rows.append(row)
    return pd.DataFrame(rows)


def violations(space: DesignSpace, frame: pd.DataFrame) -> pd.DataFrame:
    """Per constraint: ``P(quantity > limit)`` over the samples (a failed sample violates)
    with its Wilson score interval at :data:`CONFIDENCE` (scipy's ``binomtest``)."""
    rows = []
    for c in space.spec.constraints:
        v = frame[c.name].to_numpy()
        with np.errstate(invalid="ignore"):
            hits = int(np.sum(~(v <= c.limit)))
        ci = stats.binomtest(hits, len(v)).proportion_ci(CONFIDENCE, method="wilson")
        rows.append(
            {
                "constraint": c.name,
                "unit": quantity_unit(c.name),
                "limit": c.limit,
                "probability": hits / len(v),
                "low": ci.low,
                "high": ci.high,
                "samples": len(v),
            }
        )
    return pd.DataFrame(rows, columns=["constraint", "unit", "limit", "probability", "low", "high", "samples"])


# --- sensitivity: Sobol indices ------------------------------------------------------------------
@dataclass(frozen=True)
class SensitivityResult:
    """Sobol indices of a problem's quantities and how far they converged.

    Attributes
    ----------
    indices : pd.DataFrame
        [-] per (quantity, input): S1, S1_conf, ST, ST_conf, with the units (``decades`` for a
        quantity taken as ``log10``) and what each input is
    design : np.ndarray | None
        [SI] the design the study is around (None: over the whole box)
    evaluations, dropped : int
        [-] model evaluations, blocks dropped (a failed model)
    n_base : int
        [-] base samples used
    stop : str
        [-] ``"fixed"``, ``"converged"``, ``"evaluations"`` or ``"time"`` (:class:`SobolIndices`)
    target : float
        [-] the half-width every interval was to reach
    unconverged : pd.DataFrame
        [-] the intervals wider than ``target``: quantity, input, index, half_width
    logged : dict[str, tuple[float, float]]
        [SI] the quantities taken as ``log10``, with their smallest and largest value
    log : bool | None
        [-] the ``log`` asked for (None: each quantity spanning more than a decade)
    seconds : float
        [s] wall time of the indices
    """

    indices: pd.DataFrame
    design: np.ndarray | None
    evaluations: int
    dropped: int
    n_base: int
    stop: str
    target: float
    unconverged: pd.DataFrame
    logged: dict[str, tuple[float, float]]
    log: bool | None
    seconds: float


def sensitivity(
    space: DesignSpace,
    design: np.ndarray | None = None,
    n_base: int | None = None,
    seed: int = 0,
    resamples: int = 250,
    backend: Backend | None = None,
    log: bool | None = None,
    target: float = TARGET_HALF_WIDTH,
    max_evaluations: int = MAX_EVALUATIONS,
    max_seconds: float | None = None,
) -> SensitivityResult:
    """Sobol indices of every objective and constraint of ``space``.

    With ``design`` (one row): with respect to the uncertain inputs around it. Without: over
    the whole box, with respect to the design variables (uniform between their bounds; a
    choice variable uniform over its list) and the uncertain inputs.

    Without ``n_base`` the base samples double from :data:`FIRST_N_BASE` until every S1 and ST
    half-width is at most ``target`` or a cap stops it (:func:`sobol_indices`); with it, a
    power of 2, exactly that many. ``log`` None (default) takes ``log10`` of each quantity
    that spans more than a decade over the samples (its relative changes, as the optimiser
    ranks them, whose variance a few extreme designs do not dominate); True of every
    quantity, False of none.
    """
    check_sensitivity(space, design)
    if n_base is not None:
        check_n_base(n_base)
    check_convergence_settings(target, max_evaluations, max_seconds)
    evaluator = UncertainEvaluator(space)
    uncertain = list(evaluator.inputs)
    variables = [] if design is not None else list(space.variable_names)
    factors = variables + [f"{u.name} (tolerance)" if u.name in variables else u.name for u in uncertain]
    fixed = None if design is None else space.design_matrix(design)[:1]
    units = space.variable_units

    def model(u: np.ndarray) -> dict[str, np.ndarray]:
        x = np.repeat(fixed, len(u), axis=0) if fixed is not None else box_designs(space, u[:, : len(variables)])
        if not uncertain:
            from hisopt.evaluation.scenarios import case_evaluator_for

            got = case_evaluator_for(space)(x)
        else:
            got = evaluator.paired(x, u[:, len(variables) :], backend)
        return {k: got[k] for k in evaluator.names}

    run = sobol_indices(factors, model, n_base, seed, resamples, log, target, max_evaluations=max_evaluations, max_seconds=max_seconds)
    indices = run.indices
    described = {f: ("uniform over its bounds", units.get(f, "")) for f in variables}
    described |= {factor: (u.text, u.unit) for factor, u in zip(factors[len(variables) :], uncertain, strict=True)}
    indices.insert(1, "unit", ["decades" if q in run.logged else quantity_unit(q) for q in indices["quantity"]])
    indices["input_unit"] = [described[f][1] for f in indices["input"]]
    indices["distribution"] = [described[f][0] for f in indices["input"]]
    return SensitivityResult(indices, fixed, run.evaluations, run.dropped, run.n_base, run.stop, run.target, run.unconverged, run.logged, log, run.seconds)


def box_designs(space: DesignSpace, u: np.ndarray) -> np.ndarray:
    """[SI] Designs from standard uniform variates ``(M, n_var)``: each variable uniform
    between its bounds, a choice variable uniform over its listed values."""
    x = space.lower + u * (space.upper - space.lower)
    for j, listed in space.choices.items():
        x[:, j] = listed[np.minimum((u[:, j] * len(listed)).astype(int), len(listed) - 1)]
    return x


def uncertain_inputs(space: DesignSpace) -> pd.DataFrame:
    """[-] What varies in ``space``: each uncertain input, its distribution and how the
    evaluator takes it (:func:`hisopt.evaluation.uncertain.route`), in file order."""
    from hisopt.evaluation.uncertain import route

    problem_argument(space, "space")
    items = resolve_uncertain(space.spec)
    return pd.DataFrame({"input": [u.name for u in items], "distribution": [u.text for u in items], "route": [route(u, space) for u in items]})
