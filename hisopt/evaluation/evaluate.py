"""Batched, exact evaluation of objectives and constraints (docs/model.md §6 and §10).

Fast path (lumped circuits): one eigendecomposition of the state-space matrix per design gives
the poles and residues, so the FRF at any frequency is a small matrix product
``H(s) = sum_k R_k / (s - lambda_k)``; the poles also place the quadrature panels
(:mod:`hisopt.evaluation.quadrature`) and bracket each PSD peak, which is then refined off the grid by
repeated zooming. Distributed pipes use the same nodes (from the lumped poles, repaired like
the lumped path's where their eigenvectors are ill-conditioned) with a direct batched solve of
the transfer-matrix model. Each design's pole-residue form is checked
against a direct solve; designs that are unstable or singular give NaN, never an exception.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from hisopt.arguments import integer, of_type, problem_argument
from hisopt.coupled.operating_point import accumulator_quantities, accumulator_rooms
from hisopt.coupled.response import Output, accumulator_outputs, port_pressure_outputs, standard_outputs, stroke_rate_outputs, valve_flow_outputs
from hisopt.errors import ModelError
from hisopt.evaluation import psd as psd_kernels
from hisopt.evaluation.build_rules import RuleQuantities
from hisopt.evaluation.channels import (
    Channels,
    DirectOutputs,
    Pair,
    RoadCase,
    channel_feedthrough,
    frf_power,
    repair_poles,
    road_channels,
)
from hisopt.evaluation.integrals import derived_psd, integral_keys, padded_polynomials, share_outputs
from hisopt.evaluation.peaks import refine_maximum
from hisopt.evaluation.psd import comfort_gain_squared, reduce_metrics
from hisopt.evaluation.quadrature import (
    MAX_PANELS,
    POLE_MARGIN,
    design_rho,
    gauss_legendre,
    panel_nodes,
    panels,
    peak_samples,
    ripple_splits,
    singularities,
    split_nodes,
)
from hisopt.evaluation.transient import transient_quantities
from hisopt.evaluation.valve_flows import (
    FLOW_TOLERANCE,
    FlowStart,
    first_steps,
    flow_residual,
    secant_step,
    solve_valve_flows,
    valve_flow_names_of,
)
from hisopt.hydraulics.network import solved_flow_name
from hisopt.linalg import one_blas_thread
from hisopt.metrics import COMFORT_OUTPUTS, METRICS
from hisopt.road.spectra import isotropic_coherence
from hisopt.specification.validation import admissible
from hisopt.standards import iso_2631_1_1997 as iso2631
from hisopt.standards.iso_8608_2016 import class_gd_n0, temporal_power_law, temporal_psd

if TYPE_CHECKING:
    from hisopt.coupled.model import CoupledModel
    from hisopt.specification.design_space import DesignSpace, Inputs


BEYOND_RATING = frozenset(m.name for m in METRICS.values() if not m.objective or m.kind == "build")
"""Quantities whose +inf is a value, not a failure: a ratio over a rating of zero (an
accumulator without gauge precharge is rated for nothing, docs/model.md §16.8, §21.2), which no
constraint admits."""

MEASURED = "measured:"
"""Prefix of an evaluation's band RMS of an output among :attr:`Evaluator.rms_outputs` (the
damper valves' flows a design was evaluated at), dropped before :meth:`Evaluator.shared` returns."""


def _rows(given: Inputs, rows: np.ndarray) -> dict[str, np.ndarray]:
    return {k: v[rows] for k, v in given.items()}


def _flows(names: list[str], y: np.ndarray) -> dict[str, np.ndarray]:
    """The solved valves' RMS flows [m^3/s] as model inputs, from their logs ``(n, n_valves)``."""
    return {name: np.exp(y[:, j]) for j, name in enumerate(names)}


class Evaluator:
    """Objective/constraint evaluator of one problem, reusable across many calls.

    Parameters
    ----------
    problem : DesignSpace
        the problem (vehicle, HIS, road, band, comfort, objectives, constraints); of a
        problem with ``[[scenarios]]``, its ``[road]`` without a scenario's payload, each
        objective and constrained quantity under its plain name
        (:class:`~hisopt.evaluation.scenarios.ScenarioEvaluator` evaluates the load cases)
    chunk_size : int, optional
        designs per vectorised batch (bounds memory for any number of designs)
    order : int, optional
        Gauss-Legendre nodes per panel
    peak_steps : int, optional
        new samples of each PSD maximum (:func:`hisopt.evaluation.peaks.refine_maximum`)
    base_panels
        log- and linearly spaced panels over the band (each)
    pole_ratio
        growth of the panel breakpoints' distance from each resonance

    Notes
    -----
    The defaults keep every quantity within 1e-3 of a converged reference over the whole
    design box (tests check 0.5 %); ``benchmarks/bench_evaluate.py`` prints the errors.
    """

    def __init__(
        self,
        problem: DesignSpace,
        chunk_size: int = 256,
        order: int = 4,
        peak_steps: int = 2,
        tolerance: float = 1e-4,
        names: Sequence[str] | None = None,
        rms_outputs: Sequence[str] = (),
    ):
        problem_argument(problem)
        chunk_size = integer(chunk_size, "chunk_size", minimum=1)
        spec = problem.spec
        _prime_allocator()
        self.problem = problem
        self.chunk_size = chunk_size
        self.order = order
        self.peak_steps = peak_steps
        # The plain quantities, not problem.objective_names: on a problem with [[scenarios]] this
        # evaluator is its default load case (its [road], no scenario payload; as modes and
        # sweeps), whose quantities are never "<quantity>@<scenario>" columns (per_scenario).
        self.names = tuple(dict.fromkeys(spec.objectives + [c.name for c in spec.constraints])) if names is None else tuple(names)
        self.metrics = [METRICS[n] for n in self.names]
        network = problem.network()
        self.n_accumulators = len(network.accumulators())
        self.all_outputs = (
            standard_outputs(problem.vehicle)
            | accumulator_outputs(self.n_accumulators)
            | valve_flow_outputs(self.n_accumulators, len(network.flow_valves()))
            | port_pressure_outputs(self.n_accumulators, len(network.flow_valves()), len(network.ports))
            | stroke_rate_outputs(problem.vehicle)
        )
        self.build = RuleQuantities(problem, self.metrics)
        """The buildability rules the metrics need (docs/model.md §21)."""
        self.build_outputs = self.build.outputs
        solved = bool(network.solved_valves()) and names is None  # this load case's evaluator: it measures the flows it is built at
        self.rms_outputs = tuple(rms_outputs) or (tuple(valve_flow_names_of(problem)) if solved else ())
        """Outputs whose band RMS this evaluator integrates besides the metrics' (the valves'
        flows): :meth:`output_rms`, and each evaluation's ``"measured:<output>"`` columns."""
        self.columns = self.names + tuple(MEASURED + o for o in self.rms_outputs)
        wanted: list[str] = list(self.rms_outputs) + self.build_outputs
        for m in self.metrics:
            if m.kind == "comfort":
                wanted += list(COMFORT_OUTPUTS.values())
            elif m.kind == "swing":
                wanted += list(accumulator_outputs(self.n_accumulators))
            elif m.output is not None:
                wanted.append(m.output)
        self._flow_evaluator: Evaluator | None = None
        self._start: FlowStart | None = None
        if solved:  # the damper valves' RMS flows, solved on this road
            self._flow_evaluator = Evaluator(problem, chunk_size, order, peak_steps, tolerance, names=(), rms_outputs=self.rms_outputs)
        wanted = wanted or ["roll"]  # the poles need one output (a problem of static/transient quantities only)
        self.outputs: dict[str, Output] = {n: self.all_outputs[n] for n in dict.fromkeys(wanted)}
        self.output_index = {name: i for i, name in enumerate(self.outputs)}
        self.bases, self.derived = share_outputs(self.outputs)
        self.base_index = {name: i for i, name in enumerate(self.bases)}
        self._feed = channel_feedthrough(list(self.bases.values()))
        self.f_lo, self.f_hi = spec.band.f_min_hz, spec.band.f_max_hz
        self.gd_n0 = class_gd_n0(spec.road.road_class)
        self.speed = spec.road.speed
        self.tau = problem.vehicle.wheelbase / self.speed
        self.road = temporal_power_law(self.gd_n0, self.speed)  # G(f) = G_1 f^-w
        self.tolerance = tolerance
        self.unread: frozenset[str] = frozenset()
        """Transient quantities left NaN (and out of the validity check) because no one reads
        them: set by :class:`~hisopt.evaluation.scenarios.ScenarioEvaluator` for a load case
        whose model serves only scenarios where they are not asked for."""
        self.forced_edges = np.empty(0)  # [Hz] breakpoints every design's panels keep
        if spec.comfort.method == "band":  # the band method's weighting steps at the band edges
            bands = iso2631.third_octave_bands(self.f_lo, self.f_hi)
            self.forced_edges = np.r_[bands.lower_hz, bands.upper_hz]
        weightings = sorted({wt for o in self.outputs.values() if (wt := o.weighting)})
        fixed = np.r_[0.0, *(iso2631.weighting_poles_hz(wt) for wt in weightings)]  # type: ignore[arg-type]
        self.fixed_singularities = np.unique(np.round(fixed.real, 12) + 1j * np.round(np.abs(fixed.imag), 12))
        forced = np.unique(self.forced_edges)
        self._forced = forced[(forced > self.f_lo) & (forced < self.f_hi)]
        self.integrals = integral_keys(self.metrics, spec.comfort, self.outputs, self.n_accumulators)
        self.integrals += [(o, None) for o in (*self.rms_outputs, *self.build_outputs) if (o, None) not in self.integrals]
        self.weightings = sorted({wt for _, wt in self.integrals if wt})
        self._gain_polynomials = padded_polynomials(self.weightings if spec.comfort.method == "filter" else [])
        derived = [self.derived[output] for output, _ in self.integrals]
        self._sums = (  # the integrals for hisopt.evaluation.kernels.weighted_sums
            np.array([self.base_index[b] for b, _, _ in derived], dtype=np.int64),
            np.array([p for _, _, p in derived], dtype=np.int64),
            np.array([sc**2 for _, sc, _ in derived]),
            np.array([self.weightings.index(wt) if wt else -1 for _, wt in self.integrals], dtype=np.int64),
        )

    # --- public ------------------------------------------------------------------------
    def __call__(self, designs: Any, inputs: Inputs | None = None) -> dict[str, np.ndarray]:
        """Quantities by name, each shape ``(n,)``, plus ``"valid"`` (finite, stable model);
        ``inputs``: model inputs per design, as :meth:`~hisopt.specification.design_space.DesignSpace.model` takes them."""
        return self.shared(designs, [self], inputs)[0]

    def shared(self, designs: Any, evaluators: list[Evaluator], inputs: Inputs | None = None) -> list[dict[str, np.ndarray]]:
        """``[ev(designs) for ev in evaluators]`` with this evaluator's models, poles and
        residues computed once for all of them: ``evaluators`` are of problems that differ
        from this one only in the road (class, speed, coherence), load cases sharing a model
        (docs/model.md §14.4). ``inputs``: model inputs per design (``(n,)`` arrays, checked
        by the caller), as :meth:`~hisopt.specification.design_space.DesignSpace.model` takes them."""
        x = self.problem.design_matrix(designs)
        given = dict(inputs or {})
        with one_blas_thread():
            if self._flow_evaluator is not None and not all(k in given for k in self._flow_names):
                results = self._solving_flows(x, evaluators, given)
            else:
                results = self._evaluate(x, evaluators, given)
        return [{k: v for k, v in r.items() if not k.startswith(MEASURED)} for r in results]

    def _evaluate(self, x: np.ndarray, evaluators: list[Evaluator], given: Inputs) -> list[dict[str, np.ndarray]]:
        """:meth:`shared`'s work, chunk by chunk, with the measured valve flows (``rms_outputs``) kept."""
        results = [
            self._chunk(x[i : i + self.chunk_size], evaluators, {k: v[i : i + self.chunk_size] for k, v in given.items()})
            for i in range(0, max(len(x), 1), self.chunk_size)
        ]
        return [{k: np.concatenate([r[j][k] for r in results]) for k in results[0][j]} for j in range(len(evaluators))]

    def _solving_flows(self, x: np.ndarray, evaluators: list[Evaluator], given: Inputs) -> list[dict[str, np.ndarray]]:
        """:meth:`_evaluate` with the damper valves' RMS flows solved on this road (docs/model.md
        §3.3): :func:`~hisopt.evaluation.valve_flows.first_steps` for the whole batch, then the
        evaluation, which measures each design's flows; a design whose residual is above
        :data:`~hisopt.evaluation.valve_flows.FLOW_TOLERANCE` is solved on and evaluated again,
        and fails if it still is (no fixed point)."""
        assert self._flow_evaluator is not None and evaluators == [self]  # load cases with solved valves share no model
        names, measured = self._flow_names, [MEASURED + o for o in self.rms_outputs]
        valid = admissible(self.problem, x)
        y = np.full((len(x), len(names)), np.nan)
        rows = np.flatnonzero(valid)
        start = self._flow_start(x)
        last = (np.full(y[rows].shape, np.nan), np.full(y[rows].shape, np.nan))
        if len(rows):
            y[rows], last = first_steps(self._flow_evaluator, x[rows], _rows(given, rows), (start[0][rows], start[1][rows]))
        (result,) = self._evaluate(x, evaluators, dict(given) | _flows(names, y))
        g = np.log(np.column_stack([result[k] for k in measured]))
        residual = flow_residual(y, np.exp(g))
        for again in (True, False):  # a free secant step from the evaluation's own flows; then the fixed point to the end
            rows = np.flatnonzero(valid & ~(residual <= FLOW_TOLERANCE) & np.all(np.isfinite(y), axis=1) & np.all(np.isfinite(g), axis=1))
            if again and len(rows):
                mine = np.searchsorted(np.flatnonzero(valid), rows)
                y[rows] = secant_step(y[rows], g[rows], (last[0][mine], last[1][mine]), start[1][rows])
            else:
                rows = np.flatnonzero(valid & ~(residual <= FLOW_TOLERANCE))
                if not len(rows):
                    break
                guess = np.where(np.isfinite(y[rows]), y[rows], start[0][rows])
                flows, _, _ = solve_valve_flows(self._flow_evaluator, x[rows], _rows(given, rows), (guess, start[1][rows]))
                y[rows] = np.log(np.column_stack([flows[k] for k in names]))
            if not len(rows):
                continue
            (redone,) = self._evaluate(x[rows], evaluators, _rows(given, rows) | _flows(names, y[rows]))
            g[rows] = np.log(np.column_stack([redone[k] for k in measured]))
            residual[rows] = flow_residual(y[rows], np.exp(g[rows]))
            for k, v in redone.items():
                result[k][rows] = v
        failed = valid & ~(residual <= FLOW_TOLERANCE)  # no fixed point: the design fails (failure_reason)
        result = {k: np.where(failed, np.nan, v) if k != "valid" else v & ~failed for k, v in result.items()}
        return [result]

    # --- internals -----------------------------------------------------------------------
    def _chunk(self, x: np.ndarray, evaluators: list[Evaluator], inputs: Inputs) -> list[dict[str, np.ndarray]]:
        n = len(x)
        outs = [{name: np.full(n, np.nan) for name in ev.columns} for ev in evaluators]
        valid = admissible(self.problem, x)  # finite and within every parameter's rule
        if not valid.any():
            return [out | {"valid": valid} for out in outs]
        idx = np.flatnonzero(valid)
        with np.errstate(all="ignore"):
            given = {k: v[valid] for k, v in inputs.items()}
            if self._flow_evaluator is not None:  # a design without a fixed point fails (failure_reason)
                converged = np.all([np.isfinite(given[k]) for k in self._flow_names], axis=0)
                given = {k: v[converged] for k, v in given.items()}
                valid[idx[~converged]] = False
                idx = idx[converged]
        oks = [valid.copy() for _ in evaluators]
        if not valid.any():
            return [out | {"valid": valid} for out in outs]
        with np.errstate(all="ignore"):
            for rows, model in self.problem.model(x[valid], inputs=given).groups():
                try:
                    solved = self._solve(model, evaluators)
                except (np.linalg.LinAlgError, ModelError):
                    solved = self._one_by_one(x[valid][rows], evaluators, {k: v[rows] for k, v in given.items()})
                for out, ok_all, ev, (values, ok) in zip(outs, oks, evaluators, solved, strict=True):
                    for name in ev.columns:
                        out[name][idx[rows]] = np.where(ok, values[name], np.nan)
                    ok_all[idx[rows]] = ok
        return [out | {"valid": ok} for out, ok in zip(outs, oks, strict=True)]

    def _flow_start(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The fixed point's first guess for designs ``x`` (:class:`~hisopt.evaluation.valve_flows.FlowStart`,
        fitted on this load case once)."""
        assert self._flow_evaluator is not None
        if self._start is None:
            self._start = FlowStart(self._flow_evaluator)
        return self._start(x, len(self._flow_names))

    @property
    def _flow_names(self) -> list[str]:
        return [solved_flow_name(k) for k, _, _ in self.problem.network().solved_valves()]

    def output_rms(self, model: CoupledModel, outputs: Sequence[str]) -> np.ndarray:
        """Band RMS ``(n, len(outputs))`` on this evaluator's road of outputs among its
        :attr:`rms_outputs`, for a batch of models sharing one state space (NaN where a
        design's model is unstable or its poles are not trusted)."""
        lam, channels, repaired = self._channels(model)
        scale = np.abs(lam).max(axis=1)
        stable = np.all(lam.real <= 1e-9 * scale[:, None], axis=1) & np.all(np.isfinite(lam), axis=1) & repaired
        totals = self._sample(lam, channels).totals
        cols = [self.integrals.index((o, None)) for o in outputs]
        return np.where(stable[:, None], np.sqrt(np.maximum(totals[:, cols], 0.0)), np.nan)

    def _one_by_one(self, x: np.ndarray, evaluators: list[Evaluator], inputs: Inputs) -> list[tuple[dict[str, np.ndarray], np.ndarray]]:
        out = [({name: np.full(len(x), np.nan) for name in ev.columns}, np.zeros(len(x), dtype=bool)) for ev in evaluators]
        for i, row in enumerate(x):
            try:
                ((_, model),) = self.problem.model(row[None, :], inputs={k: v[i : i + 1] for k, v in inputs.items()}).groups()
                solved = self._solve(model, evaluators)
            except (np.linalg.LinAlgError, ValueError):
                continue
            for (values, ok), (v, good), ev in zip(out, solved, evaluators, strict=True):
                for name in ev.columns:
                    values[name][i] = v[name][0]
                ok[i] = good[0]
        return out

    def _solve(self, model: CoupledModel, evaluators: list[Evaluator]) -> list[tuple[dict[str, np.ndarray], np.ndarray]]:
        lam, channels, repaired = self._channels(model)
        scale = np.abs(lam).max(axis=1)
        stable = np.all(lam.real <= 1e-9 * scale[:, None], axis=1) & np.all(np.isfinite(lam), axis=1) & repaired
        shared = self._shared_samples(lam, channels, evaluators) if len(evaluators) > 1 else [None]
        steps = self._transient(model, len(lam))  # of the model alone: once for all the roads
        out = []
        for ev, prior in zip(evaluators, shared, strict=True):
            values = ev.quantities(lam, channels, model, prior, steps)
            finite = [np.isfinite(v) | ((v == np.inf) & (k in BEYOND_RATING)) for k, v in values.items() if k not in self.unread]
            out.append((values, stable & np.all(finite, axis=0)))
        return out

    def _transient(self, model: CoupledModel, n: int) -> dict[str, np.ndarray]:
        """The transient roll quantities asked for (docs/model.md §6.6) of ``n`` designs,
        which depend on the model and ``[handling]``, not on the road; NaN for those in
        :attr:`unread`."""
        names = [m.name for m in self.metrics if m.kind == "transient"]
        wanted = [name for name in names if name not in self.unread]
        handling = self.problem.spec.handling
        steps = transient_quantities(model, model.car, wanted, handling.step_g, handling.gravity_moment) if wanted else {}
        return steps | {name: np.full(n, np.nan) for name in names if name in self.unread}

    def _shared_samples(self, lam: np.ndarray, channels: Channels, evaluators: list[Evaluator]) -> list[Prior]:
        """The pole-aware nodes, laid once, and every evaluator's road PSDs there from one pass
        over the FRFs (the nodes depend on the poles and the band, not on the road)."""
        edges, f, w, f_peak = self._lay(lam)
        f_all = np.concatenate([f, f_peak], axis=1)
        roads = [RoadCase(ev.tau, ev.coherence(f_all), ev.road) for ev in evaluators]
        both = channels.powers(f_all, roads)
        order = np.argsort(f_all, axis=1, kind="stable")  # the peak search's sorted samples, for all roads
        bases = self._peak_bases()
        flat = (order + f_all.shape[1] * np.arange(len(order))[:, None]).ravel()  # one gather for all roads
        # the row length spelled out: a problem without PSD maxima has no bases (reshape cannot infer -1 from 0 rows)
        rows = both[:, bases].reshape(len(roads) * len(bases), order.size)
        values = np.take(rows, flat, axis=1).reshape(len(roads), len(bases), *order.shape)
        peaks = (np.take_along_axis(f_all, order, 1), values)
        return [Prior(edges, f, w, f_peak, both[r], (peaks[0], peaks[1][r])) for r in range(len(evaluators))]

    def _peak_bases(self) -> list[int]:
        """The base output of each PSD maximum, in metric order."""
        return [self.base_index[self.derived[m.signal][0]] for m in self.metrics if m.kind == "max"]

    def _channels(self, model: CoupledModel) -> tuple[np.ndarray, Channels, np.ndarray]:
        """Poles ``(n, k)`` [rad/s], the road channels' responses, and whether each design's
        poles are trusted (after :func:`repair_poles` where the eigenvectors are ill-conditioned)."""
        lam, channels, flagged = road_channels(model, self.bases, self._feed)
        repaired = np.ones(len(lam), dtype=bool)
        if np.any(flagged):  # nodes at such poles would miss the peaks: Newton's method on det K_dyn
            lam = lam.copy()
            lam[flagged], repaired[flagged] = repair_poles(model.subset(flagged), lam[flagged], self.f_hi)
        return lam, channels, repaired

    def nodes(self, lam: np.ndarray, model: CoupledModel | None = None) -> tuple[np.ndarray, np.ndarray]:
        """[Hz] Quadrature nodes and weights per design, sorted (docs/model.md §10.3): the
        panels the poles ``lam`` [rad/s] call for, split where ``model``'s response needs it
        for the delay ripple (without a model, as laid before any response is known), and
        the maxima's extra samples (band limits, damped frequencies) with weight 0."""
        if model is None:
            f, w = panel_nodes(self._panels(lam), self.order)
            f_peak = peak_samples(lam, self.f_lo, self.f_hi)
            f, w = np.concatenate([f, f_peak], axis=1), np.concatenate([w, np.zeros_like(f_peak)], axis=1)
        else:
            s = self._sample(lam, DirectOutputs(model, self.bases))
            f = np.concatenate([s.f, s.f_split, s.f_peak], axis=1)
            w = np.concatenate([s.w, s.w_split, np.zeros_like(s.f_peak)], axis=1)
        order = np.argsort(f, axis=1, kind="stable")
        return np.take_along_axis(f, order, 1), np.take_along_axis(w, order, 1)

    def _lay(self, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Panels ``(n, P + 1)``, their nodes and weights ``(n, F)`` and the peak samples: the
        steps of :meth:`_panels`, :func:`~hisopt.evaluation.quadrature.panel_nodes` and
        :func:`~hisopt.evaluation.quadrature.peak_samples`, compiled together."""
        from hisopt.evaluation.kernels import lay_nodes

        rho = design_rho(self.order, self.tolerance / POLE_MARGIN)
        x, w = gauss_legendre(self.order)
        return lay_nodes(
            np.ascontiguousarray(lam, dtype=complex),
            self.fixed_singularities.astype(complex),
            self._forced,
            self.f_lo,
            self.f_hi,
            0.5 * (rho + 1.0 / rho),
            x,
            w,
            MAX_PANELS,
        )

    def _panels(self, lam: np.ndarray) -> np.ndarray:
        sing = singularities(lam, self.fixed_singularities)
        return panels(self.f_lo, self.f_hi, self.forced_edges, sing, self.order, self.tolerance)

    def _sample(self, lam: np.ndarray, source: Channels, prior: Prior | None = None) -> Samples:
        """The PSDs at the pole-aware panels' nodes, at the nodes of the panels split for the
        delay ripple (where its bound times the panel's share of an integral exceeds the
        tolerance) and at the peak samples (``prior``: the first and last already known,
        :meth:`_shared_samples`)."""
        if prior is None:
            edges, f, w, f_peak = self._lay(lam)
            both = self.psd(np.concatenate([f, f_peak], axis=1), source)
        else:
            edges, f, w, f_peak, both = prior.edges, prior.f, prior.w, prior.f_peak, prior.psd_all
        n_panels = edges.shape[1] - 1
        psd = both[:, :, : f.shape[1]]
        totals, panel_abs, panel_sum = self._sums_at(f, w, psd, n_panels)
        share = np.max(panel_abs / np.where(totals != 0, np.abs(totals), np.inf)[:, None, :], axis=2, initial=0.0)
        top = np.nanmax(edges, axis=1, keepdims=True)
        e = np.where(np.isfinite(edges), edges, top)
        parts = ripple_splits(0.5 * (e[:, 1:] - e[:, :-1]), share, self.tau, self.order, self.tolerance)
        f_split, w_split = split_nodes(e, parts)
        if f_split.shape[1]:
            psd_split = self.psd(f_split, source)
            # The split panels' sums are replaced by their parts' (summed in panel order).
            kept = np.cumsum(np.where((parts > 0)[..., None], 0.0, panel_sum), axis=1)[:, -1]
            totals = kept + self._sums_at(f_split, w_split, psd_split, 0)[0]
        else:
            psd_split = np.zeros((len(self.bases),) + f_split.shape)
        w = np.where(np.repeat(parts > 0, self.order, axis=1), 0.0, w)  # the split panels' nodes stay as samples
        return Samples(f, w, psd, totals, f_split, w_split, psd_split, f_peak, both)

    def _sums_at(self, f: np.ndarray, w: np.ndarray, psd: np.ndarray, n_panels: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every integral's quadrature sum at nodes ``f`` (n, F) with weights ``w``, and per
        panel (the first ``n_panels`` groups of ``order`` nodes) its sums of ``|w g|``, ``w g``
        (:func:`hisopt.evaluation.kernels.weighted_sums`)."""
        from hisopt.evaluation.kernels import weighted_sums

        n, r = len(f), len(self.integrals)
        spec = self.problem.spec
        num, den = self._gain_polynomials
        if num.shape[0] or not self.weightings:
            gains = np.empty((0, 0, 0))
        else:  # the band method's steps: tabulated at the nodes
            gains = np.stack([comfort_gain_squared(f, wt, spec.comfort, self.f_lo, self.f_hi) for wt in self.weightings])
        totals, panel_abs, panel_sum = np.empty((n, r)), np.empty((n, n_panels, r)), np.empty((n, n_panels, r))
        weighted_sums(
            np.ascontiguousarray(f), np.ascontiguousarray(w), np.ascontiguousarray(psd), gains, num, den, *self._sums, self.order, totals, panel_abs, panel_sum
        )
        return totals, panel_abs, panel_sum

    def coherence(self, f_hz: np.ndarray) -> np.ndarray | None:
        """[-] Left-right coherence of the road's tracks at ``f_hz`` (None: independent)."""
        if self.problem.spec.road.coherence != "isotropic":
            return None
        v = self.problem.vehicle
        return isotropic_coherence(f_hz / self.speed, v.t_f + v.t_r)

    def spectra(self, f_hz: np.ndarray, channels: dict[str, Pair]) -> np.ndarray:
        """One-sided PSDs of the outputs at ``f_hz`` (n, F) from their road channels' FRFs
        (``"sym"``, ``"anti"``: (real, imag) parts, each (n, F, 2 axles, n_out)).

        Returns shape ``(n, F, n_out)`` (paper Eq. 24, :func:`hisopt.evaluation.psd.channel_power`).
        """
        power = frf_power(channels, f_hz, self.tau, self.coherence(f_hz))
        return temporal_psd(f_hz, self.gd_n0, self.speed)[..., None] * power

    def psd(self, f_hz: np.ndarray, source: Channels, output_of: np.ndarray | None = None) -> np.ndarray:
        """One-sided PSDs ``(n_out, n, F)`` of the outputs of ``source`` at ``f_hz`` (n, F)
        (``output_of``: per column, the one output needed there, or -1 for all)."""
        return source.power(f_hz, self.tau, self.coherence(f_hz), output_of, self.road)

    def quantities(
        self, lam: np.ndarray, frf: Channels, model: CoupledModel, prior: Prior | None = None, steps: dict[str, np.ndarray] | None = None
    ) -> dict[str, np.ndarray]:
        """All requested metrics from poles (for the nodes) and the road channels' FRFs
        (``prior``: what load cases sharing the model share; ``steps``: the transient
        quantities, computed here if not given)."""
        s = self._sample(lam, frf, prior)
        column = {key: r for r, key in enumerate(self.integrals)}

        def integral(output: str, weighting: str | None) -> np.ndarray:
            return s.totals[:, column[(output, weighting)]]

        peaks = [m.signal for m in self.metrics if m.kind == "max"]
        maxima: dict[str, np.ndarray] = {}
        if peaks and prior is not None:  # searched on the panels' nodes and the peak samples, sorted
            f, values = prior.sorted_peaks
        elif peaks:
            f = np.concatenate([s.f, s.f_peak], axis=1)
            order = np.argsort(f, axis=1, kind="stable")
            f = np.take_along_axis(f, order, 1)
            values = np.take_along_axis(s.psd_all[self._peak_bases()], order[None], 2)
        if peaks:
            spectra = np.stack([self._derive(name, f, values[j]) for j, name in enumerate(peaks)])
            maxima = self._refined_maxima(peaks, f, spectra, frf)
        steps = self._transient(model, len(lam)) if steps is None else steps
        measured = {MEASURED + o: np.sqrt(np.maximum(integral(o, None), 0.0)) for o in self.rms_outputs}
        return measured | reduce_metrics(
            self.metrics,
            self.problem.spec.comfort,
            lambda name: self.outputs[name].weighting,  # type: ignore[arg-type,return-value]
            integral,
            lambda output: maxima[output],
            lambda name: static_quantity(model, name, self.problem.spec.handling.gravity_moment),
            steps.__getitem__,
            lambda: accumulator_rooms(model.his) if model.his is not None else [],
            self.build.of(model, len(lam), integral),
        )

    def output_spectra(self, model: CoupledModel, names: Sequence[str], f_hz: np.ndarray) -> np.ndarray:
        """One-sided PSDs ``(n, F, len(names))`` of the outputs ``names`` (of
        :attr:`all_outputs`) at ``f_hz`` (n, F) [Hz] on this evaluator's road, of a batch of
        models sharing one state space (one of :meth:`~hisopt.coupled.model.CoupledModel.groups`):
        from the channels the evaluator integrates (:func:`~hisopt.evaluation.channels.road_channels`,
        its compiled kernel; the direct solve where a design's form is not trusted), an output
        ``s^p c^T X`` from its displacement's as the evaluator derives it."""
        bases, derived = share_outputs({name: self.all_outputs[name] for name in names})
        _, channels, _ = road_channels(model, bases)
        psd = self.psd(np.ascontiguousarray(f_hz, dtype=float), channels)
        place = {base: i for i, base in enumerate(bases)}
        return np.stack([derived_psd(derived[name], f_hz, psd[place[derived[name][0]]]) for name in names], axis=-1)

    def _derive(self, name: str, f_hz: np.ndarray, base_psd: np.ndarray) -> np.ndarray:
        """PSD of output ``name`` from its base: ``scale^2 omega^(2p) S_base``."""
        return derived_psd(self.derived[name], f_hz, base_psd)

    def _refined_maxima(self, names: list[str], f: np.ndarray, spectra: np.ndarray, frf: Channels) -> dict[str, np.ndarray]:
        """Continuous maxima of the outputs ``names``' PSDs (``spectra``: ``(k, n, F)`` at the
        sorted samples ``f``), searched together (:func:`hisopt.evaluation.peaks.refine_maximum`: one
        kernel call per step for all of them)."""
        n, k = len(f), len(names)
        bases = [self.base_index[self.derived[name][0]] for name in names]

        def values_at(pts: np.ndarray) -> np.ndarray:  # (k n, P): row block j is output j's
            per = pts.reshape(k, n, -1).transpose(1, 0, 2).reshape(n, -1)  # (n, k P)
            output_of = np.repeat(bases, pts.shape[1])
            psd = self.psd(per, frf, output_of).reshape(len(self.bases), n, k, -1)
            blocks = per.reshape(n, k, -1)
            parts = [self._derive(name, blocks[:, j], psd[bases[j], :, j]) for j, name in enumerate(names)]
            return np.concatenate(parts, axis=0)

        best = refine_maximum(values_at, f, spectra.reshape(k * n, -1), self.peak_steps)[1]
        return {name: best[j * n : (j + 1) * n] for j, name in enumerate(names)}


@dataclass(frozen=True)
class Prior:
    """What load cases sharing a model share (:meth:`Evaluator._shared_samples`): the panels,
    nodes, weights and peak samples, one road's PSDs at the nodes then the peak samples, and
    the peak search's sorted samples with the PSDs of the maxima's base outputs there."""

    edges: np.ndarray
    f: np.ndarray
    w: np.ndarray
    f_peak: np.ndarray
    psd_all: np.ndarray
    sorted_peaks: tuple[np.ndarray, np.ndarray]


@dataclass(frozen=True)
class Samples:
    """A batch's PSDs where the evaluator samples them (:meth:`Evaluator._sample`), each
    ``(n, F...)`` with PSDs ``(n_bases, n, F...)``.

    Attributes
    ----------
    f, w, psd : np.ndarray
        the pole-aware panels' nodes, weights (0 where the panel was split) and PSDs
        (sorted by frequency)
    totals : np.ndarray
        ``(n, R)`` the quadrature sum of each integral (:attr:`Evaluator.integrals`)
    f_split, w_split, psd_split : np.ndarray
        the nodes of the panels split for the delay ripple
    f_peak : np.ndarray
        the maxima's extra samples (band limits, damped frequencies)
    psd_all : np.ndarray
        the PSDs at ``f`` then ``f_peak``
    """

    f: np.ndarray
    w: np.ndarray
    psd: np.ndarray
    totals: np.ndarray
    f_split: np.ndarray
    w_split: np.ndarray
    psd_split: np.ndarray
    f_peak: np.ndarray
    psd_all: np.ndarray


_PRIMED: list[bool] = []


def _prime_allocator(block_bytes: int = 16 << 20) -> None:
    """Allocate and free one 16 MB block, once per process.

    A chunk's numpy temporaries are up to a few MB each. glibc's malloc serves blocks that
    large by mmap and returns them to the system when freed, until its adaptive threshold has
    grown past them (it grows on freeing such a block), so every chunk would fault its
    arrays' pages in afresh: about a fifth of the evaluator's time on the default problem.
    Freeing one block larger than any of them raises the threshold at once (glibc's own rule;
    elsewhere this is a harmless allocation).
    """
    if not _PRIMED:
        np.ones(block_bytes // 8)
        _PRIMED.append(True)


def poles(model: CoupledModel) -> np.ndarray:
    """[rad/s] Eigenvalues of the model's (lumped) state space, ``(n, n_states)``, computed as
    the evaluator computes them (with eigenvectors: the same LAPACK path), so nodes placed
    from them are the evaluator's own."""
    return np.linalg.eig(model.state_space().a)[0]


def static_quantity(model: CoupledModel, name: str, gravity_moment: bool) -> np.ndarray:
    """A ``static`` metric of a batch of models with HIS: :func:`roll_gradient` (with the
    body's gravity moment or not: ``[handling] gravity_moment``) or one of
    :func:`hisopt.coupled.operating_point.accumulator_quantities`."""
    if name == "roll_gradient":
        return roll_gradient(model, gravity_moment)
    if model.his is None:
        raise ValueError(f"{name}: a model without HIS has no accumulators")
    return np.asarray(accumulator_quantities(model.his)[name])


def roll_gradient(model: CoupledModel, gravity_moment: bool = True) -> np.ndarray:
    """[rad/g] Static roll angle per 1 g of a batch of models, shape (n,) (:func:`hisopt.evaluation.psd.roll_gradient`).

    Parameters
    ----------
    model : CoupledModel
        a problem's model
    gravity_moment : bool, optional
        [-] include the body's gravity moment ``m_s g h_0s phi`` (docs/model.md §6.4); pass
        ``problem.spec.handling.gravity_moment`` for the problem's own convention (the
        paper's problem: False)
    """
    from hisopt.coupled.model import CoupledModel

    of_type(model, CoupledModel, "model", "a CoupledModel (a problem's model())")
    return psd_kernels.roll_gradient(model.stiffness(), model.vehicle, gravity_moment)
