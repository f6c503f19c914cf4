"""Validated parameters of the 7-DOF full car (docs/model.md §2.5, default vehicle table)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


class VehicleParams(BaseModel):
    """Rigid body on four conventional suspensions and point-contact tyres.

    Defaults are the docs/model.md §2.5 vehicle (an SUV-size car with HIS; they replace the
    paper's Table 4, which did not survive). Front/rear values use suffixes ``f``/``r``.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    m_s: float = Field(1210.0, gt=0, description="[kg] sprung mass")
    I_x: float = Field(390.0, gt=0, description="[kg m^2] roll moment of inertia")
    I_y: float = Field(1920.0, gt=0, description="[kg m^2] pitch moment of inertia")
    m_uf: float = Field(45.0, gt=0, description="[kg] unsprung mass per front wheel")
    m_ur: float = Field(45.0, gt=0, description="[kg] unsprung mass per rear wheel")
    k_sf: float = Field(18_000.0, ge=0, description="[N/m] front suspension spring")
    k_sr: float = Field(18_000.0, ge=0, description="[N/m] rear suspension spring")
    c_sf: float = Field(1_500.0, ge=0, description="[N s/m] front damper")
    c_sr: float = Field(1_500.0, ge=0, description="[N s/m] rear damper")
    k_tf: float = Field(200_000.0, gt=0, description="[N/m] front tyre vertical stiffness")
    k_tr: float = Field(200_000.0, gt=0, description="[N/m] rear tyre vertical stiffness")
    c_tf: float = Field(0.0, ge=0, description="[N s/m] front tyre damping")
    c_tr: float = Field(0.0, ge=0, description="[N s/m] rear tyre damping")
    t_f: float = Field(0.74, gt=0, description="[m] front half track")
    t_r: float = Field(0.74, gt=0, description="[m] rear half track")
    l_f: float = Field(1.13, gt=0, description="[m] CG to front axle")
    l_r: float = Field(1.47, gt=0, description="[m] CG to rear axle")
    h_0s: float = Field(0.30, ge=0, description="[m] CG height above the roll axis")

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
