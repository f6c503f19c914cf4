"""Plausibility: impossible input refused, implausible input warned about, picks on a bound marked.

Every rule is here with its reason (docs/input.md, "Plausibility"); the validators of the
problem file (:mod:`hisopt.specification.config`), the seed parser and the outputs call these functions.

**Refused** (:class:`~hisopt.errors.ConfigError`; the CLI's one ``error:`` line, exit 2):

- a payload outside the body: ahead of its front or behind its rear (``l_f + overhang_f``,
  ``l_r + overhang_r`` from the CG), beyond its half width ``body_half_width`` from the centre
  line, or with its centre under the road (``z < -h_cg``);
- a payload so heavy that its weight alone would press the body onto the road: the springs
  and tyres (in series per corner) would sag by ``m_p g / K`` more than the CG's height
  ``h_cg`` (:func:`payload_problem`);
- a polytropic exponent outside :data:`GAMMA_RANGE` (the field's rule, with its reason in
  :data:`RULE_REASONS`);
- a road speed above :data:`SPEED_MAX`;
- more seeds than :data:`MAX_SEEDS` in one study;
- a design box in which no cylinder can be built: on an axle, every rod of the rod box (a
  ``[variables]`` range or its choices, or the fixed ``[his]`` size) at least as wide as
  every bore of the bore box (:func:`cylinder_box_problem`).

**Warned** (:class:`~hisopt.errors.PlausibilityWarning`, one line each; the work goes on), for
values the user gave (a default never warns; :func:`given_warnings`):

- a payload heavier than the car's own sprung mass;
- a handling step ``step_g`` over :data:`STEP_G_MAX`;
- an accumulator precharge under :data:`P0_MIN` (``[his] p0``, a ``[his.parameters]`` value
  the layout reads as a precharge, or ``--set``; never the ``[variables]`` box);
- a roll limit written as a bare number (read in rad) above :data:`ROLL_LIMIT_WARN`;
- a rod box reaching the largest bore of its axle (:func:`cylinder_box_warnings`): the
  designs whose rod is not thinner than their bore are invalid and never evaluated.

**Marked**: a design picked, refined or exported within :data:`BOUND_TOLERANCE` of the box
width of a variable's bound (:func:`bound_sides`, :func:`bound_labels`, :func:`with_bound_column`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from hisopt.constants import G_MPS2
from hisopt.errors import PlausibilityWarning
from hisopt.metrics import METRICS

if TYPE_CHECKING:
    import pandas as pd

# A leaf module: the hydraulics (the gamma rule), the problem file and the outputs import it,
# so it imports none of them; problems, cars and payloads come in as objects (duck-typed Any).

# --- refusals ---------------------------------------------------------------------------------
GAMMA_RANGE = (1.0, 2.0)
"""[-] Polytropic exponent of an accumulator's gas: 1 is isothermal; the adiabatic exponent is
1.4 for nitrogen and 1.67 for a monatomic gas, and real-gas effects at a HIS's pressures keep
it below 2. Outside the range no gas behaves so (``[his] gamma``, a layout's ``gamma``)."""

RULE_REASONS = {
    "gamma": "a gas's polytropic exponent lies between 1, isothermal, and its adiabatic exponent: "
    "1.4 for nitrogen, 1.67 for a monatomic gas, below 2 at a HIS's pressures",
    "orifice_diameter": "the bore of a damper valve's bleed orifice: 0 would close it and lock the strut",
    "discharge_coefficient": "the share of the orifice's area the jet fills at its vena contracta: above 0 and at most 1, about 0.6 to 0.8 for a sharp edge",
    "cracking_pressure": "the pressure drop at which a damper valve's blow-off opens: 0 opens it at once",
    "blowoff_resistance": "the slope of the blow-off's opening law, pressure per flow once open: 0 would pass any flow at the cracking pressure",
}
"""The physical reason of a parameter's rule, added to the messages that refuse a value."""

SPEED_MAX = 150.0
"""[m/s] Largest road speed (540 km/h): faster than any road vehicle; the fastest production
cars reach about 136 m/s (490 km/h). A larger value is a unit slip (km/h for m/s) or a typo."""

MAX_SEEDS = 100
"""[-] Most seeds of one study (``hisopt study``, and per layout in ``compare-layouts``). Each
seed is a whole optimisation run (the default 100 x 200 = 20,000 designs take about 25 s,
docs/optimize.md: 100 seeds of six layouts take about four hours of one core), and what a study reports across
seeds (the attainment function in steps of 1/n, hypervolume spread and median) is resolved
to 1 % by 100; ``--seeds 1-100000`` would have started 200,000 runs."""

# --- warnings ---------------------------------------------------------------------------------
STEP_G_MAX = 1.2
"""[g] Largest plausible lateral-acceleration step: road tyres grip to about 1.0-1.2 g on dry
asphalt, beyond which the car slides (or rolls over) instead of holding the step."""

P0_MIN = 1e5
"""[Pa] Smallest plausible accumulator precharge (gauge, 0.1 MPa = 1 bar): below it the gas
is near atmospheric pressure, the accumulator is hardly a spring, and in service the
circuit's pressure swings would take the oil below its vapour pressure (cavitation), which
the linear model does not show. HIS accumulators are precharged to about 1 MPa and more."""

ROLL_LIMIT_WARN = {
    "rad": 20.0 * math.pi / 180.0,
    "rad/g": 20.0 * math.pi / 180.0,
    "rad/(m/s^2)": 20.0 * math.pi / 180.0 / G_MPS2,
    "rad/s": 100.0 * math.pi / 180.0,
}
"""[SI] Largest plausible limit of a roll quantity, by its unit: 20 deg (20 deg/g; 20 deg at
1 g per m/s^2), 100 deg/s. A road car's body rolls a few degrees (roll gradients of 2-8
deg/g) and at 20 deg it is past its suspension's travel; a roll limit written as a bare number
is read in rad, so ``limit = 1.5`` meant as degrees is 86 deg."""

# --- marks -------------------------------------------------------------------------------------
BOUND_TOLERANCE = 0.01
"""[-] A design value within this share of its variable's box width of a bound is "at" the
bound: the optimiser pushed against the box there (p0 = 5 kPa on a 0-4 MPa box is 0.125 %
of the width from its lower bound), so the box, not the physics, chose that value."""

ON_BOUND = "on_bound"
"""Column of ``front.csv`` and ``front_refined.csv`` listing the variables at a bound."""


def payload_problem(vehicle: Any, payload: Any) -> str | None:
    """Why ``payload`` cannot ride on the body of ``vehicle`` (``"payload.<key>: <reason>"``),
    or None: outside the body, its centre under the road, or heavy enough to sag the body
    onto the road (module docstring). A payload of 0 kg is no payload."""
    if not payload.mass > 0:
        return None
    front, rear = vehicle.l_f + vehicle.overhang_f, vehicle.l_r + vehicle.overhang_r
    if not -rear <= payload.x <= front:
        return (
            f"payload.x: {payload.x:g} m from the CG is outside the body, which runs from {rear:g} m behind the CG "
            f"(l_r + overhang_r) to {front:g} m ahead of it (l_f + overhang_f); expected {-rear:g} m <= x <= {front:g} m"
        )
    side = vehicle.y_cg + payload.y
    if abs(side) > vehicle.body_half_width:
        return (
            f"payload.y: {payload.y:g} m from the CG puts the payload {abs(side):g} m from the centre line, outside the "
            f"body (body_half_width {vehicle.body_half_width:g} m); expected |y_cg + y| <= {vehicle.body_half_width:g} m"
        )
    if payload.z < -vehicle.h_cg:
        return (
            f"payload.z: {payload.z:g} m puts the payload's centre {-(vehicle.h_cg + payload.z):g} m under the road "
            f"(the CG is h_cg = {vehicle.h_cg:g} m above it); expected z >= {-vehicle.h_cg:g} m"
        )
    stiffness = sprung_vertical_stiffness(vehicle)
    if stiffness > 0:
        sag = payload.mass * G_MPS2 / stiffness
        if sag > vehicle.h_cg:
            return (
                f"payload.mass: {payload.mass:g} kg would sag the body {sag:.3g} m on its springs and tyres "
                f"({stiffness / 1e3:.4g} kN/m), more than the CG's height above the road (h_cg = {vehicle.h_cg:g} m): "
                f"the body would rest on the road and the model would be meaningless; "
                f"expected at most {vehicle.h_cg * stiffness / G_MPS2:.4g} kg"
            )
    return None


def sprung_vertical_stiffness(vehicle: Any) -> float:
    """[N/m] Vertical stiffness of the body on its four corners, spring and tyre in series;
    0 for a car with an axle without springs, carried there by its HIS alone: its sag then
    depends on the design, so :func:`payload_problem` leaves it to the model."""
    if not (vehicle.k_sf > 0 and vehicle.k_sr > 0):
        return 0.0
    front = vehicle.k_sf * vehicle.k_tf / (vehicle.k_sf + vehicle.k_tf)
    rear = vehicle.k_sr * vehicle.k_tr / (vehicle.k_sr + vehicle.k_tr)
    return 2.0 * front + 2.0 * rear


def speed_problem(speed: float) -> str | None:
    """Why a road speed [m/s] is impossible (None: it is not)."""
    if speed > SPEED_MAX:
        return (
            f"expected a road vehicle's speed of at most {SPEED_MAX:g} m/s ({SPEED_MAX * 3.6:g} km/h: faster than any "
            f"road vehicle, the fastest production cars reach about 136 m/s; a speed in km/h?)"
        )
    return None


def seed_count_problem(count: int) -> str | None:
    """Why a study of ``count`` seeds is refused (None: it is not; :data:`MAX_SEEDS`)."""
    if count > MAX_SEEDS:
        return (
            f"expected at most {MAX_SEEDS} seeds, got {count}: each seed is a whole optimisation run (about 25 s at the "
            f"default budget), and {MAX_SEEDS} seeds resolve what a study reports across seeds to 1 %"
        )
    return None


@dataclass(frozen=True)
class SizeBox:
    """The sizes a cylinder's bore or rod takes over the design box: a variable's range (its
    choices' if it has them) or a fixed ``[his]`` value.

    Attributes
    ----------
    key : str
        [-] where the file gives it: ``variables.rod`` or ``his.bore``
    lower, upper : float
        [m] the smallest and the largest size (equal for a fixed value)
    """

    key: str
    lower: float
    upper: float

    @property
    def text(self) -> str:
        """``variables.rod (12 to 56 mm)`` or ``his.bore (50 mm)``."""
        span = f"{self.lower * 1e3:.4g} mm" if self.lower == self.upper else f"{self.lower * 1e3:.4g} to {self.upper * 1e3:.4g} mm"
        return f"{self.key} ({span})"


def cylinder_boxes(spec: Any) -> list[tuple[SizeBox, SizeBox]]:
    """``(bore, rod)`` of each axle sized by bore and rod with at least one of them a design
    variable (the rear only with a size of its own, else it follows the front; the sources
    as :func:`hisopt.specification.validation.cylinder_breaks` reads them per design)."""
    variables, his = spec.variables, spec.his
    given = lambda n: n in variables or getattr(his, n, None) is not None  # noqa: E731
    out = []
    for axle in ("", "_rear"):
        if axle and not (given("bore_rear") or given("rod_rear")):
            continue
        found = [next((n for n in (f"{part}{axle}", part) if given(n)), None) for part in ("bore", "rod")]
        sources = [n for n in found if n is not None]
        if len(sources) < 2 or not any(n in variables for n in sources):
            continue  # a size missing (refused on its own) or a fixed pair: checked on [his] itself
        boxes = []
        for name in sources:
            var = variables.get(name)
            if var is None:
                value = float(getattr(his, name))
                boxes.append(SizeBox(f"his.{name}", value, value))
            else:
                sizes = var.choices or [var.lower, var.upper]
                boxes.append(SizeBox(f"variables.{name}", float(min(sizes)), float(max(sizes))))
        out.append((boxes[0], boxes[1]))
    return out


def _varied(bore: SizeBox, rod: SizeBox) -> SizeBox:
    """The box a message names first: the rod's if it is a design variable, else the bore's."""
    return rod if rod.key.startswith("variables.") else bore


def cylinder_box_problem(spec: Any) -> str | None:
    """Why no design of ``spec``'s box is a buildable cylinder (every rod of the rod box at
    least as wide as every bore of the bore box, on an axle), naming both boxes; or None."""
    for bore, rod in cylinder_boxes(spec):
        if rod.lower >= bore.upper:
            return (
                f"{_varied(bore, rod).key}: no rod of {rod.text} is thinner than any bore of {bore.text}, so no design of the box "
                f"is a cylinder that can be built; expected the smallest rod below the largest bore"
            )
    return None


def cylinder_box_warnings(spec: Any, given: Mapping[str, Any]) -> list[tuple[str, str]]:
    """``(key, message)`` for each axle whose rod box reaches the largest bore (some designs
    of the box cannot be built; those are invalid and not evaluated), where ``given`` holds
    the bore or the rod."""
    out = []
    for bore, rod in cylinder_boxes(spec):
        names = [box.key.split(".", 1) for box in (bore, rod)]
        if rod.upper >= bore.upper and any(_given(given, table, name) is not None for table, name in names):
            out.append(
                (
                    _varied(bore, rod).key,
                    f"the rods of {rod.text} reach the largest bore of {bore.text}: a design whose rod is not thinner than its "
                    f"bore cannot be built and is invalid (not evaluated); expected the largest rod below {bore.upper * 1e3:.4g} mm",
                )
            )
    return out


def rule_reason(name: str) -> str:
    """``" (<reason>)"`` for a parameter whose rule has a physical reason to state, else ``""``."""
    reason = RULE_REASONS.get(name) or RULE_REASONS.get(name.removesuffix("_rear"))
    return f" ({reason})" if reason else ""


# --- warnings of given values ----------------------------------------------------------------
def payload_warning(vehicle: Any, payload: Any) -> tuple[str, str] | None:
    """``("payload.mass", reason)`` if a possible ``payload`` is implausible, else None."""
    if payload.mass > vehicle.m_s:
        return "payload.mass", (
            f"{payload.mass:g} kg is more than the car's own sprung mass ({vehicle.m_s:g} kg): it compresses "
            f"the suspension further than the car's weight does, beyond the travel of most cars; taken as given"
        )
    return None


def _given(given: Mapping[str, Any], *path: str) -> Any:
    node: Any = given
    for part in path:
        if not isinstance(node, Mapping) or part not in node:
            return None
        node = node[part]
    return node


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def given_warnings(spec: Any, given: Mapping[str, Any], precharges: Collection[str]) -> list[tuple[str, str]]:
    """``(key, message)`` of each implausible value of ``spec`` that ``given`` holds.

    Parameters
    ----------
    spec : Any
        the validated problem (:class:`hisopt.specification.config.ProblemSpec`: the values judged)
    given : Mapping[str, Any]
        the problem's raw data as the user wrote it, or the part given (``{"his": {"p0":
        5e4}}`` for ``--set p0=5e4``): a value is judged only where it was given, and a roll
        limit warns only when given as a bare number (read in rad)
    precharges : Collection[str]
        the parameter names the problem's layout reads as an accumulator precharge
    """
    out: list[tuple[str, str]] = []
    his = _given(given, "his")
    if isinstance(his, Mapping):
        named = [(f"his.{k}", k, getattr(spec.his, k, None)) for k in his if k not in ("parameters", "circuits")]
        named += [(f"his.parameters.{k}", k, spec.his.parameters.get(k)) for k in _given(his, "parameters") or {}]
        for key, name, value in named:
            if name in precharges and isinstance(value, (int, float)) and value < P0_MIN:
                out.append(
                    (
                        key,
                        f"a precharge of {value / 1e3:.4g} kPa is under {P0_MIN / 1e6:g} MPa (1 bar): the gas is near atmospheric "
                        f"pressure, the accumulator hardly a spring, and the oil would cavitate as the pressure "
                        f"swings; taken as given",
                    )
                )
    for key, temperature in spec.temperatures():
        oil = spec.his.oil
        if oil.extrapolated(temperature):
            out.append(
                (
                    key,
                    f"{temperature - 273.15:.4g} degC is outside the oil's viscosity data ({oil.temperature_1 - 273.15:.4g} to "
                    f"{oil.temperature_2 - 273.15:.4g} degC): its viscosity ({oil.kinematic_viscosity(temperature) * 1e6:.4g} mm^2/s) "
                    f"is extrapolated by the Walther equation (ASTM D341)",
                )
            )
    step = _given(given, "handling", "step_g")
    if step is not None and spec.handling.step_g > STEP_G_MAX:
        out.append(
            (
                "handling.step_g",
                f"a lateral step of {spec.handling.step_g:g} g is beyond the grip of road tyres (about "
                f"{STEP_G_MAX:g} g): the car would slide or roll over first; taken as given",
            )
        )
    if _given(given, "payload") is not None and spec.payload is not None:
        heavy = payload_warning(spec.vehicle, spec.payload)
        out += [heavy] if heavy else []
    if isinstance(_given(given, "scenarios"), list):
        for sc in spec.scenarios:
            heavy = None if sc.payload is None else payload_warning(spec.vehicle, sc.payload)
            out += [(f"scenario {sc.name!r}: {heavy[0]}", heavy[1])] if heavy else []
    constraints = _given(given, "constraints")
    if isinstance(constraints, list) and len(constraints) == len(spec.constraints):
        for i, (raw, c) in enumerate(zip(constraints, spec.constraints, strict=True)):
            unit = METRICS[c.name].unit
            if isinstance(raw, Mapping) and _is_number(raw.get("limit")) and unit in ROLL_LIMIT_WARN and c.limit > ROLL_LIMIT_WARN[unit]:
                shown, top = unit.replace("rad", "deg"), ROLL_LIMIT_WARN[unit] * 180.0 / math.pi
                out.append(
                    (
                        f"constraints.{i}.limit",
                        f"{c.name} <= {c.limit:g} is read in {unit} ({c.limit * 180.0 / math.pi:.4g} {shown}), more than the "
                        f'{top:.3g} {shown} a road car\'s body rolls; if you meant degrees write limit = "{c.limit:g} {shown}"',
                    )
                )
    return out + cylinder_box_warnings(spec, given)


def warn(items: list[tuple[str, str]], file: str | None = None) -> None:
    """Issue one :class:`~hisopt.errors.PlausibilityWarning` per ``(key, message)``."""
    for key, message in items:
        warnings.warn(PlausibilityWarning(message, file=file, key=key), stacklevel=3)


# --- designs on a bound ------------------------------------------------------------------------
def bound_sides(x: Any, lower: Any, upper: Any) -> np.ndarray:
    """[-] ``(n, n_var)``: -1 where a value lies within :data:`BOUND_TOLERANCE` of the box width
    of its lower bound, +1 of its upper bound, 0 elsewhere (and for NaN)."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    reach = BOUND_TOLERANCE * (upper - lower)
    with np.errstate(invalid="ignore"):
        low, high = x - lower <= reach, upper - x <= reach
    return np.where(low, -1, np.where(high, 1, 0)).astype(np.int8)


def bound_labels(x: Any, lower: Any, upper: Any, names: tuple[str, ...] | list[str]) -> list[str]:
    """One text per row naming each variable at a bound: ``"p0 (lower); Rv (upper)"``, ``""``."""
    sides = bound_sides(x, lower, upper)
    return ["; ".join(f"{n} ({'lower' if s < 0 else 'upper'})" for n, s in zip(names, row, strict=True) if s) for row in sides]


def bound_note(value: float, lower: float, upper: float) -> str:
    """``" (at lower bound)"``, ``" (at upper bound)"`` or ``""`` for one value."""
    side = int(bound_sides([[value]], [lower], [upper])[0, 0])
    return "" if side == 0 else f" (at {'lower' if side < 0 else 'upper'} bound)"


def without_bound_column(frame: pd.DataFrame) -> pd.DataFrame:
    """``frame`` without :data:`ON_BOUND` (and its unit), e.g. a ``front.csv`` read back."""
    if ON_BOUND not in frame.columns:
        return frame
    out = frame.drop(columns=ON_BOUND)
    out.attrs = dict(frame.attrs)
    out.attrs["units"] = {k: v for k, v in frame.attrs.get("units", {}).items() if k != ON_BOUND}
    return out


def with_bound_column(frame: pd.DataFrame, problem: Any) -> pd.DataFrame:
    """``frame`` (designs with the problem's variable columns) plus :data:`ON_BOUND`, unit ``-``."""
    names = tuple(problem.variable_names)
    out = frame.drop(columns=ON_BOUND, errors="ignore").copy()
    out.attrs = dict(frame.attrs)
    out[ON_BOUND] = bound_labels(out[list(names)].to_numpy(dtype=float), problem.lower, problem.upper, names) if len(out) else []
    out.attrs["units"] = dict(frame.attrs.get("units", {})) | {ON_BOUND: "-"}
    return out
