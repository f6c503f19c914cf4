"""Constitutive laws of the HIS, each written once (docs/model.md §3).

Every function is arithmetic on its arguments (plus :mod:`hisopt.hydraulics.backend` for the
few operations numpy and CasADi spell differently), so the numpy evaluator, the CasADi
refinement and the time-domain simulator all evaluate the same expressions: floats, numpy
arrays of any (broadcast) shape, or CasADi symbols.

Units are SI: pressures in Pa (``p_abs`` absolute, otherwise gauge), volumes in m^3, flows in
m^3/s, areas in m^2, lengths in m.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np

from hisopt.constants import P_ATM_PA
from hisopt.hydraulics import backend as bk

Chamber = Literal["top", "bottom"]


# --- cylinders ---------------------------------------------------------------------------------
def bore_and_rod_parameters(bore: Any, rod: Any) -> tuple[Any, Any]:
    """The paper's ``(dA, lam)`` of a cylinder of bore diameter ``bore`` and piston-rod
    diameter ``rod`` [m] (docs/model.md §3.1): the bore area ``A_b = pi bore^2 / 4`` is the
    bottom chamber's, the annulus ``A_t = pi (bore^2 - rod^2) / 4`` the top's, so
    ``dA = A_b - A_t = pi rod^2 / 4`` (the rod's area) and ``lam = A_t / A_b = 1 - (rod / bore)^2``.

    Returns
    -------
    dA, lam : Any
        [m^2], [-]; ``lam`` in (0, 1) when ``0 < rod < bore``
    """
    ratio = rod / bore
    return 0.25 * math.pi * rod * rod, 1.0 - ratio * ratio


def bore_and_rod(dA: Any, lam: Any) -> tuple[Any, Any]:
    """[m] The bore and rod diameters of a cylinder of the paper's ``dA`` [m^2] and ``lam`` [-]:
    the inverse of :func:`bore_and_rod_parameters`, ``rod = sqrt(4 dA / pi)``,
    ``bore = rod / sqrt(1 - lam)``."""
    rod = (4.0 * dA / math.pi) ** 0.5
    return rod / (1.0 - lam) ** 0.5, rod


def cylinder_areas(dA: Any, lam: Any) -> tuple[Any, Any]:
    """Top (annulus) and bottom (bore) areas from the paper's design variables.

    ``dA = A_b - A_t`` and ``lam = A_t / A_b`` give ``A_b = dA / (1 - lam)`` and
    ``A_t = lam A_b``.

    Parameters
    ----------
    dA : Any
        [m^2] bore minus annulus area, > 0
    lam : Any
        [-] annulus over bore area, in (0, 1)

    Returns
    -------
    A_t, A_b : Any
        [m^2]
    """
    a_b = dA / (1.0 - lam)
    return lam * a_b, a_b


def chamber_area(a_top: Any, a_bottom: Any, chamber: Chamber) -> Any:
    """[m^2] Signed area ``a`` of a chamber: the flow it pushes into its circuit per unit
    stroke extension (``q = a d(delta)/dt``): ``+A_t`` for the top (rod-side annulus, which
    shrinks as the strut extends), ``-A_b`` for the bottom (bore) chamber."""
    return a_top if chamber == "top" else -a_bottom


# --- gas-charged accumulator -------------------------------------------------------------------
def absolute_pressure(p_gauge: Any) -> Any:
    """[Pa] Absolute pressure of a gauge pressure [Pa]."""
    return p_gauge + P_ATM_PA


def gas_pressure_rise(dv: Any, v0: Any, p_abs0: Any, gamma: Any) -> Any:
    """[Pa] Pressure rise above the operating point when oil takes ``dv`` of the gas volume.

    Polytropic law ``p_abs = p_abs0 (V0 / (V0 - dV))^gamma``; its slope at ``dV = 0`` is the
    linear stiffness ``gamma p_abs0 / V0``.

    Parameters
    ----------
    dv : Any
        [m^3] oil stored (gas volume lost), < V0
    v0 : Any
        [m^3] gas volume at the operating point
    p_abs0 : Any
        [Pa] absolute gas pressure at the operating point
    gamma : Any
        [-] polytropic exponent
    """
    return p_abs0 * ((v0 / (v0 - dv)) ** gamma - 1.0)


def gas_volume(p: Any, v0: Any, p_abs0: Any, gamma: Any) -> Any:
    """[m^3] Oil stored at a pressure rise ``p`` [Pa] above the operating point (inverse of
    :func:`gas_pressure_rise`): ``dV = V0 (1 - (p_abs0 / (p_abs0 + p))^(1/gamma))``."""
    return v0 * (1.0 - (p_abs0 / (p_abs0 + p)) ** (1.0 / gamma))


def gas_compliance(p: Any, v0: Any, p_abs0: Any, gamma: Any) -> Any:
    """[m^3/Pa] Tangent compliance ``d(dV)/dp`` at a pressure rise ``p`` [Pa]:
    ``V0 / (gamma p_abs) (p_abs0 / p_abs)^(1/gamma)``; ``V0 / (gamma p_abs0)`` at ``p = 0``."""
    p_abs = p_abs0 + p
    return v0 / (gamma * p_abs) * (p_abs0 / p_abs) ** (1.0 / gamma)


def accumulator_compliance(v_gas: Any, p_abs: Any, gamma: Any) -> Any:
    """[m^3/Pa] Small-signal compliance ``V / (gamma p_abs)`` of a gas volume ``V`` [m^3] at
    absolute pressure ``p_abs`` [Pa] (the linearised polytropic law)."""
    return v_gas / (gamma * p_abs)


def accumulator_stiffness(v_gas: Any, p_abs: Any, gamma: Any) -> Any:
    """[Pa/m^3] Small-signal stiffness ``gamma p_abs / V``, the inverse of
    :func:`accumulator_compliance`."""
    return gamma * p_abs / v_gas


def gas_pressure_at_temperature(p_abs: Any, temperature_ratio: Any) -> Any:
    """[Pa] Absolute pressure of a gas held at constant volume when its temperature changes
    by the ratio ``T / T_ref`` (ideal gas: ``p V = m R T``)."""
    return p_abs * temperature_ratio


def gauge_pressure_ratio(p_abs: Any, p0_abs: Any) -> Any:
    """[-] ``p_gauge / p0_gauge`` of an accumulator at absolute pressure ``p_abs`` with absolute
    precharge ``p0_abs`` [Pa] (both at the same temperature): the ratio the makers rate a
    separator for, in gauge (docs/model.md §16.8). A precharge at or below atmospheric
    pressure holds the separator against nothing: ``+inf`` (a failure of any rating, never NaN)."""
    held = p0_abs - P_ATM_PA
    charged = held > 0.0
    return bk.where(charged, (p_abs - P_ATM_PA) / bk.where(charged, held, 1.0), math.inf)


def isothermal_gas_volume(p_abs: Any, content: Any) -> Any:
    """[m^3] Volume of a gas of ``content = p V`` [Pa m^3] (``m R T`` at its temperature) at
    absolute pressure ``p_abs`` [Pa]: the static law, the gas at the oil's temperature."""
    return content / p_abs


def charge_pressure(p0_abs: Any, gas_fraction: Any) -> Any:
    """[Pa] Absolute pressure of a circuit charged until its accumulator's gas, precharged
    to ``p0_abs`` at the full volume, fills ``gas_fraction`` of it (slow charging: isothermal)."""
    return p0_abs / gas_fraction


# --- oil volumes -------------------------------------------------------------------------------
def oil_compliance(volume: Any, beta: Any) -> Any:
    """[m^3/Pa] Compressibility ``V / beta`` of an oil volume ``V`` [m^3], bulk modulus [Pa]."""
    return volume / beta


# --- valves ------------------------------------------------------------------------------------
def valve_pressure_drop(q: Any, r: Any, kq: Any = 0.0) -> Any:
    """[Pa] Damper valve law ``dp = R q + K_q q |q|`` (paper Eq. 10 plus a turbulent term).

    Parameters
    ----------
    q : Any
        [m^3/s] flow in the direction of the drop
    r : Any
        [Pa s m^-3] linear (laminar) coefficient; 0 is a short
    kq : Any, optional
        [Pa s^2 m^-6] orifice coefficient; a sharp-edged orifice of area ``A_o`` and
        discharge coefficient ``C_d`` has ``K_q = rho / (2 C_d^2 A_o^2)``
    """
    return r * q + kq * q * bk.fabs(q)


def viscous_resistance(r: Any, laminar_fraction: Any, viscosity_ratio: Any, density_ratio: Any) -> Any:
    """[Pa s m^-3] A valve's linear coefficient ``R`` (given at the reference temperature) at
    another temperature: its laminar part follows the viscosity, its orifice part the density
    (a turbulent orifice's drop is ``rho q^2 / (2 C_d^2 A^2)``, viscosity-free):

        R(T) = R [f mu(T) / mu_ref + (1 - f) rho(T) / rho_ref]

    with ``f`` = ``laminar_fraction``."""
    return r * (laminar_fraction * viscosity_ratio + (1.0 - laminar_fraction) * density_ratio)


def valve_tangent_resistance(q: Any, r: Any, kq: Any = 0.0) -> Any:
    """[Pa s m^-3] ``d(dp)/dq = R + 2 K_q |q|`` of :func:`valve_pressure_drop`."""
    return r + 2.0 * kq * bk.fabs(q)


def orifice_equivalent_resistance(r: Any, kq: Any, q_rms: Any) -> Any:
    """[Pa s m^-3] Equivalent linear resistance of the orifice law ``dp = R q + K_q q |q|`` for
    a zero-mean Gaussian flow of RMS value ``q_rms`` (statistical linearisation):

        R_eq = R + 2 sqrt(2 / pi) K_q q_rms

    the slope ``c`` minimising ``E[(K_q q |q| - c q)^2]``, which equals the mean tangent
    ``E[2 K_q |q|]`` (``E|q| = sqrt(2 / pi) q_rms``). At ``q_rms = 0`` it is the laminar part
    ``R`` alone: a sharp-edged orifice has no small-signal resistance at zero flow.

    Parameters
    ----------
    r : Any
        [Pa s m^-3] laminar (linear) coefficient
    kq : Any
        [Pa s^2 m^-6] quadratic coefficient
    q_rms : Any
        [m^3/s] RMS flow through the orifice at which to linearise
    """
    return r + 2.0 * math.sqrt(2.0 / math.pi) * kq * q_rms


# --- physical damper valves -----------------------------------------------------------------
def orifice_coefficient(diameter: Any, discharge_coefficient: Any, rho: Any) -> Any:
    """[Pa s^2 m^-6] ``K = rho / (2 C_d^2 A^2)`` of a sharp-edged orifice of ``diameter`` [m]
    and discharge coefficient [-] in oil of density ``rho`` [kg/m^3]: ``dp = K q |q|``
    (Bernoulli through the vena contracta, ``q = C_d A sqrt(2 dp / rho)``)."""
    area = 0.25 * math.pi * diameter * diameter
    return rho / (2.0 * discharge_coefficient * discharge_coefficient * area * area)


def _blowoff_drop(aq: Any, kq: Any, cracking: Any, blowoff: Any) -> Any:
    """[Pa] The valve's drop at a flow ``aq = |q|`` past cracking: the bleed and the open
    blow-off share one drop ``P``, ``|q| = sqrt(P / K) + (P - p_c) / R_b``, a quadratic in
    ``u = sqrt(P)``, solved in the form that stays exact as ``1 / R_b -> 0``."""
    a = 1.0 / blowoff
    b = 1.0 / bk.sqrt(kq)
    c = aq + cracking * a
    u = 2.0 * c / (b + bk.sqrt(b * b + 4.0 * a * c))
    return u * u


def damper_valve_pressure_drop(q: Any, kq: Any, cracking: Any = None, blowoff: Any = None, r: Any = 0.0) -> Any:
    """[Pa] Physical damper valve (docs/model.md §3.3): a bleed orifice ``dp = K q |q|`` in
    parallel with a spring-loaded blow-off that opens at the cracking pressure ``p_c`` and
    then passes ``(dp - p_c) / R_b`` more, the pair in series with a laminar part ``r q``.

    Below the crossover flow ``q_c = sqrt(p_c / K)`` only the bleed passes oil; above it the
    drop is :func:`_blowoff_drop`, which is below the bleed's ``K q^2`` there and above it below
    ``q_c``, so the drop is the smaller of the two, ``dp = r q + sign(q) min(K q^2, P_open)``:
    one expression in numpy and CasADi, continuous, with a kink in its slope at ``q_c``, and
    no division, so ``q = 0`` gives ``dp = 0`` and (CasADi's AD) the slope ``r`` there.

    Parameters
    ----------
    q : Any
        [m^3/s] flow in the direction of the drop
    kq : Any
        [Pa s^2 m^-6] the bleed orifice's :func:`orifice_coefficient`, > 0
    cracking, blowoff : Any, optional
        [Pa] cracking pressure >= 0 and [Pa s m^-3] the blow-off's resistance once open
        (the slope of its added flow), > 0; None: no blow-off (the bleed alone)
    r : Any, optional
        [Pa s m^-3] laminar part in series
    """
    aq = bk.fabs(q)
    if cracking is None:
        return r * q + kq * q * aq
    return r * q + bk.sign(q) * bk.fmin(kq * aq * aq, _blowoff_drop(aq, kq, cracking, blowoff))


def damper_valve_slope(q: Any, kq: Any, cracking: Any = None, blowoff: Any = None, r: Any = 0.0, drop: Any = None) -> Any:
    """[Pa s m^-3] Tangent ``d(dp)/dq`` of :func:`damper_valve_pressure_drop` (same arguments;
    numpy): the Newton Jacobian of the nonlinear time domain (docs/model.md §3.10).

    Below the crossover (where the bleed's drop ``K q^2`` is the smaller) it is the bleed's
    ``2 K |q|``; past it the open drop ``P = u^2`` solves ``|q| = u / sqrt(K) + (P - p_c) / R_b``,
    so ``d|q| / dP = 1 / (2 u sqrt(K)) + 1 / R_b`` and the slope is
    ``2 u / (1 / sqrt(K) + 2 u / R_b)``; plus ``r`` throughout. At the crossover itself (a kink)
    the bleed's side is taken.

    ``drop``: the law's drop at ``q`` without its laminar part, if already evaluated (past the
    crossover it is ``sign(q) P``, so ``P`` need not be solved for again; below it is unused).
    """
    aq = np.abs(q)
    bleed = 2.0 * kq * aq
    if cracking is None:
        return r + bleed
    p_open = _blowoff_drop(aq, kq, cracking, blowoff) if drop is None else np.maximum(np.abs(drop), cracking)
    u = np.sqrt(p_open)
    open_slope = 2.0 * u / (1.0 / np.sqrt(kq) + 2.0 * u / blowoff)
    return r + np.where(kq * aq * aq <= p_open, bleed, open_slope)


TAIL_NODES = 48
TAIL_SPAN = 12.0
"""Gauss-Legendre nodes over ``y = (|q| - q_c) / s`` in ``[0, TAIL_SPAN]`` for the blow-off's
share of the expected slope: the Gaussian weight beyond 12 standard deviations is below
1e-31 of the whole (error budget and check: tests/test_damper_valve.py)."""
_TAIL_Y, _TAIL_W = np.polynomial.legendre.leggauss(TAIL_NODES)
_TAIL_Y, _TAIL_W = 0.5 * TAIL_SPAN * (_TAIL_Y + 1.0), 0.5 * TAIL_SPAN * _TAIL_W
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)


def damper_valve_equivalent_resistance(q_rms: Any, kq: Any, cracking: Any = None, blowoff: Any = None, r: Any = 0.0) -> Any:
    """[Pa s m^-3] Equivalent linear resistance of :func:`damper_valve_pressure_drop` under a
    zero-mean Gaussian flow of RMS ``q_rms`` [m^3/s] (statistical linearisation, docs/model.md
    §3.3): the expected slope ``E[d(dp)/dq]``, which for a Gaussian flow is also the
    mean-square-error gain ``E[q dp] / E[q^2]`` (Stein's lemma), so the two criteria agree.

    With ``s = q_rms`` and ``x_c = q_c / s``, the bleed's share below the crossover ``q_c`` is
    closed,

        2 / sqrt(2 pi) K s (2 - (x_c^2 + 2) exp(-x_c^2 / 2))

    (``2 sqrt(2 / pi) K s``, the orifice's, without a blow-off), and the blow-off's share above
    it, ``2 / s^2 int_qc^inf q P_open(q) phi_s(q) dq``, is a fixed :data:`TAIL_NODES`-node
    Gauss-Legendre sum over ``y = (q - q_c) / s`` in ``[0, TAIL_SPAN]``: the same arithmetic in
    numpy (any batch shape) and CasADi. ``q_rms = 0`` gives ``r``.
    """
    if cracking is None:
        return r + 2.0 * math.sqrt(2.0 / math.pi) * kq * q_rms
    s = bk.fmax(q_rms, 1e-30)  # a zero flow: the bleed's share 0, the blow-off's weight exp(-inf) = 0
    q_c = bk.sqrt(cracking / kq)
    x_c = q_c / s
    bleed = kq * s * (2.0 - (x_c * x_c + 2.0) * bk.exp(-0.5 * x_c * x_c))
    if bk.is_casadi(s) or bk.is_casadi(kq) or bk.is_casadi(cracking) or bk.is_casadi(blowoff):
        total = 0.0
        for y, w in zip(_TAIL_Y, _TAIL_W, strict=True):
            q = q_c + s * float(y)
            total = total + float(w) * (q / s) * _blowoff_drop(q, kq, cracking, blowoff) * bk.exp(-0.5 * (x_c + float(y)) ** 2)
    else:  # the same sum with the nodes on a trailing axis
        at = lambda v: np.asarray(v, dtype=float)[..., None]  # noqa: E731
        q = at(q_c) + at(s) * _TAIL_Y
        terms = (q / at(s)) * _blowoff_drop(q, at(kq), at(cracking), at(blowoff)) * np.exp(-0.5 * (at(x_c) + _TAIL_Y) ** 2)
        total = terms @ _TAIL_W
    return r + 2.0 * _INV_SQRT_2PI * (bleed + total / s)


# --- pipes -------------------------------------------------------------------------------------
def pipe_area(diameter: Any) -> Any:
    """[m^2] Bore area of a circular pipe of inner diameter [m]."""
    return math.pi * diameter**2 / 4.0


def pipe_resistance_per_m(mu: Any, diameter: Any) -> Any:
    """[Pa s m^-4] Laminar (Hagen-Poiseuille) resistance per metre ``128 mu / (pi d^4)``."""
    return 128.0 * mu / (math.pi * diameter**4)


def pipe_inertance_per_m(rho: Any, diameter: Any) -> Any:
    """[Pa s^2 m^-4] Fluid inertance per metre ``rho / A``."""
    return rho / pipe_area(diameter)


def pipe_compliance_per_m(beta: Any, diameter: Any) -> Any:
    """[m^2/Pa] Volume compliance per metre ``A / beta``."""
    return pipe_area(diameter) / beta


def pipe_series_impedance_per_m(s: Any, rho: Any, mu: Any, diameter: Any) -> Any:
    """[Pa s m^-4] Series impedance per metre ``z = s rho / A + 128 mu / (pi d^4)``."""
    return s * pipe_inertance_per_m(rho, diameter) + pipe_resistance_per_m(mu, diameter)


def pipe_shunt_admittance_per_m(s: Any, beta: Any, diameter: Any) -> Any:
    """[m^2 Pa^-1 s^-1] Shunt admittance per metre ``y = s A / beta``."""
    return s * pipe_compliance_per_m(beta, diameter)


def line_transfer_matrix(z: Any, y: Any, length: Any) -> tuple[Any, Any, Any, Any]:
    """Uniform line with series impedance ``z`` and shunt admittance ``y`` per metre.

    ``Gamma = l sqrt(z y)``, ``Z_c = sqrt(z / y)`` and, with the flow positive from end 1 to
    end 2, ``[p, q]_2 = T [p, q]_1``,
    ``T = [[cosh Gamma, -Z_c sinh Gamma], [-sinh Gamma / Z_c, cosh Gamma]]`` (``det T = 1``).
    Both square roots take the principal branch, which for ``s = j omega`` puts ``Gamma`` in
    the first and ``Z_c`` in the fourth quadrant, as ``sqrt(z) sqrt(y)`` and
    ``sqrt(z) / sqrt(y)`` would.

    Returns
    -------
    T11, T12, T21, T22 : complex
        The entries of ``T``.
    """
    gamma = bk.sqrt(z * y) * length
    zc = bk.sqrt(z / y)
    ch, sh = bk.cosh(gamma), bk.sinh(gamma)
    return ch, -zc * sh, -sh / zc, ch
