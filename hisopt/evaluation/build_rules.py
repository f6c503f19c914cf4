"""The evaluator's side of the buildability rules (docs/model.md §21): which outputs' road
integrals they read, and their usages from a batch of models and those integrals
(:mod:`hisopt.coupled.buildability` holds the physics)."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from hisopt.coupled.buildability import BUILD_USAGE, RULES, BuildLimits, RoadSwing, RuleValue, accumulator_ceilings, build_rules, overall_usage
from hisopt.coupled.response import STROKE_RATE_NAMES
from hisopt.hydraulics.coupling import HydraulicSystem
from hisopt.metrics import Metric

if TYPE_CHECKING:
    from hisopt.coupled.model import CoupledModel
    from hisopt.hydraulics.network import Network


def rule_names(metrics: list[Metric]) -> tuple[str, ...]:
    """The rules the buildability ``metrics`` need (every rule for ``build_usage``)."""
    names = {m.name for m in metrics if m.kind == "build"}
    return tuple(RULES) if BUILD_USAGE in names else tuple(r for r in RULES if r in names)


def road_outputs(network: Network, rules: tuple[str, ...]) -> list[str]:
    """The outputs whose band RMS the ``rules`` read: every port's pressure, every
    accumulator's oil volume and every strut's stroke rate (none without a road rule)."""
    if not any(RULES[r].needs_road for r in rules):
        return []
    ports = [f"port_pressure_{i}" for i in range(len(network.ports))]
    volumes = [f"oil_volume_{j}" for j in range(len(network.accumulators()))]
    return ports + volumes + list(STROKE_RATE_NAMES)


def road_swing(network: Network, rms: Callable[[str], np.ndarray]) -> RoadSwing:
    """The :class:`~hisopt.coupled.buildability.RoadSwing` from each output's band RMS ``rms(name)``."""

    def stack(names: list[str], n: int) -> np.ndarray:
        return np.stack([rms(name) for name in names], axis=-1) if names else np.zeros((n, 0))

    rates = np.stack([rms(name) for name in STROKE_RATE_NAMES], axis=-1)
    n = len(rates)
    return RoadSwing(
        stack([f"port_pressure_{i}" for i in range(len(network.ports))], n),
        stack([f"oil_volume_{j}" for j in range(len(network.accumulators()))], n),
        rates,
    )


def catalogue_rating(his: HydraulicSystem) -> np.ndarray:
    """[Pa gauge] Each accumulator's highest working pressure: ``[his] pressure_rating``
    times its precharge, at most ``max_working_pressure``
    (:func:`~hisopt.coupled.buildability.accumulator_ceilings`)."""
    params = his.params
    return accumulator_ceilings(his, params.get("pressure_rating", np.nan), params.get("max_working_pressure", np.inf))


def wheel_modes_of(model: CoupledModel) -> tuple[np.ndarray, np.ndarray]:
    """Each wheel's hop frequency [Hz] and damping ratio, ``(n, 4)`` each
    (:func:`hisopt.coupled.modal.wheel_modes`)."""
    from hisopt.coupled.modal import wheel_modes

    return wheel_modes(model)


def rule_values(model: CoupledModel, limits: BuildLimits, rules: tuple[str, ...], rms: Callable[[str], np.ndarray] | None) -> dict[str, RuleValue]:
    """Every rule of ``rules`` of a batch of models with HIS, the road's swing from ``rms``
    (None: no rule needs it)."""
    assert model.his is not None
    swing = road_swing(model.his.network, rms) if rms is not None else None
    return build_rules(model, limits, swing, catalogue_rating, wheel_modes_of, rules)


def usages(values: dict[str, RuleValue], n: int) -> dict[str, np.ndarray]:
    """The metrics' values: each rule's usage and ``build_usage``, the largest of them."""
    out = {name: np.broadcast_to(v.usage, (n,)) for name, v in values.items()}
    out[BUILD_USAGE] = np.broadcast_to(overall_usage(values), (n,)) if values else np.zeros(n)
    return out
