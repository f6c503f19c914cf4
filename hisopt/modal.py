"""Modal analysis of the coupled model (paper Eq. 4-5, Table 1).

Lumped circuits: exact, from the eigenvalues of the state-space realisation. Distributed
pipes: the lumped roots refined by Newton's method on ``det K_dyn(s) = 0`` using
``d ln det K / ds = tr(K^-1 dK/ds)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from hisopt.constants import DOF_NAMES, WHEEL_NAMES
from hisopt.model import CoupledModel
from hisopt.units import attach_units

MODE_NAMES = ("bounce", "roll", "pitch") + tuple(f"wheel_hop_{w}" for w in WHEEL_NAMES)
"""Mode names, one per mechanical DOF, in DOF order (DESIGN section 6)."""

_SHAPE_COLUMNS = tuple(f"shape_{n}" for n in DOF_NAMES)


_MOTIONS = (  # one per entry of MODE_NAMES, same order
    "body bounce",
    "body roll",
    "body pitch",
    "front wheels in phase",
    "front wheels anti-phase",
    "rear wheels in phase",
    "rear wheels anti-phase",
)
# Orthonormal basis of the 7 DOFs by motion pattern (wheel pairs as sum and difference).
_R = 1 / np.sqrt(2)
_MOTION_BASIS = np.array(
    [
        [1, 0, 0, 0, 0, 0, 0],
        [0, 1, 0, 0, 0, 0, 0],
        [0, 0, 1, 0, 0, 0, 0],
        [0, 0, 0, _R, _R, 0, 0],
        [0, 0, 0, _R, -_R, 0, 0],
        [0, 0, 0, 0, 0, _R, _R],
        [0, 0, 0, 0, 0, _R, -_R],
    ]
)


def modal_table(model: CoupledModel, tol: float = 1e-8) -> pd.DataFrame:
    """Modes of a single-design model as a table, mechanical modes first.

    Columns: ``mode`` (``MODE_NAMES``; fluid-dominated modes of pipes are ``hydraulic_<k>``),
    ``frequency_hz`` (undamped, ``|s| / 2 pi``), ``damped_frequency_hz``, ``damping_ratio``,
    ``dominant`` (DOF with the largest kinetic-energy share), ``motion`` (bounce/roll/pitch or
    wheel pair in/anti-phase), ``mechanical_share`` (mechanical part of the kinetic energy)
    and the mode shape ``shape_<dof>`` normalised to a largest entry of +1 (paper Sec. II-A).
    Names are unique and stable: each motion pattern names the mode it dominates most (an
    optimal assignment on kinetic-energy shares). The wheel modes of a left-right symmetric
    car are pair motions: ``wheel_hop_fl``/``_fr`` are the front pair in phase/anti-phase,
    ``wheel_hop_rl``/``_rr`` the rear pair (the ``motion`` column says which).
    """
    ss = model.state_space()
    a = np.asarray(ss.a)
    if a.shape[:-2] not in ((), (1,)):
        raise ValueError("modal_table expects a single design; pass one design at a time")
    a = a.reshape(a.shape[-2:])
    weights = np.asarray(ss.kinetic_weights).reshape(-1)
    lam, vec = np.linalg.eig(a)
    scale = np.abs(lam).max()
    keep = lam.imag > tol * scale  # one of each conjugate pair; real (overdamped) roots dropped
    lam, vec = lam[keep], vec[:, keep]
    kinetic = weights[:, None] * np.abs(vec) ** 2
    mechanical = kinetic[7:14].sum(0) / kinetic.sum(0)
    # Kinetic energy per motion pattern (body bounce/roll/pitch, wheel pairs in/anti-phase)
    # as a share of the mode's total (fluid included); each pattern names the mode it
    # dominates most, by an optimal one-to-one assignment, so names are stable across designs.
    sqrt_m = np.sqrt(np.diag(model.mass))[:, None]
    motion_all = np.abs(_MOTION_BASIS @ (sqrt_m * vec[7:14])) ** 2 / kinetic.sum(0)
    rows, cols = linear_sum_assignment(-motion_all)
    names = {int(c): MODE_NAMES[r] for r, c in zip(rows, cols)}
    motions = {int(c): _MOTIONS[r] for r, c in zip(rows, cols)}

    if model.pipe_model == "distributed" and model.his is not None:
        lam = refine_roots(model, lam)
    records: list[dict[str, Any]] = []
    hydraulic = 0
    for c in range(lam.size):
        shape = vec[:7, c] / vec[np.argmax(np.abs(vec[:7, c])), c]
        if c in names:
            name, motion = names[c], motions[c]
        else:
            hydraulic += 1
            name, motion = f"hydraulic_{hydraulic}", "fluid"
        e = np.diag(model.mass) * np.abs(vec[:7, c]) ** 2
        records.append(
            {
                "mode": name,
                "frequency_hz": np.abs(lam[c]) / (2 * np.pi),
                "damped_frequency_hz": lam[c].imag / (2 * np.pi),
                "damping_ratio": -lam[c].real / np.abs(lam[c]),
                "dominant": DOF_NAMES[int(np.argmax(e))],
                "motion": motion,
                "mechanical_share": mechanical[c],
                **dict(zip(_SHAPE_COLUMNS, shape.real)),
            }
        )
    table = pd.DataFrame.from_records(records)
    rank = {n: i for i, n in enumerate(MODE_NAMES)}
    order = [rank.get(n, len(rank)) for n in table["mode"]]
    return table.iloc[np.lexsort((table["frequency_hz"].to_numpy(), order))].reset_index(drop=True)


def refine_roots(model: CoupledModel, roots: np.ndarray, iterations: int = 30) -> np.ndarray:
    """Newton refinement of roots of ``det K_dyn(s)`` (batched over the roots).

    The step is ``-1 / tr(K^-1 dK/ds)`` with ``dK/ds`` from a complex central difference.
    """
    s = np.asarray(roots, dtype=complex).copy()
    for _ in range(iterations):
        h = 1e-6 * np.abs(s)
        k = model.dynamic_stiffness(s)
        dk = (model.dynamic_stiffness(s + h) - model.dynamic_stiffness(s - h)) / (2 * h)[..., None, None]
        k, dk = k.reshape((-1,) + k.shape[-3:]), dk.reshape((-1,) + dk.shape[-3:])
        logdet_prime = np.trace(np.linalg.solve(k, dk), axis1=-2, axis2=-1)[0]
        step = -1.0 / logdet_prime
        s = s + step
        if np.all(np.abs(step) < 1e-12 * np.abs(s)):
            break
    return s


def modal_analysis(problem: Any, design: Any = None, his: bool = True) -> pd.DataFrame:
    """Modes of ``problem`` at ``design`` (DESIGN section 6; paper Table 1).

    Parameters
    ----------
    problem : a :class:`hisopt.problem.Problem`
    design : dict of variable names (missing ones take the baseline), a sequence in the
        problem's variable order, or ``None`` for the baseline design
    his : ``False`` gives the reference vehicle without HIS
    """
    x = problem.design_matrix(problem.baseline if design is None else design)
    if x.shape[0] != 1:
        raise ValueError(f"modal_analysis takes one design, got {x.shape[0]}")
    return attach_units(modal_table(problem.model(x, his=his)))  # units in attrs["units"]
