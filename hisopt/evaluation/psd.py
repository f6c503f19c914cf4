"""Road-induced PSD kernels shared by every engine (paper Eq. 24-26; docs/model.md §4-§6).

One kernel each, used by the numpy evaluator, the reference evaluator, sweeps, the CasADi
refinement and the report:

- :func:`channel_power`: the output PSD per unit road PSD from the two road channels (tracks
  together, tracks apart; each a front input plus the rear input delayed by ``tau``), with
  optional left-right coherence;
- :func:`comfort_gain_squared`: the ISO 2631-1 weighting a problem's comfort method uses
  (the analytic filter or the paper's one-third-octave bands);
- :func:`reduce_metrics`: the one dispatch from spectra to quantities (comfort, RMS,
  maximum, static);
- :func:`roll_gradient`: the static roll angle per 1 g;

Kernels are arithmetic on their arguments, so they serve numpy arrays (batched over designs
and frequencies) and CasADi expressions alike.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from hisopt.constants import G_MPS2
from hisopt.coupled.model import gravity_stiffness
from hisopt.hydraulics import backend as bk
from hisopt.metrics import COMFORT_OUTPUTS, Metric
from hisopt.standards import iso_2631_1_1997 as iso2631

if TYPE_CHECKING:
    from hisopt.specification.config import Comfort
    from hisopt.vehicle import VehicleParams
    from hisopt.vehicle.batch import VehicleBatch

Pair = tuple[Any, Any]
"""A complex value as (real, imaginary) parts."""


def channel_power(sym: tuple[Pair, Pair], anti: tuple[Pair, Pair], cos_t: Any, sin_t: Any, coherence: Any = None) -> Any:
    """Output PSD per unit single-track road PSD from the two road channels' FRFs.

    Each track's rear wheel sees the front input delayed by ``tau = wheelbase / speed``
    (``e = exp(-j omega tau)``). With ``H_s = h_L + h_R`` the response to both tracks moving
    together and ``H_a = h_L - h_R`` to them moving apart (each ``front + e rear``), tracks of
    equal PSD ``G`` and coherence ``g`` give ``S_y / G = [(1+g) |H_s|^2 + (1-g) |H_a|^2] / 2``,
    which is ``|h_L|^2 + |h_R|^2 + 2 g Re(h_L conj h_R)`` (paper Eq. 24, docs/model.md §4.4).

    Parameters
    ----------
    sym, anti : tuple[Pair, Pair]
        [output unit / m] each channel's FRF of the front-axle and rear-axle inputs,
        as ((re, im), (re, im))
    cos_t, sin_t : Any
        [-] ``cos(omega tau)``, ``sin(omega tau)``
    coherence : Any, optional
        [-] left-right coherence ``g(f)`` or None (independent tracks)
    """

    # Each channel: front + e rear, e = cos - j sin (written out: numba compiles this).
    (sf_re, sf_im), (sr_re, sr_im) = sym
    (af_re, af_im), (ar_re, ar_im) = anti
    s_re = sf_re + cos_t * sr_re + sin_t * sr_im
    s_im = sf_im + cos_t * sr_im - sin_t * sr_re
    a_re = af_re + cos_t * ar_re + sin_t * ar_im
    a_im = af_im + cos_t * ar_im - sin_t * ar_re
    together, apart = s_re * s_re + s_im * s_im, a_re * a_re + a_im * a_im
    if coherence is None:
        return 0.5 * (together + apart)
    return 0.5 * ((1.0 + coherence) * together + (1.0 - coherence) * apart)


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
    transient: Callable[[str], Any] | None = None,
    rooms: Callable[[], Sequence[Any]] | None = None,
    build: Callable[[str], Any] | None = None,
) -> dict[str, Any]:
    """Every metric from its spectra: the one dispatch of docs/model.md §6.

    - ``comfort`` (``sigma_aw``): ``sqrt(sum_axis k_axis^2 integral(|W_axis|^2 S_axis))``;
    - ``rms``: ``sqrt(integral(S))``;
    - ``max``: ``maximum(output)`` (continuous, or over nodes, as the engine provides);
    - ``static``: ``static(name)`` (``roll_gradient``);
    - ``transient``: ``transient(name)`` (:mod:`hisopt.evaluation.transient`; an engine without it
      raises ``ValueError`` naming the quantity);
    - ``swing`` (``accumulator_swing``): the largest ``sqrt(integral(S_oil_volume_j)) / room_j``
      over the accumulators, ``rooms()`` their static rooms
      (:func:`hisopt.coupled.operating_point.accumulator_rooms`; NaN without accumulators);
    - ``build``: ``build(name)``, a buildability rule's usage (:mod:`hisopt.coupled.buildability`;
      an engine without it raises ``ValueError`` naming the quantity).

    Parameters
    ----------
    weighting_of : Callable[[str], str]
        the ISO 2631-1 weighting of a comfort output (``"Wk"``, ``"Wd"``)
    integral, maximum, static, transient
        the engine's reductions (see :data:`Integral`)
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
        elif m.kind == "transient":
            if transient is None:
                raise ValueError(f"{m.name}: this engine has no transient roll quantities")
            out[m.name] = transient(m.name)
        elif m.kind == "swing":
            if rooms is None:
                raise ValueError(f"{m.name}: this engine has no accumulator oil volumes")
            worst: Any = math.nan
            for j, room in enumerate(rooms()):
                share = bk.sqrt(integral(f"oil_volume_{j}", None)) / room
                worst = share if j == 0 else bk.fmax(worst, share)
            out[m.name] = worst
        elif m.kind == "build":
            if build is None:
                raise ValueError(f"{m.name}: this engine has no buildability rules")
            out[m.name] = build(m.name)
        else:
            out[m.name] = static(m.name)
    return out


def roll_gradient(stiffness: Any, vehicle: VehicleParams | VehicleBatch, gravity_moment: bool) -> Any:
    """[rad/g] Static roll angle under the moment ``m_s g h_0s`` on the roll DOF (docs/model.md §6.4).

    With ``gravity_moment`` the body's weight adds ``m_s g h_0s phi`` when it rolls by
    ``phi`` about the roll axis (its CG moves ``h_0s phi`` sideways): the roll entry of the
    stiffness is reduced by ``m_s g h_0s``, so the rigid car's ``phi = M / k`` becomes
    ``M / (k - m_s g h_0s)``. Without it, the paper's convention (the moment of the lateral
    force alone).

    Parameters
    ----------
    stiffness : Any
        [N/m, N m/rad] static stiffness ``K + G^T K_his G`` (numpy ``B + (7, 7)`` or
        a CasADi matrix)
    vehicle : VehicleParams | VehicleBatch
        the car (``m_s`` [kg], ``h_0s`` [m]; one per design of a batch)
    gravity_moment : bool
        [-] include the body's gravity moment (``[handling] gravity_moment``)
    """
    moment = vehicle.m_s * G_MPS2 * vehicle.h_0s  # one per car of a batch
    load = np.zeros(np.shape(moment) + (7,))
    load[..., 1] = moment
    k = gravity_stiffness(stiffness, vehicle, gravity_moment)
    if bk.is_casadi(k):
        return bk.solve(k, load)[1]
    x = np.linalg.solve(k, np.broadcast_to(load[..., None], k.shape[:-1] + (1,)))
    return np.atleast_1d(x[..., 1, 0])
