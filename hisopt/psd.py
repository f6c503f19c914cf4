"""Road-induced PSD kernels shared by every engine (paper Eq. 24-26; docs/model.md §4-§6).

One kernel each, used by the numpy evaluator, the reference evaluator, sweeps, the CasADi
refinement and the report:

- :func:`track_power`: the two tracks' FRFs (front wheel plus the rear wheel delayed by
  ``tau``) and the output PSD per unit road PSD, with optional left-right coherence;
- :func:`comfort_gain_squared`: the ISO 2631-1 weighting a problem's comfort method uses
  (the analytic filter or the paper's one-third-octave bands);
- :func:`reduce_metrics`: the one dispatch from spectra to quantities (comfort, RMS,
  maximum, static);
- :func:`roll_gradient`: the static roll angle per 1 g;
- :func:`zoom_maximum`: the continuous maximum of a PSD off any grid.

Kernels are arithmetic on their arguments, so they serve numpy arrays (batched over designs
and frequencies) and CasADi expressions alike.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from hisopt.constants import G_MPS2
from hisopt.hydraulics import backend as bk
from hisopt.metrics import COMFORT_OUTPUTS, Metric
from hisopt.standards import iso_2631_1_1997 as iso2631

if TYPE_CHECKING:
    from hisopt.config import Comfort
    from hisopt.vehicle import VehicleParams

Pair = tuple[Any, Any]
"""A complex value as (real, imaginary) parts."""


def track_power(fl: Pair, fr: Pair, rl: Pair, rr: Pair, cos_t: Any, sin_t: Any, coherence: Any = None) -> Any:
    """Output PSD per unit single-track road PSD from the FRFs of the four wheel inputs.

    With ``e = exp(-j omega tau)`` the rear wheels see the front input delayed by
    ``tau = wheelbase / speed``: the left track's FRF is ``l = H_FL + e H_RL``, the right
    one's ``r = H_FR + e H_RR``, and ``S_y / G = |l|^2 + |r|^2 + 2 g Re(l conj r)`` with the
    left-right coherence ``g`` (``None``: independent tracks) (paper Eq. 24).

    Parameters
    ----------
    fl, fr, rl, rr : [output unit / m] FRF of each wheel input as (re, im)
    cos_t, sin_t : [-] ``cos(omega tau)``, ``sin(omega tau)``
    coherence : [-] left-right coherence ``g(f)`` or None
    """
    l_re = fl[0] + cos_t * rl[0] + sin_t * rl[1]
    l_im = fl[1] + cos_t * rl[1] - sin_t * rl[0]
    r_re = fr[0] + cos_t * rr[0] + sin_t * rr[1]
    r_im = fr[1] + cos_t * rr[1] - sin_t * rr[0]
    power = l_re * l_re + l_im * l_im + r_re * r_re + r_im * r_im
    if coherence is not None:
        power = power + 2.0 * coherence * (l_re * r_re + l_im * r_im)
    return power


def comfort_gain_squared(f_hz: np.ndarray, weighting: str, comfort: Comfort, f_lo_hz: float, f_hi_hz: float) -> np.ndarray:
    """``|W(f)|^2`` of an ISO 2631-1 weighting as the problem's comfort method applies it.

    ``"filter"``: the standard's analytic weighting; ``"band"``: the paper's method, the
    weighting's value at each one-third-octave band centre held across the band (Eq. 25-26).
    """
    if comfort.method == "band":
        return iso2631.band_gain_squared(f_hz, weighting, f_lo_hz, f_hi_hz)  # type: ignore[arg-type]
    return iso2631.weighting_gain_squared(f_hz, weighting)  # type: ignore[arg-type]


Integral = Callable[[str, "str | None"], Any]
"""``integral(output, weighting)``: ``integral of |W|^2 S_output df`` (no weighting: ``W = 1``)."""


def reduce_metrics(
    metrics: Sequence[Metric],
    comfort: Comfort,
    weighting_of: Callable[[str], str],
    integral: Integral,
    maximum: Callable[[str], Any],
    static: Callable[[str], Any],
) -> dict[str, Any]:
    """Every metric from its spectra: the one dispatch of docs/model.md §6.

    - ``comfort`` (``sigma_aw``): ``sqrt(sum_axis k_axis^2 integral(|W_axis|^2 S_axis))``;
    - ``rms``: ``sqrt(integral(S))``;
    - ``max``: ``maximum(output)`` (continuous, or over nodes, as the engine provides);
    - ``static``: ``static(name)`` (``roll_gradient``).

    Parameters
    ----------
    weighting_of : the ISO 2631-1 weighting of a comfort output (``"Wk"``, ``"Wd"``)
    integral, maximum, static : the engine's reductions (see :data:`Integral`)
    """
    out: dict[str, Any] = {}
    for m in metrics:
        if m.kind == "comfort":
            total: Any = 0.0
            for axis, name in COMFORT_OUTPUTS.items():
                total = total + getattr(comfort, f"k_{axis}") ** 2 * integral(name, weighting_of(name))
            out[m.name] = bk.sqrt(total)
        elif m.kind == "rms":
            out[m.name] = bk.sqrt(integral(m.output, None))  # type: ignore[arg-type]
        elif m.kind == "max":
            out[m.name] = maximum(m.output)  # type: ignore[arg-type]
        else:
            out[m.name] = static(m.name)
    return out


def roll_gradient(stiffness: Any, vehicle: VehicleParams) -> Any:
    """[rad/g] Static roll angle under the moment ``m_s g h_0s`` on the roll DOF.

    Parameters
    ----------
    stiffness : [N/m, N m/rad] static stiffness ``K + G^T K_his G`` (numpy ``B + (7, 7)`` or
        a CasADi matrix)
    """
    load = np.zeros(7)
    load[1] = vehicle.m_s * G_MPS2 * vehicle.h_0s
    if bk.is_casadi(stiffness):
        return bk.solve(stiffness, load)[1]
    k = np.asarray(stiffness)
    x = np.linalg.solve(k, np.broadcast_to(load[:, None], k.shape[:-1] + (1,)))
    return np.atleast_1d(x[..., 1, 0])


def zoom_maximum(
    values_at: Callable[[np.ndarray], np.ndarray],
    f_hz: np.ndarray,
    values: np.ndarray,
    steps: int,
    points: int = 7,
) -> tuple[np.ndarray, np.ndarray]:
    """[Hz], [value] Continuous maximum of a function sampled at sorted nodes, per row.

    The bracket of the best node (its neighbours) holds the peak when the nodes resolve
    every resonance (pole-aware panels do); each step samples ``points`` evenly in the
    bracket and keeps the neighbours of the best, shrinking it by ``2 / (points - 1)``.

    Parameters
    ----------
    values_at : the function at frequencies ``(n, points)`` [Hz] -> ``(n, points)``
    f_hz, values : nodes and values, ``(n, F)`` (a node of value ``-inf`` is never chosen)
    steps : zoom steps
    """
    rows = np.arange(len(f_hz))
    i = np.argmax(values, axis=1)
    best, f_best = values[rows, i], f_hz[rows, i]
    lo = f_hz[rows, np.maximum(i - 1, 0)]
    hi = f_hz[rows, np.minimum(i + 1, f_hz.shape[1] - 1)]
    t = np.linspace(0.0, 1.0, points)
    for _ in range(steps):
        pts = lo[:, None] + (hi - lo)[:, None] * t
        vals = values_at(pts)
        j = np.argmax(vals, axis=1)
        better = vals[rows, j] > best
        best = np.where(better, vals[rows, j], best)
        f_best = np.where(better, pts[rows, j], f_best)
        lo = pts[rows, np.maximum(j - 1, 0)]
        hi = pts[rows, np.minimum(j + 1, points - 1)]
    return f_best, best
