"""Whether a problem's box holds a buildable design at all (docs/model.md §21.3): before a
run, a fixed Sobol' sample of the [variables] box is judged by the buildability rules the
problem enforces as constraints; when no sampled design satisfies them in every load case,
the run is refused with the rules that fail most often, instead of an optimiser searching a
box with no feasible point.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from hisopt.coupled.buildability import BUILD_USAGE, RULES
from hisopt.errors import ConfigError
from hisopt.metrics import METRICS
from hisopt.studies.buildability import load_case_rules

if TYPE_CHECKING:
    from hisopt.specification.design_space import DesignSpace

BOX_SAMPLE = 1024
"""[-] Designs of the Sobol' sample (a power of 2: the sequence's balance properties)."""
BOX_SEED = 40
"""The sample's scrambling seed: the same sample every time for a given box."""
FAILING_SHOWN = 3
"""Rules the refusal names."""


@dataclass(frozen=True)
class BoxVerdict:
    """The enforced rules over a sample of the box: ``designs`` sampled, ``buildable`` how
    many satisfy every enforced rule in every load case, ``failing`` each enforced rule's
    share of the sample that breaks it (``"not evaluated"``: designs with no verdict),
    commonest first."""

    designs: int
    buildable: int
    failing: list[tuple[str, float]]


def enforced_rules(problem: DesignSpace) -> dict[str, list[tuple[float, list[str] | None]]]:
    """The buildability rules ``problem``'s ``[[constraints]]`` enforce: each rule's limits,
    each with the load cases it holds in (None: every one); ``build_usage`` enforces every rule."""
    out: dict[str, list[tuple[float, list[str] | None]]] = {}
    for c in problem.spec.constraints:
        if METRICS[c.name].kind != "build":
            continue
        for name in RULES if c.name == BUILD_USAGE else (c.name,):
            out.setdefault(name, []).append((c.limit, c.scenarios))
    return out


def box_sample(problem: DesignSpace, n: int = BOX_SAMPLE, seed: int = BOX_SEED) -> np.ndarray:
    """[SI] ``n`` designs of a scrambled Sobol' sequence over ``problem``'s box (seed ``seed``)."""
    from scipy.stats import qmc

    lower, upper = np.asarray(problem.lower, dtype=float), np.asarray(problem.upper, dtype=float)
    unit = qmc.Sobol(len(lower), scramble=True, seed=seed).random(n)
    return lower + unit * (upper - lower)


def box_verdict(problem: DesignSpace, n: int = BOX_SAMPLE, seed: int = BOX_SEED) -> BoxVerdict | None:
    """The :class:`BoxVerdict` of :func:`box_sample`, None when ``problem`` enforces no rule."""
    enforced = enforced_rules(problem)
    if not enforced:
        return None
    x = box_sample(problem, n, seed)
    cases = load_case_rules(problem, x)
    broken: dict[str, np.ndarray] = {}
    unknown = np.zeros(len(x), dtype=bool)
    for name, limits in enforced.items():
        broken[name] = np.zeros(len(x), dtype=bool)
        for limit, scenarios in limits:
            for case in cases:
                if scenarios is None or case.name in scenarios:
                    usage = case.rules[name].usage
                    unknown |= np.isnan(usage)  # +inf: beyond a rating of zero, judged (broken)
                    broken[name] |= usage > limit
    ok = ~unknown & ~np.any(np.stack(list(broken.values())), axis=0)
    shares = {name: float(b[~unknown].sum()) / len(x) for name, b in broken.items()}
    if unknown.any():
        shares["not evaluated"] = float(unknown.sum()) / len(x)
    failing = sorted(((k, v) for k, v in shares.items() if v > 0), key=lambda item: -item[1])
    return BoxVerdict(len(x), int(ok.sum()), failing)


def check_buildable_box(problem: DesignSpace, n: int = BOX_SAMPLE, seed: int = BOX_SEED) -> None:
    """Refuse a problem that enforces buildability rules as constraints when no design of
    :func:`box_sample` satisfies them in every load case.

    Raises
    ------
    ConfigError
        One line naming the problem file: the sample, and the rules that fail most often
        with the share of the sample that breaks each.
    """
    verdict = box_verdict(problem, n, seed)
    if verdict is None or verdict.buildable:
        return
    failing = ", ".join(f"{name} ({100 * share:.0f} % of them)" for name, share in verdict.failing[:FAILING_SHOWN])
    raise ConfigError(
        f"no design is buildable: none of {verdict.designs} designs of a Sobol' sample of the [variables] box (seed {seed}) "
        f"satisfies the buildability rules constrained here in every load case; failing most often: {failing}; widen the box "
        "or relax [build]",
        file=str(problem.path or problem.name),
        key="[[constraints]]",
    )
