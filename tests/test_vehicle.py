"""Vehicle matrices: symmetry, definiteness and the docs/model.md §2.3 structure."""

import numpy as np
import pytest

from hisopt.vehicle import VehicleParams, damping_matrix, mass_matrix, stiffness_matrix, stroke_matrix


def _is_spsd(a: np.ndarray) -> bool:
    return np.allclose(a, a.T, rtol=0, atol=1e-9 * np.abs(a).max()) and np.linalg.eigvalsh(a).min() >= -1e-9 * np.abs(a).max()


def test_mass_stiffness_damping_symmetric_psd():
    v = VehicleParams()
    for m in (mass_matrix(v), stiffness_matrix(v), damping_matrix(v)):
        assert _is_spsd(m)
    assert np.linalg.eigvalsh(stiffness_matrix(v)).min() > 0  # tyres ground every mode


def test_stroke_matrix_rigid_body_motions():
    v = VehicleParams()
    g = stroke_matrix(v)
    heave = np.array([1, 0, 0, 1, 1, 1, 1.0])  # body and wheels move together: no stroke
    np.testing.assert_allclose(g @ heave, 0, atol=1e-15)
    roll = np.array([0, 1, 0, 0, 0, 0, 0.0])
    np.testing.assert_allclose(g @ roll, [v.t_f, -v.t_f, v.t_r, -v.t_r])
    pitch = np.array([0, 0, 1, 0, 0, 0, 0.0])
    np.testing.assert_allclose(g @ pitch, [-v.l_f, -v.l_f, v.l_r, v.l_r])


def test_invalid_vehicle_rejected():
    with pytest.raises(ValueError, match="m_s"):
        VehicleParams(m_s=-1.0)
