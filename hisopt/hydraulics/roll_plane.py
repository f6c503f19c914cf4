"""Roll-plane HIS builder (paper Fig. 3, Eq. 15; DESIGN section 2).

Circuit A joins chambers 1t, 2b, 3t, 4b and circuit B joins 1b, 2t, 3b, 4t; one accumulator
per circuit and one damper valve per cylinder on its bottom-chamber line. Optional pipes run
from each cylinder port to its circuit node; optional chamber compliances sit at the ports.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike
from pydantic import BaseModel, ConfigDict, Field, model_validator

from hisopt.hydraulics.circuit import Circuit, Cylinders, HydraulicSystem, Port
from hisopt.hydraulics.elements import (
    Accumulator,
    ChamberCompliance,
    Element,
    Pipe,
    PipeModel,
    Valve,
)
from hisopt.hydraulics.fluid import Fluid

CIRCUIT_CHAMBERS: dict[str, tuple[tuple[int, Literal["top", "bottom"]], ...]] = {
    "A": ((0, "top"), (1, "bottom"), (2, "top"), (3, "bottom")),
    "B": ((0, "bottom"), (1, "top"), (2, "bottom"), (3, "top")),
}


class PipeLayout(BaseModel):
    """A pipe from every cylinder port to its circuit node (DESIGN example pipe set)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    diameter: float = Field(0.010, gt=0, description="[m] inner diameter")
    length_front: float = Field(1.0, gt=0, description="[m] front port to circuit node")
    length_rear: float = Field(2.5, gt=0, description="[m] rear port to circuit node")


class RollPlaneHIS(BaseModel):
    """Parameters of the roll-plane HIS; the four paper variables first (paper Table 2).

    Rear-axle ``dA``, ``lam`` and ``Rv`` are tied to the front ones unless given.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    p0: float = Field(2.0e6, ge=0, description="[Pa] accumulator gauge precharge")
    dA: float = Field(10e-4, gt=0, description="[m^2] bore minus annulus area A_b - A_t")
    lam: float = Field(0.5, gt=0, lt=1, description="[-] area ratio A_t / A_b")
    Rv: float = Field(8e5, ge=0, description="[Pa s m^-3] damper valve coefficient")
    dA_rear: float | None = Field(None, gt=0, description="[m^2] rear dA (None: = dA)")
    lam_rear: float | None = Field(None, gt=0, lt=1, description="[-] rear lam (None: = lam)")
    Rv_rear: float | None = Field(None, ge=0, description="[Pa s m^-3] rear Rv (None: = Rv)")
    V0: float = Field(1.0e-3, gt=0, description="[m^3] accumulator gas volume at precharge")
    gamma: float = Field(1.4, ge=1.0, description="[-] polytropic exponent of the gas")
    chamber_volume: float = Field(0.0, ge=0, description="[m^3] oil volume per chamber (0: off)")
    fluid: Fluid = Field(default_factory=Fluid)
    pipes: PipeLayout | None = None
    pipe_model: PipeModel = "lumped"

    @model_validator(mode="after")
    def _distributed_needs_pipes(self) -> "RollPlaneHIS":
        if self.pipe_model == "distributed" and self.pipes is None:
            raise ValueError("pipe_model = 'distributed' needs a [his.pipes] layout")
        return self


def cylinder_areas(dA: ArrayLike, lam: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Top (annulus) and bottom (bore) areas from ``dA = A_b - A_t`` and ``lam = A_t / A_b``.

    Returns ``(A_t, A_b)`` [m^2]: ``A_b = dA / (1 - lam)``, ``A_t = lam dA / (1 - lam)``.
    """
    dA = np.asarray(dA, dtype=float)
    lam = np.asarray(lam, dtype=float)
    a_b = dA / (1.0 - lam)
    return lam * a_b, a_b


def roll_plane_system(params: dict[str, ArrayLike], base: RollPlaneHIS | None = None) -> HydraulicSystem:
    """Build the roll-plane HIS for one design or a batch of designs.

    Parameters
    ----------
    params : overrides of :class:`RollPlaneHIS` fields (``p0``, ``dA``, ``lam``, ``Rv``, ...);
        each a scalar or an array of one common batch shape ``B`` (one value per design)
    base : fixed parameters (defaults when omitted)
    """
    base = base or RollPlaneHIS()
    get = lambda k: np.asarray(params[k], dtype=float) if k in params else getattr(base, k)  # noqa: E731

    def rear(key: str) -> np.ndarray:
        value = get(f"{key}_rear")
        return get(key) if value is None else value

    dA_f, lam_f, rv_f = get("dA"), get("lam"), get("Rv")
    dA_r, lam_r, rv_r = rear("dA"), rear("lam"), rear("Rv")
    at_f, ab_f = cylinder_areas(dA_f, lam_f)
    at_r, ab_r = cylinder_areas(dA_r, lam_r)
    top = np.stack(np.broadcast_arrays(at_f, at_f, at_r, at_r), axis=-1)
    bottom = np.stack(np.broadcast_arrays(ab_f, ab_f, ab_r, ab_r), axis=-1)

    circuits = []
    for name, chambers in CIRCUIT_CHAMBERS.items():
        elements: list[Element] = [Accumulator(name, get("V0"), get("p0"), get("gamma"))]
        ports = []
        for wheel, chamber in chambers:
            front = wheel < 2
            port_node = f"{name}.{wheel + 1}{chamber[0]}"
            # The chamber's line: damper valve (bottom chambers only), then pipe, to the node.
            pipe_start = port_node
            if chamber == "bottom":
                pipe_start = name if base.pipes is None else f"{port_node}.valve"
                elements.append(Valve(port_node, pipe_start, rv_f if front else rv_r))
            elif base.pipes is None:
                port_node = name  # a top chamber with no pipe sits on the circuit node
            if base.pipes is not None:
                length = base.pipes.length_front if front else base.pipes.length_rear
                elements.append(Pipe(pipe_start, name, length, base.pipes.diameter, base.fluid))
            if base.chamber_volume > 0:
                elements.append(ChamberCompliance(port_node, base.chamber_volume, base.fluid))
            ports.append(Port(port_node, wheel, chamber))
        circuits.append(Circuit(name, tuple(elements), tuple(ports)))
    return HydraulicSystem(Cylinders(top, bottom), tuple(circuits))
