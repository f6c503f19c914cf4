"""Where each physical damper valve works on a problem's road: its RMS flow and equivalent
resistance per design (docs/model.md §3.3), for the design sheet, the decision room and the
console."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hisopt.evaluation.evaluate import Evaluator
from hisopt.evaluation.valve_flows import FlowStart, solve_valve_flows, valve_flow_names_of
from hisopt.hydraulics.network import Network
from hisopt.specification.design_space import DesignSpace

VALIDATED_RESISTANCE = 2e9
"""[Pa s m^-3] The largest equivalent resistance at which the statistical linearisation is
validated: the time-domain agreement (the linearised frequency domain against the nonlinear
simulation over random ISO 8608 road realisations, docs/model.md §3.10,
tests/test_valve_agreement.py) finds the RMS valve flow, stroke, tyre load and sigma_aw within
10 % of it up to 2.2e9 on every road measured (within 5 % up to 5e9 on the city road; on the
valves problem's rough road 18 % on the flow and 11 % on the stroke at 4.8e9). A valve above
it is outside the linearisation's validated range (:func:`outside_validated_range`)."""
OUTSIDE_VALIDATED_RANGE = "outside the linearisation's validated range (gaps over 10 % against the nonlinear time domain)"
"""What hisopt says of a valve whose equivalent resistance exceeds :data:`VALIDATED_RESISTANCE`."""


@dataclass(frozen=True)
class ValveStates:
    """The damper valves of a batch of designs on one road.

    Attributes
    ----------
    labels : tuple[str, ...]
        [-] ``"<circuit>:<from>-><to>"`` of each damper valve, in element order
    flow_rms : np.ndarray
        [m^3/s] RMS flow through each valve over the band, ``(n, n_valves)``
    resistance : np.ndarray
        [Pa s m^-3] each valve's equivalent linear resistance there, ``(n, n_valves)``
    converged : np.ndarray
        [-] whether each design's fixed point converged (NaN rows where not), ``(n,)``
    inputs : dict[str, np.ndarray]
        [m^3/s] the solved RMS flows as model inputs
        (:func:`~hisopt.hydraulics.network.solved_flow_name`), each ``(n,)``: the model at the
        fixed point is ``space.model(designs, inputs=inputs)`` (empty when no flow is solved)
    """

    labels: tuple[str, ...]
    flow_rms: np.ndarray
    resistance: np.ndarray
    converged: np.ndarray
    inputs: dict[str, np.ndarray] = field(default_factory=dict)

    def outside(self) -> np.ndarray:
        """[-] Each valve of each design outside the validated range, ``(n, n_valves)``
        (:func:`outside_validated_range`)."""
        return outside_validated_range(self.resistance)


def outside_validated_range(resistance: Any) -> np.ndarray:
    """[-] Whether each equivalent resistance [Pa s m^-3] exceeds :data:`VALIDATED_RESISTANCE`
    (NaN, a design without a fixed point, is not: it has no resistance to judge)."""
    with np.errstate(invalid="ignore"):
        return np.asarray(resistance, dtype=float) > VALIDATED_RESISTANCE


def valve_labels(network: Network) -> tuple[str, ...]:
    """[-] ``"<circuit>:<from>-><to>"`` of each damper valve of ``network``, in element order."""
    names = [c.name for c in network.layout.circuits]
    return tuple(f"{names[network.elements[k][0]]}:{e.a}->{e.b}" for k, e, _ in network.damper_valves())


def valve_states(space: DesignSpace, designs: Any) -> ValveStates:
    """Each damper valve's RMS flow and equivalent resistance for ``designs`` on ``space``'s road
    (a load case's: :meth:`~hisopt.specification.design_space.DesignSpace.scenario_space`):
    solved as the evaluator solves them (:func:`~hisopt.evaluation.valve_flows.solve_valve_flows`),
    or at the given ``flow_rms``. A problem without damper valves gives empty tables."""
    x = space.design_matrix(designs)
    network = space.network()
    labels = valve_labels(network)
    n = len(x)
    if not labels:
        return ValveStates(labels, np.zeros((n, 0)), np.zeros((n, 0)), np.ones(n, dtype=bool))
    flows: dict[str, np.ndarray] = {}
    converged = np.ones(n, dtype=bool)
    if network.solved_valves():
        evaluator = Evaluator(space, names=(), rms_outputs=valve_flow_names_of(space))
        start = FlowStart(evaluator)(x, len(network.solved_valves())) if len(x) > 64 else None  # a fit pays off on many designs
        flows, converged, _ = solve_valve_flows(evaluator, x, {}, start)
    flow = np.full((n, len(labels)), np.nan)
    resistance = np.full((n, len(labels)), np.nan)
    if converged.any():
        rows = np.flatnonzero(converged)
        model = space.model(x[rows], inputs={k: v[rows] for k, v in flows.items()})
        his = model.his
        assert his is not None
        flowing = [k for k, _, _ in network.flow_valves()]
        outputs = [f"valve_flow_{flowing.index(k)}" for k, _, _ in network.damper_valves()]
        measured = Evaluator(space, names=(), rms_outputs=outputs)
        for group_rows, group in model.groups():
            flow[rows[group_rows]] = measured.output_rms(group, outputs)
        for j, (k, _, _) in enumerate(network.damper_valves()):
            resistance[rows, j] = np.broadcast_to(np.asarray(his.values.resistance[k], dtype=float), (len(rows),))
    return ValveStates(labels, flow, resistance, converged, flows)
