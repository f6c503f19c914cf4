"""Matrices of the 7-DOF full car (paper Eq. 1-6, docs/model.md §2).

State ``X = [z_s, phi, theta, z_u1..z_u4]`` (wheels FL, FR, RL, RR, z up). Suspension stroke
(extension positive) is ``delta = G X`` with ``G = [T_z, -I4]``.

Every function takes one car (:class:`VehicleParams`: matrices of shape ``(..., r, c)`` with
no leading axes) or a batch of cars (:class:`hisopt.vehicle.batch.VehicleBatch`, fields of
batch shape ``B``: matrices ``B + (r, c)``). One car's matrices are computed with the same
elementwise operations in the same order either way (no BLAS product, whose rounding
depends on the kernel and on the batch), so a batch's row ``i`` equals the matrix of car
``i`` to the last bit (tests/test_vehicle_batch.py).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from hisopt.vehicle.parameters import VehicleParams

if TYPE_CHECKING:
    from hisopt.vehicle.batch import VehicleBatch


def _arrays(*values: ArrayLike) -> list[np.ndarray]:
    """The values as float arrays broadcast to one shape (the batch shape; () for one car)."""
    return list(np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in values)))


def _diagonal(d: np.ndarray) -> np.ndarray:
    """``diag(d)`` over the last axis: shape ``d.shape + (d.shape[-1],)``."""
    out = np.zeros(d.shape + (d.shape[-1],))
    k = np.arange(d.shape[-1])
    out[..., k, k] = d
    return out


def body_to_corners(vehicle: VehicleParams | VehicleBatch) -> np.ndarray:
    """Map body motion ``[z_s, phi, theta]`` to the four corner displacements (paper Eq. 6).

    The corners sit at lateral positions ``t - y_cg`` (left) and ``-t - y_cg`` (right) from
    the CG; ``y_cg = 0`` (the unladen, symmetric car) is the paper's matrix.

    Returns
    -------
    ndarray, shape B + (4, 3)
    """
    t_f, t_r, y_cg, l_f, l_r = _arrays(vehicle.t_f, vehicle.t_r, vehicle.y_cg, vehicle.l_f, vehicle.l_r)
    t = np.zeros(t_f.shape + (4, 3))
    t[..., 0] = 1.0
    t[..., 0, 1], t[..., 1, 1], t[..., 2, 1], t[..., 3, 1] = t_f - y_cg, -t_f - y_cg, t_r - y_cg, -t_r - y_cg
    t[..., 0, 2], t[..., 1, 2], t[..., 2, 2], t[..., 3, 2] = -l_f, -l_f, l_r, l_r
    return t


def stroke_matrix(vehicle: VehicleParams | VehicleBatch) -> np.ndarray:
    """Stroke map ``G = [T_z, -I4]``: suspension extension of each corner, shape ``B + (4, 7)``."""
    t = body_to_corners(vehicle)
    return np.concatenate([t, np.broadcast_to(-np.eye(4), t.shape[:-2] + (4, 4))], axis=-1)


def _per_wheel(front: ArrayLike, rear: ArrayLike) -> np.ndarray:
    """``[front, front, rear, rear]`` along a last axis: shape ``B + (4,)``."""
    f, r = _arrays(front, rear)
    return np.stack([f, f, r, r], axis=-1)


def mass_matrix(vehicle: VehicleParams | VehicleBatch) -> np.ndarray:
    """``M = diag(m_s, I_x, I_y, m_uf, m_uf, m_ur, m_ur)``, shape ``B + (7, 7)``."""
    v = vehicle
    m_s, i_x, i_y, m_uf, m_ur = _arrays(v.m_s, v.I_x, v.I_y, v.m_uf, v.m_ur)
    return _diagonal(np.stack([m_s, i_x, i_y, m_uf, m_uf, m_ur, m_ur], axis=-1))


def _springs(vehicle: VehicleParams | VehicleBatch, suspension: np.ndarray, tyre: np.ndarray) -> np.ndarray:
    """``G^T diag(suspension) G`` plus ``diag(tyre)`` on the wheel DOFs, shape ``B + (7, 7)``.

    Summed corner by corner, ``sum_w k_w (g_w g_w^T)``, in elementwise arithmetic: exactly
    symmetric, and the same bits for a car alone or in any batch on any BLAS (a stacked
    ``matmul`` rounds differently from a single one, and neither keeps the symmetry).
    """
    g = stroke_matrix(vehicle)
    k = np.zeros(g.shape[:-2] + (7, 7))
    for w in range(4):
        k += suspension[..., w, None, None] * (g[..., w, :, None] * g[..., w, None, :])
    k[..., 3:, 3:] += _diagonal(tyre)
    return k


AXLES = ((0, 1), (2, 3))
"""The strokes (rows of ``G``) of the front and the rear axle, left first."""


def anti_roll_bars(vehicle: VehicleParams | VehicleBatch) -> np.ndarray:
    """The anti-roll bars' stiffness ``G^T K_b G``, shape ``B + (7, 7)`` (docs/model.md §2.3).

    An axle's bar of rate ``k`` at the wheel stores ``k (delta_L - delta_R)^2 / 2``: its
    block of ``K_b`` is ``k [[1, -1], [-1, 1]]`` on that axle's strokes, i.e.
    ``k d d^T`` with ``d = g_L - g_R``, summed in elementwise arithmetic as the springs are.
    In roll (``delta_L - delta_R = 2 t phi``) it adds ``4 k t^2`` to the roll stiffness.
    """
    g = stroke_matrix(vehicle)
    k_f, k_r = _arrays(vehicle.k_arb_f, vehicle.k_arb_r)
    k = np.zeros(g.shape[:-2] + (7, 7))
    for rate, (left, right) in zip((k_f, k_r), AXLES, strict=True):
        d = g[..., left, :] - g[..., right, :]
        k += rate[..., None, None] * (d[..., :, None] * d[..., None, :])
    return k


def stiffness_matrix(vehicle: VehicleParams | VehicleBatch) -> np.ndarray:
    """Conventional springs ``G^T K_s G``, the anti-roll bars ``G^T K_b G``
    (:func:`anti_roll_bars`) and the tyre springs on the wheel DOFs, shape ``B + (7, 7)``.

    Bars of rate 0 (the default) add exact zeros: the matrix is the springs' and tyres' to
    the last bit."""
    v = vehicle
    return _springs(v, _per_wheel(v.k_sf, v.k_sr), _per_wheel(v.k_tf, v.k_tr)) + anti_roll_bars(v)


def damping_matrix(vehicle: VehicleParams | VehicleBatch) -> np.ndarray:
    """Conventional dampers ``G^T C_s G`` plus tyre damping on the wheel DOFs, shape ``B + (7, 7)``."""
    v = vehicle
    return _springs(v, _per_wheel(v.c_sf, v.c_sr), _per_wheel(v.c_tf, v.c_tr))


def at_frequencies(matrix: np.ndarray, vehicle: VehicleParams | VehicleBatch) -> np.ndarray:
    """A car's matrix ready to meet an array of frequencies ``B + (F,)``: a batch's ``B + (r, c)``
    gets a frequency axis, ``B + (1, r, c)``; one car's ``(r, c)`` broadcasts as it is."""
    return matrix if np.ndim(vehicle.m_s) == 0 else matrix[..., None, :, :]


def dynamic_stiffness_matrix(vehicle: VehicleParams | VehicleBatch, s: ArrayLike) -> np.ndarray:
    """``D0(s) = s^2 M + s C + K`` of the car without HIS (paper Eq. 21).

    Parameters
    ----------
    vehicle : VehicleParams | VehicleBatch
        one car (``s`` of any shape: the result is ``s.shape + (7, 7)``) or a batch of shape
        ``B`` (``s`` of shape ``B + (F,)``: the result is ``B + (F, 7, 7)``)
    s : array_like
        [rad/s] Laplace variable (complex)
    """
    sb = np.asarray(s, dtype=complex)[..., None, None]
    m, c, k = (at_frequencies(a, vehicle) for a in (mass_matrix(vehicle), damping_matrix(vehicle), stiffness_matrix(vehicle)))
    return sb**2 * m + sb * c + k


def _road_input(tyre: np.ndarray) -> np.ndarray:
    b = np.zeros(tyre.shape[:-1] + (7, 4))
    b[..., 3:, :] = _diagonal(tyre)
    return b


def road_stiffness_input(vehicle: VehicleParams | VehicleBatch) -> np.ndarray:
    """Road displacement to force map ``[0; K_t]`` (paper Eq. 3), shape ``B + (7, 4)``."""
    return _road_input(_per_wheel(vehicle.k_tf, vehicle.k_tr))


def road_damping_input(vehicle: VehicleParams | VehicleBatch) -> np.ndarray:
    """Road velocity to force map ``[0; C_t]`` (zero for the default tyre), shape ``B + (7, 4)``."""
    return _road_input(_per_wheel(vehicle.c_tf, vehicle.c_tr))
