"""``conventional``: the car without circuits, with anti-roll bars, as a reference layout
(docs/model.md §15.6).

The study problem's car, its own springs and dampers, no hydraulic circuits, and an anti-roll
bar on each axle (``k_arb_f``, ``k_arb_r``: :func:`hisopt.vehicle.full_car.anti_roll_bars`).
Its design variables are the two bar rates, in :data:`BAR_BOUNDS`. At a layout study's
handling limit the bars are sized for the best comfort (``sigma_aw``) among the rates that
meet the limit and the problem's constraints a car without circuits has
(:func:`car_constraint`): a full-factorial grid over the box, then two zooms of a finer grid
around the best point (:func:`size_conventional`). Two variables need no optimiser; the grid
is deterministic and costs a few hundred evaluations of the car (a second).

The HIS-only quantities (accumulator and pressure quantities, the buildability rules) are
not defined for it: such constraints are not applied (:attr:`ConventionalResult.dropped`
names them) and its buildability columns stay empty. The car is evaluated at the inputs'
nominal values (a problem's load cases included, not statistics over ``[[uncertain]]``
samples).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.coupled.model import CoupledModel
from hisopt.evaluation.scenarios import case_evaluator_for
from hisopt.metrics import METRICS
from hisopt.problem import Problem, problem_from_dict
from hisopt.specification.design_space import VEHICLE_PREFIX
from hisopt.studies.layout_cases import CONVENTIONAL
from hisopt.studies.layout_metrics import COMFORT
from hisopt.vehicle.batch import VehicleBatch

if TYPE_CHECKING:
    from hisopt.specification.design_space import Inputs

BAR_VARIABLES = ("k_arb_f", "k_arb_r")
"""[-] The two design variables: the front and rear bar rates at the wheel (VehicleParams fields)."""

BAR_BOUNDS = (0.0, 60_000.0)
"""[N/m] Bounds of each bar rate at the wheel, set from the car's springs, not from a cited
range of production bars (none was found to cite): 60 kN/m at the wheel on the default car
(half track 0.74 m) gives ``4 k t^2`` = 131 kN m/rad per axle, 6.7 times its springs'
``2 k_s t^2`` = 19.7 kN m/rad, a generous box for a passenger car's bar that holds the
default problem's handling limit (docs/model.md §15.6)."""

GRID = 21
"""[-] Grid points per bar of the first full-factorial grid."""

ZOOMS = 2
"""[-] Finer grids (``GRID`` points per bar over two grid steps) around the best point."""

CAR_KINDS = frozenset({"comfort", "max", "rms", "transient"})
"""Metric kinds every car has (the ``static`` one a car has is ``roll_gradient``)."""


def car_constraint(name: str) -> bool:
    """[-] Whether quantity ``name`` is defined for a car without circuits."""
    metric = METRICS.get(name)
    return metric is not None and (metric.kind in CAR_KINDS or name == "roll_gradient")


class CarWithoutCircuits(Problem):
    """A problem's car without its HIS: every design is the car (the ``[his]`` variables do
    nothing), with the per-design ``"vehicle.<field>"`` inputs (the bar rates) as a batch of
    cars. Lives in memory only (a run directory re-read would restore the HIS)."""

    def model(self, designs: Any = None, his: bool = True, inputs: Inputs | None = None) -> CoupledModel:
        """The batch of cars (one per design) without HIS; ``his`` is ignored."""
        n = len(self.design_matrix(self.baseline if designs is None else designs))
        cars = {k.removeprefix(VEHICLE_PREFIX): np.broadcast_to(np.asarray(v, dtype=float), (n,)) for k, v in (inputs or {}).items()}
        unknown = [k for k in (inputs or {}) if not k.startswith(VEHICLE_PREFIX)]
        if unknown:
            raise ValueError(f"a car without circuits takes vehicle.<field> inputs only, got {unknown[0]!r}")
        return CoupledModel(VehicleBatch.of(self.vehicle, cars), None)


@dataclass(frozen=True)
class ConventionalResult:
    """The sized conventional car at a handling limit.

    Attributes
    ----------
    sigma_aw : float
        [m/s^2] best comfort meeting the limit (NaN: no bar rates meet it)
    handling : float
        [quantity unit] the handling quantity there
    k_arb_f, k_arb_r : float
        [N/m] the bar rates there (NaN without)
    handling_least : float
        [quantity unit] the least handling of the feasible grid designs
    dropped : tuple[str, ...]
        [-] the problem's constraints a car without circuits does not have
    evaluations : int
        [-] designs evaluated
    """

    sigma_aw: float
    handling: float
    k_arb_f: float
    k_arb_r: float
    handling_least: float
    dropped: tuple[str, ...]
    evaluations: int

    @property
    def met(self) -> bool:
        """[-] Whether some bar rates in the box meet the limit."""
        return bool(np.isfinite(self.sigma_aw))


def car_problem(problem: Problem, handling: str) -> tuple[CarWithoutCircuits, tuple[str, ...]]:
    """The car of ``problem`` evaluating ``sigma_aw``, ``handling`` and the constraints a car
    has, and the names of those it has not."""
    data = problem.spec.model_dump(by_alias=True)
    kept = [c for c in data["constraints"] if car_constraint(c["name"])]
    dropped = tuple(c["name"] for c in data["constraints"] if not car_constraint(c["name"]))
    data["constraints"] = kept
    constrained = {c["name"] for c in kept}
    data["objectives"] = list(dict.fromkeys((COMFORT, *([] if handling in constrained else [handling]))))
    probe = problem_from_dict(data, f"{problem.name} ({CONVENTIONAL})", warn_implausible=False)
    return CarWithoutCircuits(probe.spec), dropped


def _evaluate(car: CarWithoutCircuits, handling: str, rates: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``sigma_aw``, ``handling`` and feasibility (the kept constraints met) of bar rates ``(n, 2)``."""
    x = np.repeat(car.baseline[None, :], len(rates), axis=0)
    q = case_evaluator_for(car)(x, inputs={VEHICLE_PREFIX + name: rates[:, j] for j, name in enumerate(BAR_VARIABLES)})
    ok = np.asarray(q["valid"], dtype=bool) & np.isfinite(q[COMFORT]) & np.isfinite(q[handling])
    for c in car.spec.constraints:
        ok &= np.asarray(q[c.name]) <= c.limit
    return np.asarray(q[COMFORT], dtype=float), np.asarray(q[handling], dtype=float), ok


def _grid(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    axes = [np.linspace(lo, hi, GRID) for lo, hi in zip(lower, upper, strict=True)]
    return np.stack([a.ravel() for a in np.meshgrid(*axes, indexing="ij")], axis=-1)


def size_conventional(problem: Problem, handling: str, limit: float) -> ConventionalResult:
    """The bar rates of best comfort with ``handling <= limit`` (module docstring).

    Parameters
    ----------
    problem : Problem
        the study problem (its car, road, band, comfort settings and constraints)
    handling : str
        [-] the handling quantity held equal
    limit : float
        [quantity unit] its limit
    """
    car, dropped = car_problem(problem, handling)
    lower, upper = np.full(2, BAR_BOUNDS[0]), np.full(2, BAR_BOUNDS[1])
    rates = _grid(lower, upper)
    comfort, quantity, ok = _evaluate(car, handling, rates)
    least = float(quantity[ok].min()) if ok.any() else np.nan
    evaluations = len(rates)
    best = _best(comfort, quantity, ok, limit)
    if best is None:
        return ConventionalResult(np.nan, np.nan, np.nan, np.nan, least, dropped, evaluations)
    point, value, at = rates[best], comfort[best], quantity[best]
    step = (upper - lower) / (GRID - 1)
    for _ in range(ZOOMS):
        rates = _grid(np.maximum(point - step, lower), np.minimum(point + step, upper))
        comfort, quantity, ok = _evaluate(car, handling, rates)
        evaluations += len(rates)
        i = _best(comfort, quantity, ok, limit)
        if i is not None and comfort[i] < value:
            point, value, at = rates[i], comfort[i], quantity[i]
        step = step * 2.0 / (GRID - 1)
    return ConventionalResult(float(value), float(at), float(point[0]), float(point[1]), least, dropped, evaluations)


def _best(comfort: np.ndarray, quantity: np.ndarray, ok: np.ndarray, limit: float) -> int | None:
    """The design of least comfort among the feasible ones meeting the limit (None: none)."""
    meets = ok & (quantity <= limit)
    if not meets.any():
        return None
    return int(np.flatnonzero(meets)[np.argmin(comfort[meets])])


def with_conventional(table: pd.DataFrame, result: ConventionalResult, handling: str, limit: float) -> pd.DataFrame:
    """A layout study's table with the ``conventional`` row (``source`` ``"reference"``, its
    bars in ``best_k_arb_f``/``best_k_arb_r``, empty hypervolumes: it has no front) and
    ``gain_vs_conventional_pct = 100 (1 - sigma_layout / sigma_conventional)`` after
    ``gain_vs_roll_plane_pct``."""
    from hisopt.studies.layout_cases import REFERENCE_LAYOUT

    met = result.met
    row: dict[str, Any] = {
        "layout": CONVENTIONAL,
        "source": "reference",
        "variables": " ".join(BAR_VARIABLES),
        "handling": handling,
        "handling_limit": limit,
        "sigma_aw_at_limit": result.sigma_aw,
        "handling_at_best": result.handling,
        "refined": False,
        "handling_least": result.handling_least,
        "at_limit": "met" if met else f"no bar rates in the box meet {handling} <= {limit:g}",
        "best_k_arb_f": result.k_arb_f,
        "best_k_arb_r": result.k_arb_r,
    }
    reference = table.loc[table["layout"] == REFERENCE_LAYOUT, "sigma_aw_at_limit"].to_numpy()
    row["gain_vs_roll_plane_pct"] = 100.0 * (1.0 - result.sigma_aw / reference[0]) if len(reference) else np.nan
    out = pd.concat([table, pd.DataFrame([row])], ignore_index=True)
    out.insert(out.columns.get_loc("gain_vs_roll_plane_pct") + 1, "gain_vs_conventional_pct", 100.0 * (1.0 - out["sigma_aw_at_limit"] / result.sigma_aw))
    out.attrs["units"] = dict(table.attrs.get("units", {})) | {"gain_vs_conventional_pct": "%", "best_k_arb_f": "N/m", "best_k_arb_r": "N/m"}
    return out
