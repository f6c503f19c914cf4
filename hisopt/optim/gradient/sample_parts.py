"""The CasADi refinement's sample average (docs/model.md §18.4): one load case ("part") per
common random sample of the ``[[uncertain]]`` inputs, and the statistics over them.

Each part is the problem at that sample (:func:`hisopt.evaluation.uncertain.sample_space`)
with its CasADi model. A tolerance on a design variable moves the design affinely,
``x_s = a_s + b_s x`` (a spread in % scales it, one in its unit shifts it), so a part sees
the scaled design ``u`` through its own bounds ``a_s + b_s lower`` and ``b_s span``; the road's
roughness is a factor on every PSD, ``log10`` of which the part adds to each quantity times
its power (:data:`hisopt.metrics.ROAD_POWER`). Objectives and plain constraints are the
statistic of ``[robust]`` over the parts' values (in values scaled by the start's, so that
IPOPT sees numbers near 1); a chance constraint ``P(q > limit) <= p`` is replaced by its
conservative convex approximation ``CVaR_(1-p)(q) <= limit`` (Nemirovski and Shapiro 2006),
whose epigraph is Rockafellar and Uryasev's: the evaluator, which keeps a refined design
only if it meets the chance constraint itself, has the last word.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from hisopt.errors import ConfigError
from hisopt.evaluation.robust_evaluator import needs_samples
from hisopt.evaluation.uncertain import UncertainEvaluator, monte_carlo_variates, sample_space
from hisopt.metrics import METRICS, ROAD_POWER

if TYPE_CHECKING:
    from hisopt.problem import Problem

SPREAD_FLOOR = 1e-12
"""[-] Added to a scaled variance under the square root: a sample set without spread stays
differentiable (a bias of 1e-6 of the start's value at most)."""


def design_maps(evaluator: UncertainEvaluator, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(a, b)``, each ``(N, n_var)``: sample ``s`` moves design ``x`` to ``a_s + b_s x``.

    Raises
    ------
    ConfigError
        A tolerance on a design variable that is not affine in the design (a truncated
        normal, a spread in % of a variable that may be negative).
    """
    space = evaluator.space
    names = space.variable_names
    n = len(u)
    a, b = np.zeros((n, len(names))), np.ones((n, len(names)))
    for k, item in enumerate(evaluator.inputs):
        if item.name not in names:
            continue
        j = names.index(item.name)
        if item.relative and space.lower[j] < 0:
            raise ConfigError(f"{item.name}: a spread in % of a variable that may be negative is not affine in it; give it in its unit", key="uncertain")
        at = [item.values(np.clip(u[:, k], 1e-12, 1 - 1e-12), np.full(n, x)) for x in (1.0, 2.0, 3.0)]
        slope, offset = at[1] - at[0], 2.0 * at[0] - at[1]
        if not np.allclose(at[2], offset + 3.0 * slope, rtol=1e-12, atol=0.0):
            raise ConfigError(
                f"{item.name}: a truncated tolerance on a design variable is not affine in it; the IPOPT refinement needs one that is (method slp takes any)",
                key="uncertain",
            )
        a[:, j], b[:, j] = offset, slope
    return a, b


@dataclass(frozen=True)
class SampleCase:
    """One common random sample as a load case of the NLP: its problem (the sample's inputs
    set), the design map ``x_s = shift + scale x`` and the road PSD's factor."""

    name: str
    space: Problem
    shift: np.ndarray
    scale: np.ndarray
    road: float


def sample_cases(problem: Problem) -> list[SampleCase]:
    """One :class:`SampleCase` per common random sample of ``problem`` (its ``[robust]
    samples`` from ``[robust] seed``, the evaluator's own set)."""
    if problem.spec.scenarios:
        raise ConfigError("the IPOPT refinement takes samples or load cases, not both; refine with method slp (the default)", key="--method")
    evaluator = UncertainEvaluator(problem)
    robust = problem.spec.robust
    u = monte_carlo_variates(robust.samples, len(evaluator.inputs), robust.seed)
    baseline = np.repeat(problem.baseline[None, :], len(u), axis=0)
    values = evaluator.values(baseline, u)
    a, b = design_maps(evaluator, u)
    cases = []
    routed = list(zip(evaluator.inputs, evaluator.routes, strict=True))
    for s in range(len(u)):
        fixed = {item.name: float(values[item.name][s]) for item, how in routed if how not in ("design", "road")}
        road = [float(values[item.name][s]) / evaluator.nominal[item.name] for item, how in routed if how == "road"]
        space = sample_space(problem, fixed)
        cases.append(SampleCase(f"sample {s}", space, a[s], b[s], road[0] if road else 1.0))  # type: ignore[arg-type]
    return cases


def road_shift(name: str, road: float) -> float:
    """[decades] What the road's roughness factor ``road`` adds to ``log10`` of quantity ``name``."""
    return ROAD_POWER[METRICS[name].kind] * float(np.log10(road))


def statistic_of(values: list[Any], statistic: str, k: float) -> Any:
    """The ``[robust]`` statistic of the parts' scaled values (CasADi expressions)."""
    import casadi as ca

    n = len(values)
    mean = sum(values) / n
    if statistic == "mean":
        return mean
    variance = sum((v - mean) ** 2 for v in values) / max(n - 1, 1)
    return mean + k * ca.sqrt(variance + SPREAD_FLOOR)


def sample_objectives(problem: Problem, z_of: list[dict[str, Any]], ref_log: np.ndarray) -> dict[str, Any]:
    """``log10`` of each objective's statistic over the samples (the nominal statistic: the
    sample average, the engine's model of a value at the nominal inputs being the parts')."""
    import casadi as ca

    robust = problem.spec.robust
    statistic = "mean" if robust.statistic == "nominal" else robust.statistic
    out = {}
    for i, q in enumerate(problem.objective_names):
        scaled = [10 ** (z[q] - ref_log[i]) for z in z_of]
        out[q] = ref_log[i] + ca.log(statistic_of(scaled, statistic, robust.k)) / np.log(10.0)
    return out


def sample_constraints(problem: Problem, z_of: list[dict[str, Any]]) -> tuple[list[tuple[Any, float]], list[Any]]:
    """Each constraint over the samples as new variables (with lower bounds) and constraints
    ``<= 0``: a plain one on the statistic, a chance one as ``CVaR_(1-p) <= limit``."""
    import casadi as ca

    robust = problem.spec.robust
    statistic = "mean" if robust.statistic == "nominal" else robust.statistic
    extra: list[tuple[Any, float]] = []
    g: list[Any] = []
    n = len(z_of)
    for c in problem.spec.constraints:
        scaled = [10 ** (z[c.name] - np.log10(c.limit)) for z in z_of]  # value / limit
        if c.probability is None:
            g.append(statistic_of(scaled, statistic, robust.k) - 1.0)
            continue
        eta, slack = ca.MX.sym(f"eta_{c.name}"), [ca.MX.sym(f"xi_{c.name}_{s}") for s in range(n)]
        extra += [(eta, -np.inf)] + [(xi, 0.0) for xi in slack]
        g += [v - eta - xi for v, xi in zip(scaled, slack, strict=True)]
        g.append(eta + sum(slack) / (n * c.probability) - 1.0)
    return extra, g


def uses_samples(problem: Problem) -> bool:
    """Whether the refinement of ``problem`` averages over samples."""
    return needs_samples(problem)
