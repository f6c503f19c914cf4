"""``Problem``: what users load: a :class:`~hisopt.specification.design_space.DesignSpace` with its evaluator.

``hisopt.load_problem(path)`` gives one; ``problem.evaluate(designs)`` returns the
docs/model.md §8.1 DataFrame (objectives, constraints, ``feasible``, ``status``, ``reason``).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.arguments import of_type
from hisopt.evaluation.evaluate import Evaluator
from hisopt.evaluation.results_frame import results_frame
from hisopt.evaluation.robust_evaluator import RobustEvaluator, evaluator_for
from hisopt.evaluation.scenarios import ScenarioEvaluator
from hisopt.specification.config import parse_problem, read_problem_file
from hisopt.specification.design_space import DesignSpace
from hisopt.specification.validation import design_matrix, flag_summary

if TYPE_CHECKING:
    from hisopt.evaluation.parallel import Backend


class Problem(DesignSpace):
    """A design problem with its (cached) evaluator: vehicle, HIS, variables, road, objectives."""

    def evaluator(self) -> Evaluator | ScenarioEvaluator | RobustEvaluator:
        """The (cached) batched evaluator of this problem's objectives and constraints (a
        :class:`~hisopt.evaluation.scenarios.ScenarioEvaluator` for a problem with scenarios, a
        :class:`~hisopt.evaluation.robust_evaluator.RobustEvaluator` for one whose columns are
        statistics over ``[[uncertain]]`` samples)."""
        return evaluator_for(self)

    def model(self, designs: Any = None, his: bool = True, inputs: Any = None) -> Any:
        """The coupled model of :meth:`DesignSpace.model`; with physical damper valves whose RMS
        flows are solved (docs/model.md §3.3), each valve linearised at the fixed point on this
        problem's road (:func:`hisopt.evaluation.valve_flows.solve_valve_flows`) unless
        ``inputs`` give the flows. A design without a fixed point raises :class:`ModelError`."""
        from hisopt.errors import ModelError
        from hisopt.evaluation.valve_flows import solve_valve_flows, valve_flow_names_of
        from hisopt.hydraulics.network import solved_flow_name

        names = [solved_flow_name(k) for k, _, _ in self.network().solved_valves()]
        given = dict(inputs or {})
        if not his or not names or all(n in given for n in names):
            return super().model(designs, his, inputs)
        x = self.design_matrix(self.baseline if designs is None else designs)
        if "flow_evaluator" not in self._cache:
            self._cache["flow_evaluator"] = Evaluator(self, names=(), rms_outputs=valve_flow_names_of(self))
        flows, converged, _ = solve_valve_flows(self._cache["flow_evaluator"], x, {k: np.asarray(v) for k, v in given.items()})
        if not converged.all():
            row = int(np.flatnonzero(~converged)[0])
            raise ModelError(f"design {row}: the damper valves' RMS flows have no fixed point on this road (the model is unstable or singular there)")
        return super().model(x, his, given | flows)

    def results_frame(self, designs: Any, quantities: dict[str, np.ndarray]) -> pd.DataFrame:
        """Designs plus evaluated quantities as the docs/model.md §8.1 DataFrame."""
        return results_frame(self, designs, quantities)

    def evaluate(self, designs: Any, *, backend: Backend | None = None, source: str | None = None, log: bool = True) -> pd.DataFrame:
        """Objectives and constraints of many designs (docs/model.md §8.1).

        Every row is checked first (:func:`hisopt.specification.validation.check_designs`): an ``invalid`` row
        (not finite, or a parameter's rule broken) is not evaluated and gets NaN results; an
        ``out_of_bounds`` row is evaluated; neither is ever feasible. With flagged rows and
        ``log``, one warning line counting them goes to the ``hisopt`` logger.

        Parameters
        ----------
        designs : Any
            [variable units] any form :func:`hisopt.specification.validation.design_matrix` accepts
        backend : Backend | None, optional
            [-] a :class:`hisopt.evaluation.parallel.Backend` (Dask) or None for this process
        source : str | None, optional
            [-] where the designs come from (named in the messages)
        log : bool, optional
            [-] log the warning line (the CLI prints it itself)
        """
        from hisopt.evaluation.robust_evaluator import evaluate_designs

        x = design_matrix(self, designs, source)
        df = results_frame(self, x, evaluate_designs(self, x, backend))
        summary = flag_summary(df["status"], source)
        if summary and log:
            logging.getLogger("hisopt").warning(summary)
        return df


def load_problem(path: str | Path, *, warn_implausible: bool = True) -> Problem:
    """Load and validate a problem file (``ConfigError`` names the file and key on failure).

    An implausible value the file gives issues a :class:`~hisopt.errors.PlausibilityWarning`
    (:mod:`hisopt.plausibility`) unless ``warn_implausible`` is False (a run's own copy).
    """
    of_type(path, (str, os.PathLike), "path", "a problem file's path (str or Path)")
    spec, digest = read_problem_file(path, warn_implausible=warn_implausible)
    return Problem(spec, Path(path), digest)


def problem_from_dict(data: dict[str, Any], source: str = "<problem>", *, warn_implausible: bool = True) -> Problem:
    """Build a problem from a dictionary with the problem file's structure (``warn_implausible``:
    as :func:`hisopt.specification.config.parse_problem`; False for a dump of a checked problem with a change)."""
    of_type(data, Mapping, "data", "a dict with the problem file's structure")
    return Problem(parse_problem(data, source, warn_implausible=warn_implausible))
