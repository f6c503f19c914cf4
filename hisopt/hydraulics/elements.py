"""Circuit elements (DESIGN section 2). Each element is data: node names plus parameters.

Parameters may be scalars or arrays of one batch shape (one value per design); everything
downstream broadcasts over that batch. Series elements join two nodes (``a`` -> ``b`` is the
positive flow direction); shunt elements hang one node to the zero-pressure reference.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, Union

import numpy as np
from numpy.typing import ArrayLike

from hisopt.constants import P_ATM_PA
from hisopt.hydraulics.fluid import Fluid
from hisopt.hydraulics import twoport

PipeModel = Literal["lumped", "distributed"]


@dataclass(frozen=True)
class Valve:
    """Linear damper valve between nodes ``a`` and ``b``: ``p_a - p_b = R q`` (paper Eq. 10).

    ``resistance`` [Pa s m^-3]; ``0`` is a short (handled exactly, no regularisation).
    """

    a: str
    b: str
    resistance: ArrayLike


@dataclass(frozen=True)
class Pipe:
    """Circular pipe with laminar friction between nodes ``a`` and ``b``.

    Lumped: series inertance ``rho l / A`` and resistance ``128 mu l / (pi d^4)``, compliance
    ``A l / beta`` split half to each end (a pi-section). Distributed: the uniform line of
    ``twoport.uniform_line`` with the same per-length series impedance and shunt admittance.
    """

    a: str
    b: str
    length: ArrayLike
    diameter: ArrayLike
    fluid: Fluid = field(default_factory=Fluid)

    @property
    def area(self) -> np.ndarray:
        """[m^2] bore area."""
        return np.pi * np.asarray(self.diameter, dtype=float) ** 2 / 4.0

    @property
    def resistance(self) -> np.ndarray:
        """[Pa s m^-3] laminar (Hagen-Poiseuille) resistance."""
        d = np.asarray(self.diameter, dtype=float)
        return 128.0 * self.fluid.mu * np.asarray(self.length, dtype=float) / (np.pi * d**4)

    @property
    def inertance(self) -> np.ndarray:
        """[Pa s^2 m^-3] fluid inertance."""
        return self.fluid.rho * np.asarray(self.length, dtype=float) / self.area

    @property
    def compliance(self) -> np.ndarray:
        """[m^3/Pa] volume compliance of the whole pipe."""
        return self.area * np.asarray(self.length, dtype=float) / self.fluid.beta

    def transfer_matrix(self, s: np.ndarray) -> np.ndarray:
        """Distributed-line transfer matrix.

        Parameters have batch shape ``B``; ``s`` [rad/s] has shape ``(F,)`` or ``B + (F,)``.
        Returns shape ``B + (F, 2, 2)``.
        """
        d = np.asarray(self.diameter, dtype=float)[..., None]
        area = np.pi * d**2 / 4.0
        z = s * self.fluid.rho / area + 128.0 * self.fluid.mu / (np.pi * d**4)
        y = s * area / self.fluid.beta
        return twoport.uniform_line(z, y, np.asarray(self.length, dtype=float)[..., None])


@dataclass(frozen=True)
class Accumulator:
    """Gas-charged accumulator at ``node``, linearised about its precharge.

    ``p = p0 (V0 / (V0 - dV))^gamma`` (absolute pressure) gives the compliance
    ``V0 / (gamma p_abs0)``; a gauge precharge of 0 (atmospheric gas) is valid.
    """

    node: str
    volume: ArrayLike
    precharge_gauge: ArrayLike
    gamma: ArrayLike = 1.4

    @property
    def absolute_precharge(self) -> np.ndarray:
        """[Pa] absolute gas pressure at equilibrium."""
        return np.asarray(self.precharge_gauge, dtype=float) + P_ATM_PA

    @property
    def compliance(self) -> np.ndarray:
        """[m^3/Pa] small-signal volume compliance."""
        return np.asarray(self.volume, dtype=float) / (
            np.asarray(self.gamma, dtype=float) * self.absolute_precharge
        )

    @property
    def stiffness(self) -> np.ndarray:
        """[Pa/m^3] small-signal pressure rise per stored volume, ``gamma p_abs0 / V0``."""
        return 1.0 / self.compliance


@dataclass(frozen=True)
class ChamberCompliance:
    """Oil compressibility of a volume at ``node``: compliance ``V / beta``."""

    node: str
    volume: ArrayLike
    fluid: Fluid = field(default_factory=Fluid)

    @property
    def compliance(self) -> np.ndarray:
        """[m^3/Pa] volume compliance."""
        return np.asarray(self.volume, dtype=float) / self.fluid.beta


SeriesElement = Union[Valve, Pipe]
ShuntElement = Union[Accumulator, ChamberCompliance]
Element = Union[Valve, Pipe, Accumulator, ChamberCompliance]
