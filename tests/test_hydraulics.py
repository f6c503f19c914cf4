"""Hydraulic elements and circuits: reciprocity, passivity, shorts, lumped vs distributed.

The two-port kernels below (paper Eq. 8-14: series impedance, shunt admittance, cascade and
the open-circuit impedance of Eq. 11) are an independent second method: the library
assembles circuits by nodal analysis only.
"""

import numpy as np
import pytest

from hisopt.constants import P_ATM_PA
from hisopt.hydraulics import laws
from hisopt.hydraulics.coupling import HydraulicSystem
from hisopt.hydraulics.layout import Accumulator, Circuit, Layout, Pipe, Port, Valve
from hisopt.hydraulics.network import compile_network
from hisopt.hydraulics.roll_plane import PipeLayout, RollPlaneHIS, roll_plane_system

F_HZ = np.geomspace(0.05, 200, 120)
S = 2j * np.pi * F_HZ
FLUID = {"rho": 870.0, "mu": 0.03, "beta": 1.5e9}


# --- paper Eq. 8-14 as transfer matrices (the reference of the nodal assembly) ----------------
def _stack(t11, t12, t21, t22):
    t11, t12, t21, t22 = np.broadcast_arrays(t11, t12, t21, t22)
    return np.stack([np.stack([t11, t12], -1), np.stack([t21, t22], -1)], -2)


def series_impedance(z):
    z = np.asarray(z, dtype=complex)
    return _stack(np.ones_like(z), -z, np.zeros_like(z), np.ones_like(z))


def shunt_admittance(y):
    y = np.asarray(y, dtype=complex)
    return _stack(np.ones_like(y), np.zeros_like(y), -y, np.ones_like(y))


def cascade(*matrices):
    out = matrices[0]
    for t in matrices[1:]:
        out = t @ out
    return out


def port_impedance_matrix(t):
    """Paper Eq. 11: ``[p1, p2] = Z [q1, q2]`` with both flows counted into the element."""
    t11, t12, t21, t22 = t[..., 0, 0], t[..., 0, 1], t[..., 1, 0], t[..., 1, 1]
    det = t11 * t22 - t12 * t21
    return _stack(-t22 / t21, -1.0 / t21, -det / t21, -t11 / t21)


def pipe_transfer_matrix(s, length=2.5, diameter=0.01):
    z = laws.pipe_series_impedance_per_m(s, FLUID["rho"], FLUID["mu"], diameter)
    y = laws.pipe_shunt_admittance_per_m(s, FLUID["beta"], diameter)
    return _stack(*laws.line_transfer_matrix(z, y, length))


def circuit_impedance(circuit, s, fidelity="lumped", **params):
    system = HydraulicSystem(compile_network(Layout((circuit,)), fidelity), FLUID | {"gamma": 1.4} | params)
    return system.port_impedance(s)


def _random_his(rng, n=6):
    return {
        "p0": rng.uniform(0, 4e6, n),
        "dA": rng.uniform(1e-4, 25e-4, n),
        "lam": rng.uniform(0.1, 0.8, n),
        "Rv": np.r_[0.0, rng.uniform(0, 16e5, n - 1)],
    }


def test_two_ports_are_reciprocal(rng):
    s = rng.normal(size=20) + 1j * rng.uniform(0.1, 500, 20)
    for t in (
        series_impedance(rng.uniform(0, 1e6, 20) + s * 1e5),
        shunt_admittance(s * 1e-9),
        pipe_transfer_matrix(s),
    ):
        np.testing.assert_allclose(np.linalg.det(t), 1.0, rtol=1e-9)
    chain = cascade(series_impedance(1e5 + 0 * s), pipe_transfer_matrix(s), shunt_admittance(1e-9 * s))
    np.testing.assert_allclose(np.linalg.det(chain), 1.0, rtol=1e-9)


def test_two_port_impedance_of_a_cascade_matches_nodal_assembly():
    """Paper Eq. 11 from a transfer-matrix cascade equals the nodal (MNA) assembly."""
    compliance = laws.accumulator_compliance(1e-3, 2e6 + P_ATM_PA, 1.4)
    # Cascade p1 -> pipe -> n (shunt accumulator) -> valve (reversed) -> p2.
    t = cascade(pipe_transfer_matrix(S, 1.0), shunt_admittance(S * compliance), series_impedance(8e5 + 0 * S))
    z_cascade = port_impedance_matrix(t)
    circuit = Circuit(
        "c",
        (Accumulator("n", 1e-3, 2e6), Pipe("p1", "n", 1.0, 0.01), Valve("p2", "n", 8e5)),
        (Port("p1", 0, "top"), Port("p2", 1, "bottom")),
    )
    z_mna = circuit_impedance(circuit, S, "distributed")
    np.testing.assert_allclose(z_mna, z_cascade, rtol=1e-9)


@pytest.mark.parametrize("model", ["lumped", "distributed"])
def test_port_impedance_reciprocal_and_passive(model, rng):
    base = RollPlaneHIS(pipes=PipeLayout(), chamber_volume=2e-4, pipe_model=model) if model == "distributed" else RollPlaneHIS()
    system = roll_plane_system(_random_his(rng), base)
    z_all = system.port_impedance(S[None, :])
    for c in range(system.network.n_circuits):
        ports = np.flatnonzero(system.network.port_circuit == c)
        z = z_all[..., ports[:, None], ports[None, :]]
        np.testing.assert_allclose(z, np.swapaxes(z, -1, -2), rtol=1e-9, atol=1e-12 * np.abs(z).max())
        herm = 0.5 * (z + np.conj(np.swapaxes(z, -1, -2)))
        eig = np.linalg.eigvalsh(herm)
        assert eig.min() >= -1e-9 * np.abs(z).max(axis=(-1, -2)).max()


def test_zero_valve_resistance_is_an_exact_short():
    acc = Accumulator("n", 1e-3, 0.0)  # p0 = 0 gauge also works
    shorted = Circuit("c", (acc, Valve("p", "n", 0.0)), (Port("p", 0, "bottom"),))
    direct = Circuit("c", (acc,), (Port("n", 0, "bottom"),))
    np.testing.assert_allclose(circuit_impedance(shorted, S), circuit_impedance(direct, S), rtol=1e-12)
    np.testing.assert_allclose(circuit_impedance(direct, S)[..., 0, 0], 1.4 * P_ATM_PA / 1e-3 / S, rtol=1e-12)


def test_lumped_and_distributed_pipe_agree_below_5_hz():
    """The example pipe (10 mm, 2.5 m) between a chamber and an accumulator."""
    f = np.linspace(0.1, 5.0, 60)
    circuit = Circuit("c", (Accumulator("n", 1e-3, 2e6), Pipe("p", "n", 2.5, 0.01)), (Port("p", 0, "top"),))
    zl = circuit_impedance(circuit, 2j * np.pi * f, "lumped")[..., 0, 0]
    zd = circuit_impedance(circuit, 2j * np.pi * f, "distributed")[..., 0, 0]
    assert np.max(np.abs(zl / zd - 1)) < 0.01


def test_his_static_stiffness_matches_design_section_2(rng):
    params = _random_his(rng)
    base = RollPlaneHIS()
    system = roll_plane_system(params, base)
    k_his = system.stroke_impedance(np.array([1e-7j]))[..., 0, :, :].real  # D(s -> 0)
    np.testing.assert_allclose(system.static_stiffness(), k_his, rtol=1e-9, atol=1e-12 * np.abs(k_his).max())
    k_acc = base.gamma * (params["p0"] + P_ATM_PA) / base.V0
    a_t, a_b = laws.cylinder_areas(params["dA"], params["lam"])
    pitch, warp = np.array([1, 1, -1, -1.0]), np.array([1, -1, -1, 1.0])
    bounce, roll = np.ones(4), np.array([1, -1, 1, -1.0])
    quad = lambda v: np.einsum("i,...ij,j->...", v, k_his, v)  # noqa: E731
    scale = np.abs(k_his).max()
    np.testing.assert_allclose(k_his @ pitch, 0, atol=1e-12 * scale)
    np.testing.assert_allclose(k_his @ warp, 0, atol=1e-12 * scale)
    # 2 dA per unit bounce stroke into each of two accumulators; 2 (A_t + A_b) in roll.
    np.testing.assert_allclose(quad(bounce), 2 * k_acc * (2 * params["dA"]) ** 2, rtol=1e-9)
    np.testing.assert_allclose(quad(roll), 2 * k_acc * (2 * (a_t + a_b)) ** 2, rtol=1e-9)


def test_valve_damping_matches_design_section_2(rng):
    params = _random_his(rng)
    system = roll_plane_system(params)
    w = 2 * np.pi * 3.0
    d = system.stroke_impedance(np.array([1j * w]))[..., 0, :, :]
    _, a_b = laws.cylinder_areas(params["dA"], params["lam"])
    c_his = d.imag / w
    np.testing.assert_allclose(np.diagonal(c_his, axis1=-2, axis2=-1), (params["Rv"] * a_b**2)[:, None] * np.ones(4), rtol=1e-9, atol=1e-9)
