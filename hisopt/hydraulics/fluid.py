"""Hydraulic fluid properties and how they follow temperature (docs/model.md §3.3, §16).

:class:`Fluid` (``[his.fluid]``) holds the oil's density, viscosity and bulk modulus at the
reference temperature (the charge temperature, default 20 C); :class:`Oil` (``[his.oil]``)
holds the data the temperature laws are fitted to:

- kinematic viscosity by the Walther equation of ASTM D341,
  ``log10 log10(nu + 0.7) = A - B log10 T`` (``nu`` in mm^2/s, ``T`` in K), through two
  data points of the oil;
- density by a constant volumetric expansion coefficient ``alpha``:
  ``rho(T) = rho_ref / (1 + alpha (T - T_ref))``.

A model at temperature ``T`` uses ``rho = rho_fluid * r_rho`` and ``mu = mu_fluid * r_mu``
with the oil's ratios ``r = value(T) / value(T_ref)`` (:func:`thermal_ratios`): the fluid's
values say how much, the oil how it changes. At the reference temperature both ratios are 1
exactly, so a problem without temperatures is the problem it always was.

One oil per problem: a ``[his.fluid]`` density or viscosity not given is the oil's at the
reference temperature (:func:`oil_fluid`), so pipes and hoses run on the oil's viscosity at
every load case's temperature; one given must agree with the oil's within
:data:`FLUID_OIL_TOLERANCE` (:func:`fluid_oil_problem`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_serializer, model_validator

from hisopt.quantities import absolute_zero_problem, si

WALTHER_OFFSET = 0.7
"""[mm^2/s] The constant of ASTM D341's Walther equation; the equation holds down to about
2 mm^2/s (below it D341 adds correction terms)."""

WALTHER_MIN_VISCOSITY = 2.0e-6
"""[m^2/s] Lowest kinematic viscosity the two-constant Walther equation is used for."""


FLUID_OIL_TOLERANCE = 0.02
"""[-] How far a ``[his.fluid]`` density or viscosity may lie from the oil's at the reference
temperature (relative). A data sheet rounds its values to two or three figures: 32 mm^2/s is
32 +- 0.5 (1.6 %), 5.4 mm^2/s 5.4 +- 0.05 (0.9 %), 875 kg/m^3 875 +- 0.5 (0.06 %), so the same
oil read off the sheet at 20 C agrees within 2 % (the shipped envelope problem's 0.0755 Pa s:
0.36 % from the default oil's fit, 0.005 % from its own). It is a fifth of an ISO 3448
viscosity grade's +-10 % band, so another grade (VG 46 is 44 % thicker than VG 32) or the old
default 0.03 Pa s (60 % below VG 32 at 20 C) is refused."""


class Fluid(BaseModel):
    """The oil's properties at the reference temperature, used by pipes, valves and chamber
    compliances; a density or viscosity not given is the oil's (``[his.oil]``) at the reference
    temperature (:func:`oil_fluid`)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    rho: float | None = Field(None, gt=0, description="density (None: the oil's at the reference temperature)", json_schema_extra=si("kg/m^3"))
    mu: float | None = Field(None, gt=0, description="dynamic viscosity (None: the oil's at the reference temperature)", json_schema_extra=si("Pa s"))
    beta: float = Field(1.5e9, gt=0, description="effective bulk modulus", json_schema_extra=si("Pa"))

    @model_serializer(mode="wrap")
    def _given_only(self, handler: Any) -> dict[str, Any]:
        # a value taken from the oil (oil_fluid) is not written: a dump reads back to the oil's
        data = handler(self)
        for key in ("rho", "mu"):
            if key not in self.model_fields_set:
                data.pop(key, None)
        return data


class Oil(BaseModel):
    """The data of the oil's temperature laws (default: an ISO VG 32 mineral hydraulic oil).

    Notes
    -----
    Default values: Shell Tellus S2 M 32 technical data sheet (typical values): kinematic
    viscosity 32 mm^2/s at 40 C and 5.4 mm^2/s at 100 C (and 338 mm^2/s at 0 C, which the
    tests use as the third value), density 875 kg/m^3 at 15 C. Expansion coefficient
    7e-4 1/K: the usual value for mineral hydraulic oils (6.5e-4 to 7.5e-4 1/K).
    ``lowest`` is the oil's pour point (-30 C on the data sheet): below it the oil does not
    flow and no viscosity law applies.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    name: str = Field("ISO VG 32 mineral hydraulic oil (Shell Tellus S2 M 32, typical values)", min_length=1)
    temperature_1: float = Field(313.15, gt=0, description="temperature of the first viscosity point", json_schema_extra=si("K"))
    viscosity_1: float = Field(32.0e-6, gt=0, description="kinematic viscosity at temperature_1", json_schema_extra=si("m^2/s"))
    temperature_2: float = Field(373.15, gt=0, description="temperature of the second viscosity point", json_schema_extra=si("K"))
    viscosity_2: float = Field(5.4e-6, gt=0, description="kinematic viscosity at temperature_2", json_schema_extra=si("m^2/s"))
    density: float = Field(875.0, gt=0, description="density at density_temperature", json_schema_extra=si("kg/m^3"))
    density_temperature: float = Field(288.15, gt=0, description="temperature of the density", json_schema_extra=si("K"))
    expansion: float = Field(7.0e-4, ge=0, lt=0.01, description="volumetric thermal expansion coefficient", json_schema_extra=si("1/K"))
    lowest: float = Field(243.15, gt=0, description="lowest temperature the oil is used at (pour point)", json_schema_extra=si("K"))
    highest: float = Field(393.15, gt=0, description="highest temperature the oil is used at", json_schema_extra=si("K"))

    @model_validator(mode="after")
    def _two_distinct_points(self) -> Oil:
        points = ("temperature_1", "viscosity_1", "temperature_2", "viscosity_2")
        given = [k for k in points if k in self.model_fields_set]
        if given and len(given) < len(points):
            missing = [k for k in points if k not in given]
            raise ValueError(f"an oil's viscosity law needs two data points; {', '.join(missing)} missing (give all of {', '.join(points)})")
        if self.temperature_2 <= self.temperature_1:
            raise ValueError("temperature_2 must be above temperature_1: the viscosity law needs two distinct points")
        if self.viscosity_2 >= self.viscosity_1:
            raise ValueError("viscosity_2 must be below viscosity_1: an oil thins as it warms")
        if min(self.viscosity_1, self.viscosity_2) < WALTHER_MIN_VISCOSITY:
            raise ValueError(f"viscosities below {WALTHER_MIN_VISCOSITY * 1e6:g} mm^2/s are outside the Walther equation (ASTM D341)")
        if self.highest <= self.lowest:
            raise ValueError("highest must be above lowest")
        return self

    @property
    def walther(self) -> tuple[float, float]:
        """[-] ``(A, B)`` of :func:`walther_viscosity` through the two data points."""
        return walther_constants(self.temperature_1, self.viscosity_1, self.temperature_2, self.viscosity_2)

    def kinematic_viscosity(self, temperature: float) -> float:
        """[m^2/s] Kinematic viscosity at ``temperature`` [K] (:func:`walther_viscosity`)."""
        return walther_viscosity(temperature, *self.walther)

    def density_at(self, temperature: float) -> float:
        """[kg/m^3] Density at ``temperature`` [K] (:func:`expanded_density`)."""
        return expanded_density(temperature, self.density, self.density_temperature, self.expansion)

    def temperature_problem(self, temperature: float, *, written: str | None = None) -> str | None:
        """Why the oil cannot be used at ``temperature`` [K] (at or below absolute zero,
        outside ``lowest`` to ``highest``, or thinner than the Walther equation holds), or
        None. ``written``: the value as the person wrote it with its unit (``"-100 degF"``),
        named as such; None for a bare number (kelvin), which under 150 K gets the hint that
        Celsius may have been meant (a value with a unit never does; one below absolute zero
        is refused where it is read: :func:`hisopt.quantities.absolute_zero_problem`)."""
        hint = f' (a bare number is kelvin; for Celsius write "{temperature:g} degC")' if written is None and temperature < 150.0 else ""
        below = absolute_zero_problem(temperature, f"{temperature:g} K")
        if below:
            return below + hint
        shown = written if written is not None else f"{temperature - 273.15:.4g} degC"
        if not self.lowest <= temperature <= self.highest:
            return (
                f"{shown} is outside the range the oil is used in "
                f"({self.lowest - 273.15:.4g} to {self.highest - 273.15:.4g} degC: his.oil.lowest, his.oil.highest){hint}"
            )
        if self.kinematic_viscosity(temperature) < WALTHER_MIN_VISCOSITY:
            return f"{shown} thins the oil below {WALTHER_MIN_VISCOSITY * 1e6:g} mm^2/s, outside the Walther equation (ASTM D341)"
        return None

    def extrapolated(self, temperature: float) -> bool:
        """Whether the viscosity at ``temperature`` [K] lies outside the two data points."""
        return not self.temperature_1 <= temperature <= self.temperature_2


def walther_constants(t1: float, nu1: float, t2: float, nu2: float) -> tuple[float, float]:
    """[-] ``(A, B)`` of the Walther equation through ``(t1, nu1)`` and ``(t2, nu2)`` (K, m^2/s)."""
    w1, w2 = _walther(nu1), _walther(nu2)
    b = (w1 - w2) / (math.log10(t2) - math.log10(t1))
    return w1 + b * math.log10(t1), b


def walther_viscosity(temperature: float, a: float, b: float) -> float:
    """[m^2/s] ``nu = 10^(10^(A - B log10 T)) - 0.7`` mm^2/s (ASTM D341, the Walther equation)."""
    return (10.0 ** (10.0 ** (a - b * math.log10(temperature))) - WALTHER_OFFSET) * 1e-6


def _walther(nu: float) -> float:
    return math.log10(math.log10(nu * 1e6 + WALTHER_OFFSET))


def expanded_density(temperature: float, density: float, at: float, expansion: float) -> float:
    """[kg/m^3] ``rho(T) = rho_ref / (1 + alpha (T - T_ref))``: a mass whose volume grows by
    ``alpha`` per kelvin."""
    return density / (1.0 + expansion * (temperature - at))


def oil_density_viscosity(oil: Oil, temperature: float) -> tuple[float, float]:
    """[kg/m^3], [Pa s] The oil's density and dynamic viscosity ``mu = nu rho`` at
    ``temperature`` [K] (:meth:`Oil.density_at`, :meth:`Oil.kinematic_viscosity`)."""
    rho = oil.density_at(temperature)
    return rho, oil.kinematic_viscosity(temperature) * rho


def fluid_oil_problem(fluid: Fluid, oil: Oil, temperature: float) -> str | None:
    """Why ``fluid``'s given density or viscosity is not ``oil``'s at ``temperature`` [K] (the
    reference temperature) within :data:`FLUID_OIL_TOLERANCE`, as one line starting with the
    key (``fluid.mu: ...``), or None."""
    oils = dict(zip(("rho", "mu"), oil_density_viscosity(oil, temperature), strict=True))
    for key, unit, what in (("mu", "Pa s", "viscosity"), ("rho", "kg/m^3", "density")):
        given = getattr(fluid, key)
        if given is not None and abs(given / oils[key] - 1.0) > FLUID_OIL_TOLERANCE:
            return (
                f"fluid.{key}: {given:.4g} {unit} is not the {what} of the problem's oil (his.oil, {oil.name}) at the reference temperature "
                f"{temperature - 273.15:.4g} degC, {oils[key]:.4g} {unit} ({100.0 * (given / oils[key] - 1.0):+.0f} %); expected them within "
                f"{100.0 * FLUID_OIL_TOLERANCE:g} % (one oil per problem), or no fluid.{key}: it is then the oil's"
            )
    return None


def oil_fluid(fluid: Fluid, oil: Oil, temperature: float) -> Fluid:
    """``fluid`` with the density and viscosity it does not give taken from ``oil`` at
    ``temperature`` [K] (the reference temperature); what it gives is kept, and so is what it
    was given with (``model_fields_set``: a dump writes only those)."""
    oils = dict(zip(("rho", "mu"), oil_density_viscosity(oil, temperature), strict=True))
    values = {key: oils[key] if getattr(fluid, key) is None else getattr(fluid, key) for key in ("rho", "mu")}
    return Fluid.model_construct(set(fluid.model_fields_set), **values, beta=fluid.beta)


@dataclass(frozen=True)
class ThermalRatios:
    """[-] The oil's properties at a temperature over those at the reference temperature
    (floats for one temperature, arrays of its shape for an array of temperatures)."""

    density: Any
    viscosity: Any
    """dynamic viscosity ``mu = nu rho``"""
    volume: Any
    """oil volume of a fixed mass: the inverse of ``density``"""


def thermal_ratios(oil: Oil, temperature: float | np.ndarray, reference: float) -> ThermalRatios:
    """The ratios of :class:`ThermalRatios` at ``temperature`` over ``reference`` [K]; all 1
    exactly when the two are equal.

    An array of temperatures (one per design or sample) gives arrays of its shape, each
    element computed as for that temperature alone, to the same bits (the Walther equation's
    ``math.log10`` and powers are not numpy's, whose rounding may differ by an ulp).
    """
    if np.ndim(temperature) == 0:
        return _thermal_ratios_at(oil, float(temperature), reference)
    levels, where = np.unique(np.asarray(temperature, dtype=float), return_inverse=True)
    each = [_thermal_ratios_at(oil, float(t), reference) for t in levels]
    shape = np.shape(temperature)
    return ThermalRatios(*(np.array([getattr(r, name) for r in each])[where].reshape(shape) for name in ("density", "viscosity", "volume")))


def _thermal_ratios_at(oil: Oil, temperature: float, reference: float) -> ThermalRatios:
    if temperature == reference:
        return ThermalRatios(1.0, 1.0, 1.0)
    density = oil.density_at(temperature) / oil.density_at(reference)
    viscosity = oil.kinematic_viscosity(temperature) / oil.kinematic_viscosity(reference) * density
    return ThermalRatios(density, viscosity, 1.0 / density)
