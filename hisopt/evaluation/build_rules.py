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
from hisopt.hydraulics.network import resolve
from hisopt.metrics import Metric

if TYPE_CHECKING:
    from hisopt.coupled.model import CoupledModel
    from hisopt.hydraulics.network import Network
    from hisopt.specification.design_space import DesignSpace


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


def catalogue_rating(space: DesignSpace) -> Callable[[HydraulicSystem], np.ndarray]:
    """[Pa gauge] Each accumulator's highest working pressure, as ``space`` rates it: the part
    you would buy for its volume from the problem's accumulator catalogue (its ratio times the
    precharge, at most its size's maximum working pressure; ``[his] separator``,
    ``pressure_rating`` and ``max_working_pressure`` override, docs/model.md §16.8), via
    :func:`~hisopt.coupled.buildability.accumulator_ceilings`."""
    from pathlib import Path

    from hisopt.hydraulics.parts_catalogue import his_accumulator_rating
    from hisopt.specification.catalogues import catalogue_accumulator_ratings

    spec = space.spec
    v0 = spec.variables.get("V0")
    path = space.path
    base = Path(path).parent if path is not None else None
    ratings = catalogue_accumulator_ratings(v0.catalogue if v0 is not None else None, base)

    def rating(his: HydraulicSystem) -> np.ndarray:
        volumes = [np.broadcast_to(np.asarray(resolve(e.volume, his.params), dtype=float), his.batch_shape) for _, e, _ in his.network.accumulators()]
        if not volumes:
            return np.zeros(his.batch_shape + (0,))
        ratio, pressure = his_accumulator_rating(spec.his, np.stack(volumes, axis=-1), ratings)
        return accumulator_ceilings(his, ratio, pressure)

    return rating


def wheel_modes_of(model: CoupledModel) -> tuple[np.ndarray, np.ndarray]:
    """Each wheel's hop frequency [Hz] and damping ratio, ``(n, 4)`` each
    (:func:`hisopt.coupled.modal.wheel_modes`)."""
    from hisopt.coupled.modal import wheel_modes

    return wheel_modes(model)


def rule_values(
    model: CoupledModel, limits: BuildLimits, rules: tuple[str, ...], rms: Callable[[str], np.ndarray] | None, rating: Callable[[HydraulicSystem], np.ndarray]
) -> dict[str, RuleValue]:
    """Every rule of ``rules`` of a batch of models with HIS, the road's swing from ``rms``
    (None: no rule needs it), the accumulators' ratings from ``rating`` (:func:`catalogue_rating`)."""
    assert model.his is not None
    swing = road_swing(model.his.network, rms) if rms is not None else None
    return build_rules(model, limits, swing, rating, wheel_modes_of, rules)


def usages(values: dict[str, RuleValue], n: int) -> dict[str, np.ndarray]:
    """The metrics' values: each rule's usage and ``build_usage``, the largest of them."""
    out = {name: np.broadcast_to(v.usage, (n,)) for name, v in values.items()}
    out[BUILD_USAGE] = np.broadcast_to(overall_usage(values), (n,)) if values else np.zeros(n)
    return out


class RuleQuantities:
    """The buildability metrics of one load case's evaluator: which rules, which outputs'
    integrals they read, and their values from a batch of models (the ``build`` callback of
    :func:`~hisopt.evaluation.psd.reduce_metrics`)."""

    def __init__(self, space: DesignSpace, metrics: list[Metric]):
        self.space = space
        self.rules = rule_names(metrics)
        self.limits = space.spec.build_limits
        self.outputs = road_outputs(space.network(), self.rules) if self.rules else []
        """Outputs whose band RMS the rules read (the chambers' and accumulators' pressures, the strokes' rates)."""
        self._rating: Callable[[HydraulicSystem], np.ndarray] | None = None

    def of(self, model: CoupledModel, n: int, integral: Callable[[str, str | None], np.ndarray]) -> Callable[[str], np.ndarray]:
        """``build(name)`` for the ``n`` models of ``model``: every rule computed once, on
        the first quantity asked for, from the evaluator's band ``integral``."""
        done: dict[str, np.ndarray] = {}

        def build(name: str) -> np.ndarray:
            if model.his is None:
                return np.full(n, np.nan)
            if not done:
                if self._rating is None:
                    self._rating = catalogue_rating(self.space)
                rms = (lambda o: np.sqrt(np.maximum(integral(o, None), 0.0))) if self.outputs else None
                done.update(usages(rule_values(model, self.limits, self.rules, rms, self._rating), n))
            return done[name]

        return build
