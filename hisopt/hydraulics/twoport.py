"""Two-port transfer-matrix kernels (paper Eq. 8-14, DESIGN section 2).

Convention: ``[p, q]_out = T [p, q]_in`` with the flow ``q`` positive from end 1 to end 2.
Every array function broadcasts over leading axes and returns shape ``(..., 2, 2)``.
A passive, reciprocal element has ``det T = 1``.
"""

from __future__ import annotations

import numpy as np


def _stack(t11, t12, t21, t22) -> np.ndarray:
    t11, t12, t21, t22 = np.broadcast_arrays(t11, t12, t21, t22)
    return np.stack([np.stack([t11, t12], -1), np.stack([t21, t22], -1)], -2)


def series_impedance(z: np.ndarray) -> np.ndarray:
    """Transfer matrix of a series impedance ``z`` [Pa s/m^3]: ``p_out = p_in - z q``."""
    z = np.asarray(z, dtype=complex)
    return _stack(np.ones_like(z), -z, np.zeros_like(z), np.ones_like(z))


def shunt_admittance(y: np.ndarray) -> np.ndarray:
    """Transfer matrix of a shunt admittance ``y`` [m^3/(Pa s)]: ``q_out = q_in - y p``."""
    y = np.asarray(y, dtype=complex)
    return _stack(np.ones_like(y), np.zeros_like(y), -y, np.ones_like(y))


def uniform_line(z_per_m: np.ndarray, y_per_m: np.ndarray, length: np.ndarray) -> np.ndarray:
    """Distributed line with series impedance ``z`` and shunt admittance ``y`` per metre.

    ``Gamma = l sqrt(z y)``, ``Z_c = sqrt(z / y)``;
    ``T = [[cosh Gamma, -Z_c sinh Gamma], [-sinh Gamma / Z_c, cosh Gamma]]``.

    Parameters
    ----------
    z_per_m : [Pa s m^-4] series impedance per unit length, shape (...)
    y_per_m : [m^2 Pa^-1 s^-1] shunt admittance per unit length, shape (...)
    length : [m] line length, shape (...)
    """
    z = np.asarray(z_per_m, dtype=complex)
    y = np.asarray(y_per_m, dtype=complex)
    gamma = np.sqrt(z * y) * length
    zc = np.sqrt(z / y)
    # Same branch for Gamma and Z_c: Z_c * sinh(Gamma) and sinh(Gamma) / Z_c are branch-free.
    ch, sh = np.cosh(gamma), np.sinh(gamma)
    return _stack(ch, -zc * sh, -sh / zc, ch)


def cascade(*matrices: np.ndarray) -> np.ndarray:
    """Chain two-ports in flow order: ``cascade(T1, T2) = T2 @ T1``."""
    out = matrices[0]
    for t in matrices[1:]:
        out = t @ out
    return out


def port_impedance_matrix(t: np.ndarray) -> np.ndarray:
    """Open-circuit impedance of a two-port, paper Eq. 11.

    With both flows counted *into* the element (``q_1`` in at end 1, ``q_2`` in at end 2),
    ``[p_1, p_2] = Z [q_1, q_2]``; requires ``T_21 != 0`` (a shunt path to ground).
    """
    t11, t12, t21, t22 = t[..., 0, 0], t[..., 0, 1], t[..., 1, 0], t[..., 1, 1]
    det = t11 * t22 - t12 * t21
    # q_out = -q_2 (flow leaves at end 2): p1 = (-T22 q1 - q2)/T21 ... solved for both ends.
    z11 = -t22 / t21
    z12 = -1.0 / t21
    z21 = -det / t21
    z22 = -t11 / t21
    return _stack(z11, z12, z21, z22)
