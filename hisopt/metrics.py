"""Registry of objective and constraint quantities (docs/model.md §6)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

Kind = Literal["comfort", "max", "rms", "static", "transient", "swing", "build"]


@dataclass(frozen=True)
class Metric:
    """A scalar performance quantity of a design, in physical units (smaller is better, except
    where ``objective`` is False: such a quantity may only be constrained, ``value <= limit``)."""

    name: str
    kind: Kind
    output: str | None
    unit: str
    description: str
    objective: bool = True

    @property
    def signal(self) -> str:
        """The output a ``max`` or ``rms`` metric reduces (``ValueError`` for the others)."""
        if self.output is None:
            raise ValueError(f"{self.name} ({self.kind}) reduces no single output")
        return self.output


BUILD_METRICS = (
    Metric(
        "pressure_floor_usage",
        "build",
        None,
        "-",
        "lowest chamber or accumulator pressure (static, k road sigmas, cornering) against its floor; above 1: below it",
    ),
    Metric("pressure_ceiling_usage", "build", None, "-", "highest chamber or accumulator pressure (gauge) over its rating"),
    Metric("strut_load_usage", "build", None, "-", "static fluid force on a strut over its corner's sprung load, over the allowed share"),
    Metric("area_ratio_usage", "build", None, "-", "cylinder area ratio bore/annulus over the largest in the series"),
    Metric("annulus_wall_usage", "build", None, "-", "thinnest annulus wall (bore - rod)/2 against its minimum; above 1: thinner"),
    Metric("rod_buckling_usage", "build", None, "-", "peak rod force over Euler's buckling load divided by the safety factor"),
    Metric("hose_velocity_usage", "build", None, "-", "peak hose flow velocity (k road sigmas) over its limit"),
    Metric("hose_reynolds_usage", "build", None, "-", "peak hose Reynolds number over the laminar law's limit"),
    Metric("wheel_hop_usage", "build", None, "-", "highest wheel-hop frequency over its limit (hydraulic lock)"),
    Metric("wheel_damping_usage", "build", None, "-", "lowest wheel-hop damping ratio against its minimum; above 1: less damped"),
    Metric("build_usage", "build", None, "-", "largest usage of every buildability rule: at most 1 for a buildable design"),
)
"""The buildability rules' usages (docs/model.md §21), ``[build]`` their settings: at most 1
where a rule holds; ``1 - usage`` is its margin."""

METRICS: dict[str, Metric] = {
    m.name: m
    for m in (
        Metric("sigma_aw", "comfort", None, "m/s^2", "ISO 2631-1 total weighted RMS acceleration at the CG"),
        Metric("max_roll_psd", "max", "roll", "rad^2/Hz", "maximum over the band of the roll-angle PSD"),
        Metric("max_stroke_psd", "max", "stroke_fl", "m^2/Hz", "maximum over the band of the FL stroke PSD"),
        Metric("max_tire_load_psd", "max", "tire_load_fl", "N^2/Hz", "maximum over the band of the FL dynamic tyre load PSD"),
        Metric("rms_roll", "rms", "roll", "rad", "RMS roll angle over the band"),
        Metric("rms_stroke", "rms", "stroke_fl", "m", "RMS FL suspension stroke over the band"),
        Metric("rms_tire_load", "rms", "tire_load_fl", "N", "RMS FL dynamic tyre load over the band"),
        Metric("roll_gradient", "static", None, "rad/g", "static roll angle per 1 g lateral acceleration"),
        Metric(
            "static_gas_fraction", "static", None, "-", "largest static gas share V/V0 of any accumulator (1: no oil in it; a constraint only)", objective=False
        ),
        Metric("static_pressure_ratio", "static", None, "-", "largest static accumulator pressure over precharge (gauge; a constraint only)", objective=False),
        Metric(
            "pressure_rating_usage",
            "static",
            None,
            "-",
            "static_pressure_ratio over the accumulators' pressure_rating (above 1: beyond the part's rating; a constraint only)",
            objective=False,
        ),
        Metric(
            "accumulator_swing",
            "swing",
            None,
            "-",
            "largest RMS road-induced swing of an accumulator's oil volume over the static oil (or gas) volume it can give (or take)",
        ),
        *BUILD_METRICS,
        Metric("roll_step_peak", "transient", None, "rad", "largest roll angle after a lateral-acceleration step of [handling] step_g"),
        Metric("roll_step_overshoot", "transient", None, "-", "roll step peak over its steady state, minus 1"),
        Metric("roll_rate_peak", "transient", None, "rad/s", "largest roll rate after a lateral-acceleration step of [handling] step_g"),
        Metric("roll_gain_peak", "transient", None, "rad/(m/s^2)", "largest roll angle per lateral acceleration over 0.1-4 Hz"),
        Metric("roll_gain_peak_hz", "transient", None, "Hz", "frequency of roll_gain_peak (a constraint only: lower is not better)", objective=False),
    )
}

ROAD_POWER: dict[Kind, float] = {"comfort": 0.5, "rms": 0.5, "swing": 0.5, "max": 1.0, "static": 0.0, "transient": 0.0, "build": math.nan}
"""The power of the road's roughness ``G_d(n0)`` each kind of quantity is proportional to: a
PSD is linear in it, so an RMS value goes as its square root and a PSD maximum as itself;
static and transient quantities do not see the road (ISO 8608: the class only scales the PSD);
a buildability rule adds the road's swing to a static value, so no power scales it (NaN)."""

COMFORT_OUTPUTS = {"x": "acc_x", "y": "acc_y", "z": "acc_z"}
"""Translational accelerations entering sigma_aw, by axis (paper Eq. 26)."""
