"""Validated parameters of the 7-DOF full car (docs/model.md §2.5, default vehicle table)."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from hisopt.quantities import si


class VehicleParams(BaseModel):
    """Rigid body on four conventional suspensions and point-contact tyres.

    Defaults are the docs/model.md §2.5 vehicle (an SUV-size car with HIS; they replace the
    paper's Table 4, which did not survive). Front/rear values use suffixes ``f``/``r``.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    m_s: float = Field(1210.0, gt=0, description="sprung mass", json_schema_extra=si("kg"))
    I_x: float = Field(390.0, gt=0, description="roll moment of inertia", json_schema_extra=si("kg m^2"))
    I_y: float = Field(1920.0, gt=0, description="pitch moment of inertia", json_schema_extra=si("kg m^2"))
    m_uf: float = Field(45.0, gt=0, description="unsprung mass per front wheel", json_schema_extra=si("kg"))
    m_ur: float = Field(45.0, gt=0, description="unsprung mass per rear wheel", json_schema_extra=si("kg"))
    k_sf: float = Field(18_000.0, ge=0, description="front suspension spring", json_schema_extra=si("N/m"))
    k_sr: float = Field(18_000.0, ge=0, description="rear suspension spring", json_schema_extra=si("N/m"))
    c_sf: float = Field(1_500.0, ge=0, description="front damper", json_schema_extra=si("N s/m"))
    c_sr: float = Field(1_500.0, ge=0, description="rear damper", json_schema_extra=si("N s/m"))
    k_arb_f: float = Field(
        0.0, ge=0, description="front anti-roll bar rate at the wheel: force per unit difference of the left and right strokes", json_schema_extra=si("N/m")
    )
    k_arb_r: float = Field(
        0.0, ge=0, description="rear anti-roll bar rate at the wheel: force per unit difference of the left and right strokes", json_schema_extra=si("N/m")
    )
    k_tf: float = Field(200_000.0, gt=0, description="front tyre vertical stiffness", json_schema_extra=si("N/m"))
    k_tr: float = Field(200_000.0, gt=0, description="rear tyre vertical stiffness", json_schema_extra=si("N/m"))
    c_tf: float = Field(0.0, ge=0, description="front tyre damping", json_schema_extra=si("N s/m"))
    c_tr: float = Field(0.0, ge=0, description="rear tyre damping", json_schema_extra=si("N s/m"))
    t_f: float = Field(0.74, gt=0, description="front half track", json_schema_extra=si("m"))
    t_r: float = Field(0.74, gt=0, description="rear half track", json_schema_extra=si("m"))
    l_f: float = Field(1.13, gt=0, description="CG to front axle", json_schema_extra=si("m"))
    l_r: float = Field(1.47, gt=0, description="CG to rear axle", json_schema_extra=si("m"))
    h_0s: float = Field(0.30, ge=0, description="CG height above the roll axis", json_schema_extra=si("m"))
    y_cg: float = Field(
        0.0, description="lateral offset of the CG to the left of the track centre line (a laden car, hisopt.coupled.payload)", json_schema_extra=si("m")
    )
    # The body's extent: read only by the plausibility checks of a payload (hisopt.plausibility),
    # never by the model, which needs no CG height above the road (h_0s is above the roll axis).
    h_cg: float = Field(0.65, gt=0, description="CG height above the road (the body's extent, payload checks only)", json_schema_extra=si("m"))
    body_half_width: float = Field(0.93, gt=0, description="half the body's width (the body's extent, payload checks only)", json_schema_extra=si("m"))
    overhang_f: float = Field(0.90, ge=0, description="body ahead of the front axle (the body's extent, payload checks only)", json_schema_extra=si("m"))
    overhang_r: float = Field(1.00, ge=0, description="body behind the rear axle (the body's extent, payload checks only)", json_schema_extra=si("m"))

    @model_validator(mode="after")
    def _cg_inside_track(self) -> VehicleParams:
        half = min(self.t_f, self.t_r)
        if not abs(self.y_cg) < half:
            raise ValueError(f"y_cg: expected the CG inside the track, |y_cg| < {half:g} m (the smaller half track), got {self.y_cg:g} m")
        return self

    @property
    def wheelbase(self) -> float:
        """[m] front-to-rear axle distance."""
        return self.l_f + self.l_r

    @property
    def total_mass(self) -> float:
        """[kg] sprung plus unsprung mass."""
        return self.m_s + 2.0 * (self.m_uf + self.m_ur)

    def static_wheel_loads(self, g: float = 9.81) -> tuple[float, float]:
        """[N] static vertical load of one front and one rear wheel (sprung share by lever rule)."""
        front = 0.5 * self.m_s * g * self.l_r / self.wheelbase + self.m_uf * g
        rear = 0.5 * self.m_s * g * self.l_f / self.wheelbase + self.m_ur * g
        return front, rear

    def static_corner_loads(self, g: float = 9.81) -> np.ndarray:
        """[N] static vertical load of each wheel FL, FR, RL, RR, shape (4,).

        The sprung weight splits between the axles by the lever rule (exact: the car is
        statically determinate in pitch) and, on each axle, between its wheels by the lateral
        lever rule about the CG offset ``y_cg`` (exact for ``y_cg = 0``; with an offset it
        assumes each axle's share of the roll stiffness equals its share of the load).
        """
        unsprung = np.array([self.m_uf, self.m_uf, self.m_ur, self.m_ur]) * g
        return sprung_corner_loads(self, g) + unsprung


def sprung_corner_loads(vehicle: Any, g: float = 9.81) -> np.ndarray:
    """[N] The sprung weight each corner's suspension carries at rest, FL, FR, RL, RR, shape
    ``B + (4,)`` for a car or a batch of cars (:class:`~hisopt.vehicle.batch.VehicleBatch`):
    between the axles by the lever rule (exact), on each axle between its wheels by the
    lateral lever rule about the CG offset ``y_cg`` (:meth:`VehicleParams.static_corner_loads`)."""
    m_s, l_f, l_r, t_f, t_r, y = (np.asarray(getattr(vehicle, k), dtype=float) for k in ("m_s", "l_f", "l_r", "t_f", "t_r", "y_cg"))
    front, rear = m_s * g * l_r / (l_f + l_r), m_s * g * l_f / (l_f + l_r)  # both wheels of an axle
    left_f, left_r = 0.5 + 0.5 * y / t_f, 0.5 + 0.5 * y / t_r
    return np.stack(np.broadcast_arrays(front * left_f, front * (1.0 - left_f), rear * left_r, rear * (1.0 - left_r)), axis=-1)
