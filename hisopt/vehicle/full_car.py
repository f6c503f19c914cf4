"""Matrices of the 7-DOF full car (paper Eq. 1-6, docs/model.md §2).

State ``X = [z_s, phi, theta, z_u1..z_u4]`` (wheels FL, FR, RL, RR, z up). Suspension stroke
(extension positive) is ``delta = G X`` with ``G = [T_z, -I4]``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from hisopt.vehicle.parameters import VehicleParams


def body_to_corners(vehicle: VehicleParams) -> np.ndarray:
    """Map body motion ``[z_s, phi, theta]`` to the four corner displacements (paper Eq. 6).

    The corners sit at lateral positions ``t - y_cg`` (left) and ``-t - y_cg`` (right) from
    the CG; ``y_cg = 0`` (the unladen, symmetric car) is the paper's matrix.

    Returns
    -------
    ndarray, shape (4, 3)
    """
    v = vehicle
    return np.array(
        [
            [1.0, v.t_f - v.y_cg, -v.l_f],
            [1.0, -v.t_f - v.y_cg, -v.l_f],
            [1.0, v.t_r - v.y_cg, v.l_r],
            [1.0, -v.t_r - v.y_cg, v.l_r],
        ]
    )


def stroke_matrix(vehicle: VehicleParams) -> np.ndarray:
    """Stroke map ``G = [T_z, -I4]``: suspension extension of each corner, shape (4, 7)."""
    return np.hstack([body_to_corners(vehicle), -np.eye(4)])


def _per_wheel(front: float, rear: float) -> np.ndarray:
    return np.array([front, front, rear, rear], dtype=float)


def mass_matrix(vehicle: VehicleParams) -> np.ndarray:
    """``M = diag(m_s, I_x, I_y, m_uf, m_uf, m_ur, m_ur)``, shape (7, 7)."""
    v = vehicle
    return np.diag(np.r_[v.m_s, v.I_x, v.I_y, _per_wheel(v.m_uf, v.m_ur)])


def stiffness_matrix(vehicle: VehicleParams) -> np.ndarray:
    """Conventional springs ``G^T K_s G`` plus tyre springs on the wheel DOFs, shape (7, 7)."""
    v = vehicle
    g = stroke_matrix(v)
    k = g.T @ np.diag(_per_wheel(v.k_sf, v.k_sr)) @ g
    k[3:, 3:] += np.diag(_per_wheel(v.k_tf, v.k_tr))
    return k


def damping_matrix(vehicle: VehicleParams) -> np.ndarray:
    """Conventional dampers ``G^T C_s G`` plus tyre damping on the wheel DOFs, shape (7, 7)."""
    v = vehicle
    g = stroke_matrix(v)
    c = g.T @ np.diag(_per_wheel(v.c_sf, v.c_sr)) @ g
    c[3:, 3:] += np.diag(_per_wheel(v.c_tf, v.c_tr))
    return c


def dynamic_stiffness_matrix(vehicle: VehicleParams, s: ArrayLike) -> np.ndarray:
    """``D0(s) = s^2 M + s C + K`` of the car without HIS (paper Eq. 21), shape ``s.shape + (7, 7)``.

    Parameters
    ----------
    vehicle : VehicleParams
        the car
    s : array_like
        [rad/s] Laplace variable, any shape (complex)
    """
    sb = np.asarray(s, dtype=complex)[..., None, None]
    return sb**2 * mass_matrix(vehicle) + sb * damping_matrix(vehicle) + stiffness_matrix(vehicle)


def road_stiffness_input(vehicle: VehicleParams) -> np.ndarray:
    """Road displacement to force map ``[0; K_t]`` (paper Eq. 3), shape (7, 4)."""
    b = np.zeros((7, 4))
    b[3:, :] = np.diag(_per_wheel(vehicle.k_tf, vehicle.k_tr))
    return b


def road_damping_input(vehicle: VehicleParams) -> np.ndarray:
    """Road velocity to force map ``[0; C_t]`` (zero for the default tyre), shape (7, 4)."""
    b = np.zeros((7, 4))
    b[3:, :] = np.diag(_per_wheel(vehicle.c_tf, vehicle.c_tr))
    return b
