"""Transient roll under a lateral-acceleration step, and the roll frequency response
(docs/model.md §6.6).

A lateral acceleration ``a_y`` acts on the sprung mass as the roll moment ``m_s a_y h_0s``
on the roll DOF (the moment the static ``roll_gradient`` uses). With the exact lumped state
space ``dx/dt = A x + b a_y`` (:meth:`hisopt.coupled.model.CoupledModel.state_space`; ``b`` the
moment on the roll velocity row divided by ``I_x``, :func:`roll_moment_input`), the roll
angle per unit ``a_y`` has the pole-residue form

    H(s) = sum_k r_k / (s - lambda_k),     r_k = (c v_k)(w_k b)

and the step response of size ``a`` is ``phi(t) = a [H(0) + sum_k r_k e^(lambda_k t) /
lambda_k]``; its time derivatives are ``a sum_k r_k lambda_k^(m-1) e^(lambda_k t)``. A
maximum of ``|phi|`` (or of ``|dphi/dt|``) is a root of the next derivative: it is bracketed
on a time grid that resolves every significant mode (vectorised over designs) and refined
by safeguarded Newton steps. ``roll_gain_peak`` is the largest ``|H(j 2 pi f)|`` over
:data:`GAIN_BAND_HZ`, refined off the grid by :func:`hisopt.evaluation.peaks.refine_maximum`.

The body's gravity moment (``[handling] gravity_moment``, docs/model.md §6.4): when the body
rolls by ``phi`` its weight adds ``m_s g h_0s phi``, the moment of a lateral acceleration
``g phi``, so the state matrix gains ``g b`` in the roll angle's column
(:func:`gravity_softened`) and the dynamic stiffness loses ``m_s g h_0s`` on its roll
entry: the transient quantities use the same convention as ``roll_gradient``, and the step
response settles at ``roll_gradient`` times the step.

Designs whose eigenvectors are too ill-conditioned for the residues (checked by the
identities ``phi(0) = 0`` and ``dphi/dt(0) = 0``; e.g. pipes of micrometres) get NaN step
quantities (their gain comes from a direct solve); an unstable design gives NaN. Distributed pipes: the step quantities come from the lumped
state space (pipes as pi-sections), the frequency response from a direct solve of the
distributed model's dynamic stiffness.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Protocol, cast

import numpy as np

from hisopt.constants import G_MPS2
from hisopt.evaluation.peaks import refine_maximum
from hisopt.evaluation.pole_residue import balance
from hisopt.evaluation.psd import roll_gradient

if TYPE_CHECKING:
    from hisopt.coupled.model import CoupledModel, StateSpace
    from hisopt.vehicle import VehicleParams

ROLL = 1
"""Index of the roll angle ``phi`` among the DOFs (``hisopt.constants.DOF_NAMES``)."""

GAIN_BAND_HZ = (0.1, 4.0)
"""[Hz] Band of ``roll_gain_peak``: the handling range of lateral-acceleration inputs."""

STEP_NAMES = ("roll_step_peak", "roll_step_overshoot", "roll_rate_peak")
GAIN_NAMES = ("roll_gain_peak", "roll_gain_peak_hz")
NAMES = STEP_NAMES + GAIN_NAMES
"""The quantities :func:`transient_quantities` computes (:data:`hisopt.metrics.METRICS`)."""

DECAY = np.log(1e4)
"""[-] A mode's envelope counts until it has decayed by ``e^-DECAY`` (1e-4)."""
CYCLES = 20
"""[-] Periods of the slowest significant oscillation searched at most (lightly damped)."""
PER_PERIOD = 12
"""[-] Grid samples per period of the fastest significant oscillation."""
TAIL_SAMPLES = 128
"""[-] Geometric samples from the end of the oscillations to the end of the slow decays."""
SIGNIFICANT = 1e-3
"""[-] A mode is significant when its amplitude in phi or dphi/dt is this share of the largest."""
NEWTON_STEPS = 12
"""[-] Safeguarded Newton steps of each peak (quadratic convergence: a handful suffice)."""
GAIN_SAMPLES = 41
"""[-] Log-spaced samples of the gain band (plus every mode's damped frequency)."""
GAIN_STEPS = 12
"""[-] Parabolic refinement steps of the gain peak (:func:`hisopt.evaluation.peaks.refine_maximum`)."""
RESIDUE_CHECK = 1e-8
"""[-] Relative size of ``phi(0)``, ``dphi/dt(0)`` beyond which residues are not trusted."""


# --- the input ---------------------------------------------------------------------------------
def roll_moment_input(vehicle: VehicleParams, n_states: int) -> np.ndarray:
    """[rad/s^2 per m/s^2] State-space input column of a lateral acceleration ``a_y``.

    The moment ``m_s h_0s a_y`` enters the roll velocity equation (state ``7 + 1``: the
    first 7 states are ``X``, the next 7 the velocities) divided by ``I_x``.

    Parameters
    ----------
    vehicle : VehicleParams
        the car (``m_s`` [kg], ``h_0s`` [m], ``I_x`` [kg m^2])
    n_states : int
        [-] size of the state space
    """
    b = np.zeros(n_states)
    b[7 + ROLL] = vehicle.m_s * vehicle.h_0s / vehicle.I_x
    return b


def gravity_softened(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """[1/s] State matrices ``a`` ``(n, N, N)`` with the body's gravity moment
    ``m_s g h_0s phi`` (module docstring): a lateral acceleration ``g phi``, so ``g b``
    (``b`` ``(n, N)``: :func:`roll_moment_input`) is added to the roll angle's column."""
    out = np.array(a, dtype=float)
    out[..., :, ROLL] += G_MPS2 * b
    return out


def moment_per_acceleration(vehicle: VehicleParams) -> float:
    """[N m per m/s^2] Roll moment of a unit lateral acceleration, ``m_s h_0s``."""
    return vehicle.m_s * vehicle.h_0s


# --- responses in time ------------------------------------------------------------------------
class TimeForm(Protocol):
    """The roll response per unit ``a_y`` of a batch of designs, as functions of time."""

    @property
    def lam(self) -> np.ndarray:
        """[rad/s] Poles ``(n, K)``."""
        ...

    @property
    def static(self) -> np.ndarray:
        """[rad per m/s^2] ``H(0)`` ``(n,)``."""
        ...

    def __call__(self, t: np.ndarray, order: int) -> np.ndarray:
        """``d^order/dt^order`` of the unit step response at times ``t`` [s] ``(n, P)``."""
        ...

    def values(self, t: np.ndarray, orders: Sequence[int]) -> list[np.ndarray]:
        """The derivatives ``orders`` at once (sharing the work)."""
        ...


@dataclass(frozen=True)
class ModalForm:
    """Poles ``lam`` [rad/s] ``(n, K)`` and residues ``res`` [rad/s per m/s^2] ``(n, K)`` of
    the roll angle per unit ``a_y``; ``static`` = ``H(0)`` [rad per m/s^2] ``(n,)``."""

    lam: np.ndarray
    res: np.ndarray
    static: np.ndarray

    def __call__(self, t: np.ndarray, order: int) -> np.ndarray:
        return self.values(t, (order,))[0]

    def values(self, t: np.ndarray, orders: Sequence[int]) -> list[np.ndarray]:
        """``phi^(m)(t)`` for each ``m`` of ``orders`` at times ``t`` [s] ``(n, P)``, sharing
        each mode's ``e^(lambda t)`` (real arithmetic: a conjugate pair is twice the real part
        of its member with ``Im lambda > 0``; LAPACK returns exact pairs)."""
        factor = np.where(self.lam.imag > 0, 2.0, np.where(self.lam.imag < 0, 0.0, 1.0))
        with np.errstate(all="ignore"):
            coeff = [factor * self.res * self.lam ** (m - 1) for m in orders]
        out = [np.zeros(t.shape) for _ in orders]
        for k in range(self.lam.shape[1]):  # a loop over modes; times stay vectorised
            used = factor[:, k] > 0
            if not used.any():
                continue
            lam = self.lam[:, k, None]
            decay = np.exp(np.where(used[:, None], lam.real * t, -np.inf))
            if np.any(lam.imag != 0):
                phase = lam.imag * t
                cos, sin = decay * np.cos(phase), decay * np.sin(phase)
            else:
                cos, sin = decay, np.zeros_like(decay)
            for y, c in zip(out, coeff, strict=True):
                y += c[:, k, None].real * cos - c[:, k, None].imag * sin
        return [y + self.static[:, None] if m == 0 else y for y, m in zip(out, orders, strict=True)]

    def frequency_response(self, f_hz: np.ndarray) -> np.ndarray:
        """[rad per m/s^2] ``H(j 2 pi f)`` at ``f_hz`` ``(n, F)``."""
        s = 2j * np.pi * np.asarray(f_hz)
        return np.sum(self.res[:, None, :] / (s[..., None] - self.lam[:, None, :]), axis=-1)


def modal_form(a: np.ndarray, b: np.ndarray, static: np.ndarray, row: int = ROLL) -> tuple[ModalForm, np.ndarray]:
    """The pole-residue form of ``phi`` per unit ``a_y`` and whether each design's is trusted
    (``row``: the state that is ``phi``).

    Parameters
    ----------
    a : np.ndarray
        [1/s] state matrices ``(n, N, N)``
    b : np.ndarray
        [rad/s^2 per m/s^2] input columns ``(n, N)`` (:func:`roll_moment_input`)
    static : np.ndarray
        [rad per m/s^2] ``H(0)`` by a static solve ``(n,)``
    """
    d = balance(a)  # A_b = D^-1 A D: better conditioned eigenvectors
    a_bal = a * d[:, None, :] / d[:, :, None]
    lam, v = np.linalg.eig(a_bal)
    with np.errstate(all="ignore"):
        w_b = np.linalg.solve(v, (b / d)[..., None])[..., 0]
        res = v[:, row, :] * d[:, row, None] * w_b
        at_zero = static + np.sum(res / lam, axis=1)  # phi(0) = 0
        slope = np.sum(res, axis=1)  # dphi/dt(0) = c b = 0
        size = np.sum(np.abs(res / lam), axis=1)
        trusted = (np.abs(at_zero) <= RESIDUE_CHECK * size) & (np.abs(slope) <= RESIDUE_CHECK * np.sum(np.abs(res), axis=1))
    trusted &= np.all(np.isfinite(res), axis=1) & np.all(np.isfinite(lam), axis=1)
    return ModalForm(lam, res, static), trusted


def stable(lam: np.ndarray) -> np.ndarray:
    """Whether every pole ``lam`` [rad/s] ``(n, K)`` lies in the open left half-plane (as the
    evaluator decides it: ``Re lam <= 1e-9 max |lam|``, finite, no pole at 0)."""
    scale = np.abs(lam).max(axis=1)
    return np.all(np.isfinite(lam), axis=1) & np.all(lam.real <= 1e-9 * scale[:, None], axis=1) & np.all(lam != 0, axis=1)


# --- step response peaks ---------------------------------------------------------------------
def time_grid(lam: np.ndarray, res: np.ndarray) -> np.ndarray:
    """[s] Per design a sorted grid ``(n, P)`` that brackets every peak of ``phi`` and
    ``dphi/dt``.

    The union of one uniform grid per significant oscillating mode, :data:`PER_PERIOD`
    samples per period over its life (until its envelope has fallen by 1e-4, or
    :data:`CYCLES` periods, whichever is first), and :data:`TAIL_SAMPLES` geometric samples
    from the fastest time constant to the end of the slowest decay (creeping modes).

    Parameters
    ----------
    lam, res : np.ndarray
        [rad/s], [rad/s per m/s^2] poles and residues ``(n, K)`` (``res`` only ranks
        the modes: any consistent amplitude will do)
    """
    sigma, omega = -lam.real, lam.imag
    with np.errstate(all="ignore"):
        amp, rate = np.abs(res / lam), np.abs(res)
        big = (amp >= SIGNIFICANT * amp.max(axis=1, keepdims=True)) | (rate >= SIGNIFICANT * rate.max(axis=1, keepdims=True))
        big &= np.isfinite(lam) & (sigma > 0) & (omega >= 0)  # one member of each pair
        life = np.where(big, DECAY / sigma, 0.0)
        period = np.where(omega > 0, 2 * np.pi / omega, np.inf)
        span = np.where(big & (omega > 0), np.minimum(life, CYCLES * period), 0.0)  # (n, K)
        count = np.where(span > 0, np.ceil(PER_PERIOD * span / period), 0).astype(np.int64)
        fast = np.min(np.where(big, 1.0 / np.abs(lam), np.inf), axis=1)
    t_end = np.max(life, axis=1)
    fast = np.where(np.isfinite(fast), fast, 1.0)
    t_end = np.where(t_end > fast, t_end, 10 * fast)
    # Column j of a row belongs to the mode whose block of count samples holds it.
    ends = np.cumsum(count, axis=1)
    width = max(int(ends[:, -1].max(initial=0)), 1)
    j = np.arange(width)
    mode = np.minimum(np.sum(j[None, :, None] >= ends[:, None, :], axis=2), lam.shape[1] - 1)  # (n, width)
    start = np.take_along_axis(ends - count, mode, 1)
    within = (j - start) / np.maximum(np.take_along_axis(count, mode, 1), 1)
    uniform = np.where(j < ends[:, -1:], np.take_along_axis(span, mode, 1) * within, 0.0)
    tail = fast[:, None] * (t_end / fast)[:, None] ** np.linspace(0.0, 1.0, TAIL_SAMPLES)
    return np.sort(np.concatenate([uniform, tail], axis=1), axis=1)


def _local_peak_columns(values: np.ndarray, candidates: int = 2) -> np.ndarray:
    """Columns ``(n, candidates)`` of the largest local maxima of ``values`` ``(n, P)``, largest
    first (a row with fewer repeats its largest sample)."""
    inner = (values[:, 1:-1] >= values[:, :-2]) & (values[:, 1:-1] >= values[:, 2:])
    local = np.zeros(values.shape, dtype=bool)
    local[:, 1:-1] = inner
    local[:, -1] = values[:, -1] >= values[:, -2]
    masked = np.where(local, values, -np.inf)
    order = np.argsort(-masked, axis=1, kind="stable")[:, :candidates]
    found = np.take_along_axis(masked, order, 1)
    return np.where(np.isfinite(found), order, np.argmax(values, axis=1)[:, None])


def refine_peak(form: TimeForm, t: np.ndarray, order: int) -> np.ndarray:
    """Largest ``|phi^(order)|`` over ``t >= 0`` per design from the grid ``t`` ``(n, P)``.

    The two largest local maxima of the samples are followed: each is a root of
    ``phi^(order+1)`` bracketed by its neighbours, found by Newton steps on it (with
    ``phi^(order+2)``) that fall back to bisection when they would leave the bracket.
    """
    return _refine(form, t, order, np.abs(form(t, order)))


def _refine(form: TimeForm, t: np.ndarray, order: int, y: np.ndarray) -> np.ndarray:
    """:func:`refine_peak` from the samples ``y = |phi^(order)(t)|``."""
    n = len(t)
    rows = np.arange(n)[:, None]
    idx = _local_peak_columns(y)
    best = y[rows[:, 0], idx[:, 0]]
    last = t.shape[1] - 1
    a, c = t[rows, np.maximum(idx - 1, 0)], t[rows, np.minimum(idx + 1, last)]
    ga, gc = form(a, order + 1), form(c, order + 1)
    bracketed = np.sign(ga) * np.sign(gc) < 0
    m = t[rows, idx]
    for _ in range(NEWTON_STEPS):  # rtsafe: Newton inside the bracket, else bisection
        g, dg = form.values(m, (order + 1, order + 2))
        left = np.sign(g) == np.sign(ga)
        a, ga = np.where(left, m, a), np.where(left, g, ga)
        c, gc = np.where(left, c, m), np.where(left, gc, g)
        with np.errstate(all="ignore"):
            step = m - g / dg
        inside = np.isfinite(step) & (step > a) & (step < c)
        m = np.where(inside, step, 0.5 * (a + c))
    found = np.where(bracketed, np.abs(form(m, order)), -np.inf)
    return np.maximum(best, found.max(axis=1))


def step_response_peaks(form: TimeForm, step_g: float, t: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """``roll_step_peak`` [rad], ``roll_step_overshoot`` [-] and ``roll_rate_peak`` [rad/s]
    of a lateral-acceleration step of ``step_g`` [g], each ``(n,)``.

    The peak is the supremum of ``|phi(t)|`` over ``t >= 0``: the largest refined maximum,
    or the steady state ``|H(0)| a`` when the response creeps up to it (overshoot 0).

    Parameters
    ----------
    form : TimeForm
        the response per unit ``a_y`` (:class:`ModalForm`)
    step_g : float
        [g] size of the step
    t : np.ndarray | None, optional
        [s] the search grid ``(n, P)`` (default :func:`time_grid` of a modal form)
    """
    a_y = step_g * G_MPS2
    grid = time_grid(form.lam, form.res) if t is None else t  # type: ignore[attr-defined]
    steady = np.abs(form.static)
    phi, rate = (np.abs(y) for y in form.values(grid, (0, 1)))
    peak = np.maximum(_refine(form, grid, 0, phi), steady)
    rate = _refine(form, grid, 1, rate)
    with np.errstate(all="ignore"):
        overshoot = peak / steady - 1.0
    return {"roll_step_peak": a_y * peak, "roll_step_overshoot": overshoot, "roll_rate_peak": a_y * rate}


# --- frequency response ------------------------------------------------------------------------
def gain_nodes(lam: np.ndarray, f_lo_hz: float = GAIN_BAND_HZ[0], f_hi_hz: float = GAIN_BAND_HZ[1]) -> np.ndarray:
    """[Hz] Sorted samples of the gain band ``(n, GAIN_SAMPLES + K)``: log-spaced plus the
    damped frequency of every pole ``lam`` [rad/s] in the band (the upper limit for others)."""
    f_d = np.abs(lam.imag) / (2 * np.pi)
    f_d = np.where((f_d > f_lo_hz) & (f_d < f_hi_hz), f_d, f_hi_hz)
    grid = np.broadcast_to(np.geomspace(f_lo_hz, f_hi_hz, GAIN_SAMPLES), (len(lam), GAIN_SAMPLES))
    return np.sort(np.concatenate([grid, f_d], axis=1), axis=1)


def roll_gain_peak(
    gain_at: Callable[[np.ndarray], np.ndarray], lam: np.ndarray, f_lo_hz: float = GAIN_BAND_HZ[0], f_hi_hz: float = GAIN_BAND_HZ[1]
) -> tuple[np.ndarray, np.ndarray]:
    """[Hz], [rad per m/s^2] Frequency and value of the largest ``|H(j 2 pi f)|`` over the band.

    Sampled at :func:`gain_nodes`, refined off the grid by successive parabolic
    interpolation of ``1/|H|^2`` (:func:`hisopt.evaluation.peaks.refine_maximum`, exact for a
    resonance); a maximum at a band edge stays there.

    Parameters
    ----------
    gain_at : Callable[[np.ndarray], np.ndarray]
        ``|H|`` [rad per m/s^2] at frequencies ``(n, F)`` [Hz]
    lam : np.ndarray
        [rad/s] poles ``(n, K)`` (only their damped frequencies are used)
    """
    f = gain_nodes(lam, f_lo_hz, f_hi_hz)
    power = lambda x: np.square(gain_at(np.clip(x, f_lo_hz, f_hi_hz)))  # noqa: E731
    f_peak, value = refine_maximum(power, f, power(f), GAIN_STEPS)
    return f_peak, np.sqrt(value)


# --- one entry point ---------------------------------------------------------------------------
def transient_quantities(
    model: CoupledModel | StateSpace, vehicle: VehicleParams, names: Sequence[str], step_g: float, gravity_moment: bool
) -> dict[str, np.ndarray]:
    """The transient quantities ``names`` of a batch of designs, each ``(n,)`` (NaN where a
    design is unstable or singular; never raises for one).

    Parameters
    ----------
    model : CoupledModel | StateSpace
        a :class:`~hisopt.coupled.model.CoupledModel` (designs sharing one pattern of shorted
        valves, as :meth:`~hisopt.coupled.model.CoupledModel.groups` gives them) or its state space
    vehicle : VehicleParams
        the car (``m_s``, ``h_0s``, ``I_x``)
    names : Sequence[str]
        quantities from :data:`NAMES`
    step_g : float
        [g] lateral-acceleration step of the step quantities
    gravity_moment : bool
        [-] with the body's gravity moment (module docstring; ``[handling] gravity_moment``)
    """
    unknown = [name for name in names if name not in NAMES]
    if unknown:
        raise ValueError(f"unknown transient quantity {unknown[0]!r}; expected one of {', '.join(NAMES)}")
    groups = _valve_groups(model)
    if len(groups) > 1:
        parts = [(np.asarray(rows), transient_quantities(sub, vehicle, names, step_g, gravity_moment)) for rows, sub in groups]  # rows of groups() are arrays
        total = sum(len(rows) for rows, _ in parts)
        merged = {name: np.full(total, np.nan) for name in names}
        for rows, part in parts:
            for name in names:
                merged[name][rows] = part[name]
        return merged
    roll = _roll_form(groups[0][1], vehicle, gravity_moment)
    form, trusted, ok, a, b, coupled = roll.form, roll.trusted, roll.ok, roll.a, roll.b, roll.coupled
    out = {name: np.full(len(a), np.nan) for name in names}
    if not ok.any():
        return out
    fast = ok & trusted  # untrusted residues: NaN steps (a matrix-exponential fallback was too slow and fragile there)
    if any(name in STEP_NAMES for name in names) and fast.any():
        grid = time_grid(form.lam[fast], form.res[fast])
        with np.errstate(all="ignore"):
            peaks = step_response_peaks(_rows(form, fast), step_g, grid)
        for name in STEP_NAMES:
            if name in out:
                out[name][fast] = peaks[name]
    if any(name in GAIN_NAMES for name in names):
        direct = ~trusted | (coupled is not None and coupled.pipe_model == "distributed")
        rows = ok
        gain = _gain_function(form, direct, a, b, coupled, vehicle, rows, gravity_moment)
        with np.errstate(all="ignore"):
            f_peak, value = roll_gain_peak(gain, form.lam[rows])
        if "roll_gain_peak" in out:
            out["roll_gain_peak"][rows] = value
        if "roll_gain_peak_hz" in out:
            out["roll_gain_peak_hz"][rows] = f_peak
    return out


def step_responses(model: CoupledModel, vehicle: VehicleParams, t_s: np.ndarray, step_g: float, gravity_moment: bool, halves: bool = True) -> np.ndarray:
    """[rad] Roll angle ``phi(t)`` of a batch of designs under a lateral-acceleration step of
    ``step_g`` [g] at times ``t_s`` [s] ``(P,)``, shape ``(n, P)``: the pole-residue form of
    the step quantities (module docstring); NaN where a design is unstable or its residues
    are not trusted (as its ``roll_step_peak``). ``halves``: the form of a model that is its
    own mirror image from its antisymmetric half (the same form to rounding, an eighth of the
    work); False: from the full state space, as :func:`transient_quantities` takes it.
    ``gravity_moment``: with the body's gravity moment (module docstring)."""
    t_s = np.asarray(t_s, dtype=float)
    parts = [(rows, _roll_form(sub, vehicle, gravity_moment, halve=halves)) for rows, sub in _valve_groups(model)]
    out = np.full((sum(len(roll.a) for _, roll in parts), t_s.size), np.nan)
    for rows, roll in parts:
        usable = roll.ok & roll.trusted
        if usable.any():
            with np.errstate(all="ignore"):
                phi = _rows(roll.form, usable)(np.broadcast_to(t_s, (int(usable.sum()), t_s.size)), 0)
            out[(np.arange(len(roll.a)) if rows is None else np.asarray(rows))[usable]] = step_g * G_MPS2 * phi
    return out


@dataclass(frozen=True)
class _RollForm:
    """The roll response per unit ``a_y`` of designs sharing one state space: the modal form,
    whether its residues are trusted, whether the design is stable with a static gain (``ok``),
    the state matrices ``a`` (without the gravity moment: :func:`direct_response` adds it),
    input columns ``b`` and the coupled model (None: a bare state space)."""

    form: ModalForm
    trusted: np.ndarray
    ok: np.ndarray
    a: np.ndarray
    b: np.ndarray
    coupled: CoupledModel | None


def _valve_groups(model: CoupledModel | StateSpace) -> list[tuple[np.ndarray | None, CoupledModel | StateSpace]]:
    """``(rows, model)`` per pattern of shorted valves (one state space each); a bare state
    space or a distributed model is one group, ``rows`` None: all its designs."""
    from hisopt.coupled.model import CoupledModel

    if isinstance(model, CoupledModel) and model.pipe_model == "lumped" and model.his is not None:
        return list(model.groups())
    return [(None, model)]


def _roll_form(model: CoupledModel | StateSpace, vehicle: VehicleParams, gravity_moment: bool, halve: bool = False) -> _RollForm:
    """:class:`_RollForm` of designs sharing one state space (one of :func:`_valve_groups`),
    with the body's gravity moment or not (``gravity_moment``, :func:`gravity_softened`);
    ``halve``: of a model that is its own mirror image, from its antisymmetric half alone
    (:func:`_roll_half`; the same form, an eighth of the eigendecomposition's work)."""
    from hisopt.coupled.model import CoupledModel

    coupled = model if isinstance(model, CoupledModel) else None
    ss = coupled.state_space() if coupled is not None else model
    a = np.asarray(ss.a, dtype=float)  # type: ignore[union-attr]
    a = a.reshape((-1,) + a.shape[-2:])
    n, size = a.shape[:2]
    b = np.broadcast_to(roll_moment_input(vehicle, size), (n, size))
    moved = gravity_softened(a, b) if gravity_moment else a  # the dynamics the step and the gain see
    lumped = coupled is not None and coupled.pipe_model == "lumped"  # a distributed model's state space is its lumped twin's
    if halve and lumped:
        full = cast("StateSpace", ss)  # a coupled model's
        half = _roll_half(coupled, replace(full, a=moved.reshape(np.shape(full.a))) if gravity_moment else full, b)  # type: ignore[arg-type]
    else:
        half = None
    with np.errstate(all="ignore"):
        static = _static_gain(moved, b) if coupled is None else static_roll_gain(coupled, gravity_moment)
        if half is None:
            form, trusted = modal_form(moved, b, static)
            ok = stable(form.lam)
        else:
            form, trusted = modal_form(half[0], half[1], static, half[2])
            ok = stable(form.lam) & stable(np.linalg.eigvals(half[3]))  # the symmetric half's poles too
        ok &= np.isfinite(static) & (static != 0)
        form = ModalForm(form.lam, form.res, np.where(ok, static, 1.0))  # placeholders: those rows stay NaN
    return _RollForm(form, trusted, ok, a, b, coupled)


def _roll_half(model: CoupledModel, ss: StateSpace, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, int, np.ndarray] | None:
    """The roll moment's half of a model that is its own mirror image
    (:func:`hisopt.evaluation.symmetry.split`): a roll moment excites and a roll angle reads only
    the antisymmetric states. Its state matrix, the input ``b`` ``(n, N)`` in its states, the
    state that is the roll angle there, and the symmetric half's state matrix (for stability);
    None when the model has no such halves."""
    from hisopt.evaluation.symmetry import split, state_mirror

    halves = split(ss, state_mirror(model, ss))
    if halves is None:
        return None
    basis = halves["anti"].basis
    roll = np.flatnonzero(basis[ROLL])
    inside = b @ basis
    if roll.size != 1 or basis[ROLL, roll[0]] != 1.0 or not np.array_equal(inside @ basis.T, b):  # the roll is one state there, the moment all in it
        return None
    return halves["anti"].a, inside, int(roll[0]), halves["sym"].a


def static_roll_gain(model: CoupledModel, gravity_moment: bool) -> np.ndarray:
    """[rad per m/s^2] ``H(0)`` per design from the static stiffness (the law of
    ``roll_gradient``, with the body's gravity moment or not): well conditioned where the
    state matrix is not (pipes of 1e-10 m make ``A`` numerically singular, and which
    designs' solves fail then depends on the BLAS kernel)."""
    return np.asarray(roll_gradient(model.stiffness(), model.car, gravity_moment), dtype=float) / G_MPS2


def _static_gain(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """[rad per m/s^2] ``H(0) = -c A^-1 b`` per design (NaN where ``A`` is singular)."""
    try:
        return -np.linalg.solve(a, b[..., None])[:, ROLL, 0]
    except np.linalg.LinAlgError:  # rare: find the singular designs one by one
        out = np.full(len(a), np.nan)
        for i in range(len(a)):
            try:
                out[i] = -np.linalg.solve(a[i], b[i])[ROLL]
            except np.linalg.LinAlgError:
                continue
        return out


def _rows(form: ModalForm, rows: np.ndarray) -> ModalForm:
    return ModalForm(form.lam[rows], form.res[rows], form.static[rows])


def _gain_function(
    form: ModalForm,
    direct: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    coupled: CoupledModel | None,
    vehicle: VehicleParams,
    rows: np.ndarray,
    gravity_moment: bool,
) -> Callable[[np.ndarray], np.ndarray]:
    """``|H|`` at frequencies ``(m, F)`` [Hz] of the designs ``rows``: from poles and residues,
    except for the designs flagged ``direct`` (a dense solve, of the dynamic stiffness when
    there is a model: exact for distributed pipes)."""
    modal = _rows(form, rows)
    solve = direct[rows]
    sub = coupled.subset(np.flatnonzero(rows)[solve]) if coupled is not None and solve.any() else None

    def gain_at(f_hz: np.ndarray) -> np.ndarray:
        h = modal.frequency_response(f_hz)
        if solve.any():
            h[solve] = direct_response(f_hz[solve], a[rows][solve], b[rows][solve], sub, vehicle, gravity_moment)
        return np.abs(h)

    return gain_at


def direct_response(f_hz: np.ndarray, a: np.ndarray, b: np.ndarray, model: CoupledModel | None, vehicle: VehicleParams, gravity_moment: bool) -> np.ndarray:
    """[rad per m/s^2] ``H(j 2 pi f)`` at ``f_hz`` ``(n, F)`` by dense solve: ``m_s h_0s
    [D(s)^-1]_(phi, phi)`` with the model's dynamic stiffness ``D`` (any pipe model), else
    ``c (sI - A)^-1 b`` of the state space ``a`` ``(n, N, N)``, ``b`` ``(n, N)``; with
    ``gravity_moment`` the body's gravity moment softens both (module docstring)."""
    s = 2j * np.pi * np.asarray(f_hz)
    if model is not None:
        kdyn = np.array(model.dynamic_stiffness(s))
        if gravity_moment:
            kdyn[..., ROLL, ROLL] -= G_MPS2 * moment_per_acceleration(vehicle)
        unit = np.zeros(7)
        unit[ROLL] = 1.0
        rhs = np.broadcast_to(unit[:, None], kdyn.shape[:-1] + (1,))
        return moment_per_acceleration(vehicle) * np.linalg.solve(kdyn, rhs)[..., ROLL, 0]
    size = a.shape[-1]
    moved = gravity_softened(a, b) if gravity_moment else a
    lhs = s[..., None, None] * np.eye(size) - moved[:, None]
    rhs = np.broadcast_to(b[:, None, :, None], lhs.shape[:-1] + (1,))
    return np.linalg.solve(lhs, rhs)[..., ROLL, 0]
