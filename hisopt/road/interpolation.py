"""Road displacement at the wheels between samples, for time-domain simulation.

A road record (``(n_t, 4)`` displacements under FL, FR, RL, RR at increasing times, e.g. from
:mod:`hisopt.road.profiles`) is read between samples by a piecewise cubic Hermite (or linear)
interpolant, evaluated in plain Python per solver stage.
"""

from __future__ import annotations

from bisect import bisect_right
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicSpline, PchipInterpolator

from hisopt.errors import ConfigError

Interpolation = Literal["pchip", "cubic", "linear"]
"""How the road is read between samples: ``"pchip"`` (shape-preserving cubic, C1: steps stay
steps), ``"cubic"`` (C2 spline: smoothest, best for sampled random roads; rings at steps) or
``"linear"`` (kinks at every sample, which slow the integrator down)."""


class RoadInput:
    """Road displacement at the four wheels between samples, held outside the record.

    Piecewise cubic Hermite (or linear) in time, evaluated in plain Python per solver stage.

    Parameters
    ----------
    t_s
        [s] Increasing sample times, shape ``(n_t,)``.
    z_m
        [m] Displacements under FL, FR, RL, RR, shape ``(n_t, 4)``, or ``(n_t, 4, k)`` for
        ``k`` roads read at once (a batch of simulations sharing one integrator).
    interpolation
        See :data:`Interpolation`.
    """

    def __init__(self, t_s: ArrayLike, z_m: ArrayLike, interpolation: Interpolation = "pchip"):
        t = np.asarray(t_s, dtype=float)
        z = np.asarray(z_m, dtype=float)
        if t.ndim != 1 or t.size < 2 or not np.all(np.diff(t) > 0):
            raise ConfigError(f"expected t_s 1-D and increasing with >= 2 samples, got shape {t.shape}")
        if z.shape[:2] != (t.size, 4) or z.ndim not in (2, 3):
            raise ConfigError(f"expected road_m of shape ({t.size}, 4) (FL, FR, RL, RR) or ({t.size}, 4, k), got {z.shape}")
        if not np.all(np.isfinite(z)):
            raise ConfigError("road_m contains NaN or inf")
        if interpolation not in ("pchip", "cubic", "linear"):
            raise ConfigError(f"unknown interpolation {interpolation!r}; expected 'pchip', 'cubic' or 'linear'")
        self.t_s, self.z_m, self.interpolation = t, z, interpolation
        self._h = np.diff(t)
        self._secant = np.diff(z, axis=0) / self._h.reshape((-1,) + (1,) * (z.ndim - 1))
        if interpolation == "pchip":
            self.slopes = PchipInterpolator(t, z, axis=0).derivative()(t)
        elif interpolation == "cubic":
            self.slopes = CubicSpline(t, z, axis=0).derivative()(t)
        else:
            self.slopes = np.gradient(z, t, axis=0)
        self._t_list = t.tolist()  # plain floats: one look-up per solver stage

    def _segment(self, t: float) -> tuple[int, float]:
        i = min(max(bisect_right(self._t_list, t) - 1, 0), len(self._t_list) - 2)
        return i, (t - self._t_list[i]) / self._h[i]

    def value(self, t: float) -> NDArray[np.float64]:
        """[m] Displacements at time ``t`` [s], shape ``(4,)`` (``(4, k)`` for a batch)."""
        if t <= self._t_list[0]:
            return self.z_m[0]
        if t >= self._t_list[-1]:
            return self.z_m[-1]
        i, x = self._segment(t)
        if self.interpolation == "linear":
            return self.z_m[i] + x * self._h[i] * self._secant[i]
        # Cubic Hermite basis on the segment, x in [0, 1].
        x2 = x * x
        x3 = x2 * x
        h = self._h[i]
        return (
            (2 * x3 - 3 * x2 + 1) * self.z_m[i]
            + (x3 - 2 * x2 + x) * h * self.slopes[i]
            + (3 * x2 - 2 * x3) * self.z_m[i + 1]
            + (x3 - x2) * h * self.slopes[i + 1]
        )

    def rate(self, t: float) -> NDArray[np.float64]:
        """[m/s] Time derivative of the interpolant at ``t`` [s] (0 outside the record), ``(4,)``
        (``(4, k)`` for a batch)."""
        if t < self._t_list[0] or t >= self._t_list[-1]:
            return np.zeros(self.z_m.shape[1:])
        i, x = self._segment(t)
        if self.interpolation == "linear":
            return self._secant[i]
        x2 = x * x
        return 6 * (x - x2) * self._secant[i] + (3 * x2 - 4 * x + 1) * self.slopes[i] + (3 * x2 - 2 * x) * self.slopes[i + 1]

    def sampled_rate(self) -> NDArray[np.float64]:
        """[m/s] Rate at the samples, shape ``(n_t, 4)`` or ``(n_t, 4, k)`` (central differences if linear)."""
        return self.slopes


# --- systems -------------------------------------------------------------------------------
