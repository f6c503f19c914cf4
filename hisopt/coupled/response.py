"""Response outputs and their road-induced PSDs (paper Eq. 22-24, docs/model.md §4.4 and §5.1).

An output is a polynomial in ``s`` of the car's motion and the road input:
``y(s) = sum_p s^p (c_p . X(s) + d_p . z_g(s))``. With the 4-wheel FRF ``H_X = X / z_g`` the
output FRF per wheel input is ``H_y = sum_p s^p (c_p H_X + d_p)``; the two tracks combine front
and delayed rear inputs and ``S_y = G (|h_L|^2 + |h_R|^2 + 2 g Re(h_L conj(h_R)))``
(:meth:`hisopt.evaluation.evaluate.Evaluator.spectra`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hisopt.constants import WHEEL_NAMES
from hisopt.linalg import bmm
from hisopt.vehicle import VehicleParams, stroke_matrix


@dataclass(frozen=True)
class Output:
    """A linear response: ``c`` (P, 7) weights ``s^p X``, ``d`` (P, 4) weights ``s^p z_g``;
    a ``c`` of ``7 + E`` columns also weights the ``E`` accumulators' oil volumes
    (:func:`accumulator_outputs`)."""

    name: str
    unit: str
    c: np.ndarray
    d: np.ndarray
    weighting: str | None = None  # ISO 2631-1 weighting applied in comfort sums

    def frf(self, h_x: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Output FRF per wheel input, shape ``(..., F, 4)``.

        Parameters
        ----------
        h_x : np.ndarray
            X / z_g, shape ``(..., F, 7, 4)``, or with the accumulators' oil volumes
            after ``X`` (``(..., F, 7 + E, 4)``)
        s : np.ndarray
            [rad/s] Laplace variable, shape ``(..., F)``
        """
        out = np.zeros(np.broadcast_shapes(h_x.shape[:-2], s.shape) + (4,), dtype=np.result_type(h_x, s))
        for p in range(self.c.shape[0]):
            term = bmm(self.c[p][None, :], h_x[..., : self.c.shape[1], :])[..., 0, :] + self.d[p]
            out = out + s[..., None] ** p * term
        return out


def _unit(i: int, n: int) -> np.ndarray:
    e = np.zeros(n)
    e[i] = 1.0
    return e


def standard_outputs(vehicle: VehicleParams) -> dict[str, Output]:
    """Every output of docs/model.md §5.1, keyed by name.

    ``acc_z`` (CG vertical), ``acc_x = h_0s theta''``, ``acc_y = -h_0s phi''`` (paper Eq. 26),
    ``acc_roll``/``acc_pitch`` (angular), ``roll``, ``pitch``, ``stroke_<w>`` (``delta_i``,
    extension positive) and ``tire_load_<w> = k_t (z_ui - z_gi) + c_t s (z_ui - z_gi)`` for
    every wheel ``<w>`` of FL, FR, RL, RR (the metrics read FL's).
    """
    v = vehicle
    zero7, zero4 = np.zeros(7), np.zeros(4)

    def poly(*cs: np.ndarray) -> np.ndarray:
        return np.array(cs)

    acc = lambda c: poly(zero7, zero7, c)  # noqa: E731  s^2 x
    acc_d = poly(zero4, zero4, zero4)
    g = stroke_matrix(v)
    return (
        {
            "acc_z": Output("acc_z", "m/s^2", acc(_unit(0, 7)), acc_d, "Wk"),
            "acc_x": Output("acc_x", "m/s^2", acc(v.h_0s * _unit(2, 7)), acc_d, "Wd"),
            "acc_y": Output("acc_y", "m/s^2", acc(-v.h_0s * _unit(1, 7)), acc_d, "Wd"),
            "acc_roll": Output("acc_roll", "rad/s^2", acc(_unit(1, 7)), acc_d, "We"),
            "acc_pitch": Output("acc_pitch", "rad/s^2", acc(_unit(2, 7)), acc_d, "We"),
            "roll": Output("roll", "rad", poly(_unit(1, 7)), poly(zero4)),
            "pitch": Output("pitch", "rad", poly(_unit(2, 7)), poly(zero4)),
        }
        | {f"stroke_{w}": Output(f"stroke_{w}", "m", poly(g[i]), poly(zero4)) for i, w in enumerate(WHEEL_NAMES)}
        | {
            f"tire_load_{w}": Output(
                f"tire_load_{w}",
                "N",
                poly(k_t * _unit(3 + i, 7), c_t * _unit(3 + i, 7)),
                poly(-k_t * _unit(i, 4), -c_t * _unit(i, 4)),
            )
            for i, (w, k_t, c_t) in enumerate(zip(WHEEL_NAMES, (v.k_tf, v.k_tf, v.k_tr, v.k_tr), (v.c_tf, v.c_tf, v.c_tr, v.c_tr), strict=True))
        }
    )


def accumulator_outputs(n_accumulators: int) -> dict[str, Output]:
    """The oil volume in each accumulator [m^3], in the network's element order, keyed
    ``oil_volume_<j>`` (docs/model.md §16.9): an output over ``[X, V_acc]`` (its ``c`` has
    ``7 + n_accumulators`` columns), which the engines read from the hydraulic unknowns."""
    out = {}
    for j in range(n_accumulators):
        c = np.zeros((1, 7 + n_accumulators))
        c[0, 7 + j] = 1.0
        out[f"oil_volume_{j}"] = Output(f"oil_volume_{j}", "m^3", c, np.zeros((1, 4)))
    return out


def valve_flow_outputs(n_accumulators: int, n_valves: int) -> dict[str, Output]:
    """The flow through each nonlinear valve [m^3/s] (damper valve or orifice), in the
    network's element order (:meth:`~hisopt.hydraulics.network.Network.flow_valves`), keyed ``valve_flow_<j>``: an
    output over ``[X, V_acc, Q_valve]`` (its ``c`` has ``7 + n_accumulators + n_valves``
    columns), read from the hydraulic unknowns like the accumulators' oil volumes."""
    out = {}
    for j in range(n_valves):
        c = np.zeros((1, 7 + n_accumulators + n_valves))
        c[0, 7 + n_accumulators + j] = 1.0
        out[f"valve_flow_{j}"] = Output(f"valve_flow_{j}", "m^3/s", c, np.zeros((1, 4)))
    return out


def port_pressure_outputs(n_accumulators: int, n_valves: int, n_ports: int) -> dict[str, Output]:
    """The dynamic pressure at each port's node, the chamber's [Pa], in the network's port
    order (:attr:`~hisopt.hydraulics.network.Network.ports`), keyed ``port_pressure_<i>``: an
    output over ``[X, V_acc, Q_valve, p_port]`` (its ``c`` has ``7 + n_accumulators + n_valves
    + n_ports`` columns), read from the hydraulic unknowns like the accumulators' oil volumes
    (docs/model.md §21: the buildability rules' road swing of the chamber pressures)."""
    out = {}
    width = 7 + n_accumulators + n_valves + n_ports
    for i in range(n_ports):
        c = np.zeros((1, width))
        c[0, 7 + n_accumulators + n_valves + i] = 1.0
        out[f"port_pressure_{i}"] = Output(f"port_pressure_{i}", "Pa", c, np.zeros((1, 4)))
    return out


STROKE_RATE_NAMES = ("stroke_rate_fl", "stroke_rate_fr", "stroke_rate_rl", "stroke_rate_rr")
"""The strokes' rates in wheel order: a port's flow is its chamber's area times its strut's rate."""


def stroke_rate_outputs(vehicle: VehicleParams) -> dict[str, Output]:
    """[m/s] Each strut's stroke rate ``s delta_i`` (extension positive), keyed by
    :data:`STROKE_RATE_NAMES`: a chamber's flow is its area times its strut's rate, so the
    hoses' road flows come from these (docs/model.md §21)."""
    g = stroke_matrix(vehicle)
    zero7, zero4 = np.zeros(7), np.zeros(4)
    return {name: Output(name, "m/s", np.array([zero7, g[i]]), np.array([zero4, zero4])) for i, name in enumerate(STROKE_RATE_NAMES)}
