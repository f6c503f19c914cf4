"""A payload: a point mass carried by the body (docs/model.md §13)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


class Payload(BaseModel):
    """``[payload]`` or a scenario's ``payload``: a point mass relative to the unladen CG."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    mass: float = Field(0.0, ge=0, description="[kg] payload mass")
    x: float = Field(0.0, description="[m] forward of the unladen CG")
    y: float = Field(0.0, description="[m] to the left of the unladen CG")
    z: float = Field(0.0, description="[m] above the unladen CG")
    I_x: float = Field(0.0, ge=0, description="[kg m^2] roll inertia about its own centre")
    I_y: float = Field(0.0, ge=0, description="[kg m^2] pitch inertia about its own centre")
