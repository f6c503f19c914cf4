"""Modal analysis of the coupled model (paper Eq. 4-5, Table 1).

Lumped circuits: exact, from the eigenvalues of the state-space realisation. Distributed
pipes: the lumped roots refined by Newton's method on ``det K_dyn(s) = 0``
(:func:`hisopt.coupled.roots.refine_roots`).

Mode names (docs/model.md §8.2) come from the mode shape alone, by the kinetic energy of
the car's motion with the oil it drives through the pipes (:mod:`hisopt.coupled.mode_energy`,
:func:`name_modes`), so a physical mode keeps its name across designs and with or without
HIS, and a wheel's hop carries its hoses' oil; the other modes of a pipe network, oil moving
against the hydraulic compliance, are ``oil_column_<k>``. Along a sequence of designs (a
sweep) :func:`track_modes` follows each mode continuously instead. The four wheel modes of a
whole batch of designs at once: :func:`wheel_modes`.

Names and their documented aliases (the names of hisopt 0.x, still accepted by
:func:`canonical_mode_name`):

=====================  ===============  ===============================================
name                   alias            motion
=====================  ===============  ===============================================
``bounce``                              body heave
``roll``                                body roll
``pitch``                               body pitch
``front_axle_hop``     ``wheel_hop_fl`` wheels of an axle in phase, front axle
``front_axle_tramp``   ``wheel_hop_fr`` wheels of an axle in anti-phase, front axle
``rear_axle_hop``      ``wheel_hop_rl`` wheels of an axle in phase, rear axle
``rear_axle_tramp``    ``wheel_hop_rr`` wheels of an axle in anti-phase, rear axle
=====================  ===============  ===============================================
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from hisopt.arguments import integer, number, problem_argument
from hisopt.constants import DOF_NAMES
from hisopt.coupled.mode_energy import (
    MODE_ALIASES,
    MODE_NAMES,
    ModeSet,
    mode_set,
    motion_coordinates,
    name_slots,
    wheel_modes,
)
from hisopt.coupled.model import CoupledModel
from hisopt.coupled.roots import refine_roots
from hisopt.errors import ConfigError
from hisopt.units import attach_units

__all__ = [
    "MODE_ALIASES",
    "MODE_NAMES",
    "canonical_mode_name",
    "mac",
    "mechanical_mode_shapes",
    "modal_analysis",
    "modal_table",
    "motion_coordinates",
    "name_modes",
    "refine_roots",
    "track_modes",
    "wheel_modes",
]

_SHAPE_COLUMNS = tuple(f"shape_{n}" for n in DOF_NAMES)


def canonical_mode_name(name: str) -> str:
    """The mode name for ``name``, which may be a name of :data:`MODE_NAMES` or an alias.

    Raises
    ------
    ValueError
        ``name`` is neither (the message lists both).
    """
    if name in MODE_NAMES:
        return name
    if name in MODE_ALIASES:
        return MODE_ALIASES[name]
    raise ValueError(f"unknown mode {name!r}; expected one of {', '.join(MODE_NAMES)} (or an alias: {', '.join(MODE_ALIASES)})")


def name_modes(u: np.ndarray, total_energy: np.ndarray) -> list[str | None]:
    """Name each mode of one design from its shape (``None``: not one of the seven mechanical
    modes), by the rule of :func:`hisopt.coupled.mode_energy.name_slots`.

    Parameters
    ----------
    u : np.ndarray
        [sqrt(kg) m/s] velocity shapes in motion coordinates (:func:`motion_coordinates`),
        ``(7, m)``
    total_energy : np.ndarray
        [J] each mode's energy budget (its kinetic energy including the oil's), ``(m,)``

    Returns
    -------
    list[str | None]
        A name of :data:`MODE_NAMES` or ``None`` per mode (``m`` entries).
    """
    slots = name_slots(np.asarray(u)[None], np.asarray(total_energy)[None])[0]
    return [MODE_NAMES[k] if k >= 0 else None for k in slots]


def _describe(name: str, u: np.ndarray) -> tuple[str, float]:
    """Motion description of a named mode and the energy share of the motion its name says
    (of its rigid-oil motion's energy, ``u`` in motion coordinates)."""
    energy = np.abs(u) ** 2
    share = float(energy[MODE_NAMES.index(name)] / energy.sum())  # the basis rows are in name order
    if name == "roll":
        return "body roll", share
    if name in ("bounce", "pitch"):
        b = energy[0] / (energy[0] + energy[2])
        text = f"body bounce {b:.0%}, pitch {1 - b:.0%}" if name == "bounce" else f"body pitch {1 - b:.0%}, bounce {b:.0%}"
        return text.replace("%", " %"), share
    kind, (i, j) = ("hop", (3, 5)) if name.endswith("hop") else ("tramp", (4, 6))
    front = energy[i] / (energy[i] + energy[j])
    sense = "in phase" if (u[i] * np.conj(u[j])).real >= 0 else "opposed"
    return f"{kind}: front {front:.0%}, rear {1 - front:.0%}, axles {sense}".replace("%", " %"), share


def _describe_oil(modes: ModeSet, c: int) -> str:
    """What an oil-column mode (column ``c`` of a one-design :class:`ModeSet`) moves: the shares
    of its kinetic energy in the oil of the pipes each axle drives and in the car."""
    pipes = modes.pipe_energy[0, :, c]
    axle = modes.pipe_axle[0]
    total = modes.total[0, c]
    front, rear = (float(pipes[axle == k].sum() / total) for k in (0, 1))
    text = f"oil column: front pipes {front:.0%}, rear pipes {rear:.0%}"
    other = 1.0 - front - rear - float(modes.mechanical[0, c])
    if other > 0.005:
        text += f", other pipes {other:.0%}"
    return (text + f", car {modes.mechanical[0, c]:.0%}").replace("%", " %")


def _single(model: CoupledModel, tol: float, what: str) -> ModeSet:
    """The :class:`ModeSet` of a one-design model (``what``: the caller, for the message)."""
    modes = mode_set(model, tol)
    if modes.lam.shape[0] != 1:
        raise ValueError(f"{what} expects a single design; pass one design at a time")
    return modes


def modal_table(model: CoupledModel, tol: float = 1e-8) -> pd.DataFrame:
    """Modes of a single-design model as a table, mechanical modes first.

    Columns: ``mode`` (:data:`MODE_NAMES`; the other modes of pipe networks, oil columns
    moving against the hydraulic compliance, are ``oil_column_<k>`` in order of frequency),
    ``frequency_hz`` (undamped, ``|s| / 2 pi``), ``damped_frequency_hz``, ``damping_ratio``,
    ``dominant`` (DOF with the largest kinetic-energy share), ``motion`` (what the mode does:
    bounce and pitch shares of the body's energy; for wheel modes the front and rear axles'
    shares and whether they move in the same or opposite sense; for an oil column the
    shares of its energy in each axle's pipes and in the car), ``motion_share`` (share of
    the mode's rigid-oil energy, the car with the oil it drives, in the motion its name
    says, e.g. 0.5 for each axle of the default car's tramps; 0 for oil columns),
    ``mechanical_share`` (the car's part of the kinetic energy) and the mode shape
    ``shape_<dof>`` normalised to a largest entry of +1 (paper Sec. II-A).

    Names come from the kinetic energy of each mode's motion with the oil it drives, by the
    rule of :func:`hisopt.coupled.mode_energy.name_slots` (docs/model.md §8.2): symmetry
    and body or wheel character fix the group (bounce/pitch, roll, axle hops, axle tramps);
    within a group, bounce is the mode with the larger bounce share, and of two wheel modes
    the front-dominated one, or, when both axles move equally (identical wheel stations
    front and rear), the one with front and rear in phase, is ``front_axle_*``. Older names
    are aliases (:data:`MODE_ALIASES`).
    """
    modes = _single(model, tol, "modal_table")
    keep = np.flatnonzero(modes.oscillating[0])
    lam, vec = modes.lam[0, keep], modes.vec[0][:, keep]
    if model.pipe_model == "distributed" and model.his is not None:
        lam = refine_roots(model, lam)
    records: list[dict[str, Any]] = []
    oil = 0
    for i in np.argsort(np.abs(lam), kind="stable"):
        c = keep[i]
        shape = vec[:7, i] / vec[np.argmax(np.abs(vec[:7, i])), i]
        slot = modes.slots[0, c]
        if slot < 0:
            oil += 1
            name, motion, share = f"oil_column_{oil}", _describe_oil(modes, c), 0.0
        else:
            name = MODE_NAMES[slot]
            motion, share = _describe(name, modes.u[0, :, c])
        e = np.diag(model.mass) * np.abs(vec[:7, i]) ** 2
        records.append(
            {
                "mode": name,
                "frequency_hz": np.abs(lam[i]) / (2 * np.pi),
                "damped_frequency_hz": lam[i].imag / (2 * np.pi),
                "damping_ratio": -lam[i].real / np.abs(lam[i]),
                "dominant": DOF_NAMES[int(np.argmax(e))],
                "motion": motion,
                "motion_share": share,
                "mechanical_share": modes.mechanical[0, c],
                **dict(zip(_SHAPE_COLUMNS, shape.real, strict=True)),
            }
        )
    table = pd.DataFrame.from_records(records)
    rank = {n: i for i, n in enumerate(MODE_NAMES)}
    order = [rank.get(n, len(rank)) for n in table["mode"]]
    return table.iloc[np.lexsort((table["frequency_hz"].to_numpy(), order))].reset_index(drop=True)


def _named(modes: ModeSet) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per design of ``modes``: the roots ``(7,)`` of the seven named modes and the car's
    motion in motion coordinates ``(7, 7)``, in :data:`MODE_NAMES` order (NaN if absent)."""
    out = []
    for d in range(modes.lam.shape[0]):
        lam = np.full(len(MODE_NAMES), np.nan, dtype=complex)
        u = np.full((7, len(MODE_NAMES)), np.nan, dtype=complex)
        for c in np.flatnonzero(modes.slots[d] >= 0):
            lam[modes.slots[d, c]], u[:, modes.slots[d, c]] = modes.lam[d, c], modes.shapes[d, :, c]
        out.append((lam, u))
    return out


def mechanical_mode_shapes(model: CoupledModel, tol: float = 1e-8) -> tuple[np.ndarray, np.ndarray]:
    """Roots and complex shapes of the seven mechanical modes of a single-design model.

    The names are :func:`modal_table`'s (the same rule); the shapes, the car's motion, are
    for comparing with measured motion (:func:`mac`), e.g. drop-test pairing
    (:mod:`hisopt.simulation.droptest`).

    Returns
    -------
    roots : np.ndarray
        [rad/s] ``(7,)`` in :data:`MODE_NAMES` order (of the lumped realisation; NaN where
        a mode is overdamped)
    shapes : np.ndarray
        [sqrt(kg) m/s] mass-weighted velocity shapes in motion coordinates
        (:func:`motion_coordinates`), ``(7, 7)``, column ``j`` mode ``MODE_NAMES[j]`` (NaN if absent)
    """
    return _named(_single(model, tol, "mechanical_mode_shapes"))[0]


def modal_analysis(problem: Any, design: Any = None, his: bool = True) -> pd.DataFrame:
    """Modes of ``problem`` at ``design`` (docs/model.md §8.2; paper Table 1).

    Parameters
    ----------
    problem : Any
        a :class:`hisopt.problem.Problem`
    design : Any, optional
        dict of variable names (missing ones take the baseline), a sequence in the
        problem's variable order, or ``None`` for the baseline design
    his : bool, optional
        ``False`` gives the reference vehicle without HIS

    Returns
    -------
    pd.DataFrame
        The :func:`modal_table` of the design: one row per mode, named by its shape.
    """
    problem_argument(problem)
    x = problem.design_matrix(problem.baseline if design is None else design)
    if x.shape[0] != 1:
        raise ConfigError(f"modal_analysis takes one design, got {x.shape[0]}", key="design")
    return attach_units(modal_table(problem.model(x, his=his)))  # units in attrs["units"]


# --- following modes along a path of designs ---------------------------------------------------
def mac(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """[-] Modal assurance criterion ``|u_i^H v_j|^2 / (|u_i|^2 |v_j|^2)``, ``(m, k)``; NaN shapes give 0.

    Parameters
    ----------
    u, v : np.ndarray
        mass-weighted shapes (e.g. :func:`motion_coordinates`), ``(7, m)`` and ``(7, k)``
    """
    num = np.abs(u.conj().T @ v) ** 2
    den = np.outer(np.sum(np.abs(u) ** 2, 0), np.sum(np.abs(v) ** 2, 0))
    with np.errstate(invalid="ignore"):
        out = num / den
    return np.nan_to_num(out, nan=0.0)


def _follow(
    prev: tuple[np.ndarray, np.ndarray],
    x_prev: np.ndarray,
    nxt: tuple[np.ndarray, np.ndarray],
    x_next: np.ndarray,
    compute: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    min_mac: float,
    depth: int,
) -> tuple[np.ndarray, np.ndarray]:
    """``nxt``'s modes reordered to follow ``prev``'s, bisecting the step while it is ambiguous."""
    m = mac(prev[1], nxt[1])
    rows, cols = linear_sum_assignment(-m)
    order = cols[np.argsort(rows)]
    matched = m[np.arange(m.shape[0]), order]
    present = ~np.isnan(prev[0]) & ~np.isnan(nxt[0][order])
    if depth == 0 or np.all(matched[present] >= min_mac):
        return nxt[0][order], nxt[1][:, order]
    x_mid = 0.5 * (x_prev + x_next)
    mid = _follow(prev, x_prev, compute(x_mid), x_mid, compute, min_mac, depth - 1)
    return _follow(mid, x_mid, nxt, x_next, compute, min_mac, depth - 1)


def track_modes(
    problem: Any,
    designs: Any,
    anchor: int = 0,
    his: bool = True,
    min_mac: float = 0.9,
    max_depth: int = 12,
) -> pd.DataFrame:
    """The mechanical modes along a path of designs, each followed continuously (sweeps).

    Names are those of the design at ``anchor`` (:func:`modal_table`'s rule); from there
    each mode is followed to the next design by its shape: the modes of neighbouring designs
    are paired by an optimal assignment on the modal assurance criterion (MAC) of their
    mass-weighted shapes, and while any pair's MAC is below ``min_mac`` the step is halved
    (up to ``max_depth`` times), so modes that cross or veer are followed through. A name
    therefore stays on one continuous frequency curve; where two modes exchange character
    (the bounce and pitch modes of the default car veer near p0 = 0.65 MPa) the curve keeps
    its name while ``motion_share`` falls below 1/2, and :func:`modal_table` of a design
    beyond the veering names the mode by its new character.

    Parameters
    ----------
    problem : Any
        a :class:`hisopt.problem.Problem`
    designs : Any
        ``n`` designs along the path, as :meth:`hisopt.problem.Problem.design_matrix`
        accepts (consecutive designs should be close, e.g. a sweep's grid)
    anchor : int, optional
        [-] index of the design whose names the curves take
    his : bool, optional
        ``False`` gives the reference vehicle without HIS
    min_mac : float, optional
        [-] smallest MAC accepted between a mode and its successor without bisection
    max_depth : int, optional
        [-] most halvings of one step

    Returns
    -------
    pd.DataFrame
        One row per design and mode (``n * 7`` rows, designs in order, modes in
        :data:`MODE_NAMES` order): ``design`` (index into ``designs``), ``mode``,
        ``frequency_hz``, ``damped_frequency_hz``, ``damping_ratio`` and ``motion_share`` (as
        in :func:`modal_table`; NaN where a mode is overdamped).
    """
    problem_argument(problem)
    x = problem.design_matrix(designs)
    if not len(x):
        raise ConfigError("expected at least one design, got none", key="designs")
    anchor = integer(anchor, "anchor", minimum=0)
    if anchor >= len(x):
        raise ConfigError(f"{anchor} is not a design index (0 to {len(x) - 1})", key="anchor")
    number(min_mac, "min_mac", low=0.0, high=1.0)
    integer(max_depth, "max_depth", minimum=0)

    def sets(xs: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        named = _named(mode_set(problem.model(xs, his=his)))
        return named * len(xs) if len(named) == 1 and len(xs) > 1 else named  # the reference vehicle: one model

    points = sets(x)
    tracked: list[tuple[np.ndarray, np.ndarray]] = list(points)
    for step in (1, -1):
        stop = len(x) if step == 1 else -1
        for i in range(anchor + step, stop, step):
            tracked[i] = _follow(tracked[i - step], x[i - step], points[i], x[i], lambda xm: sets(xm[None])[0], min_mac, max_depth)
    lam = np.array([t[0] for t in tracked])  # (n, 7)
    distributed = his and problem.model(x[:1]).pipe_model == "distributed"
    if distributed:
        lam = np.array([refine_roots(problem.model(x[i : i + 1]), lam[i]) for i in range(len(x))])
    energy = np.array([np.abs(t[1]) ** 2 for t in tracked])  # (n, 7 coords, 7 modes)
    own = np.arange(len(MODE_NAMES))  # the basis rows are in name order
    share = energy[:, own, np.arange(len(MODE_NAMES))] / energy.sum(1)
    return pd.DataFrame(
        {
            "design": np.repeat(np.arange(len(x)), len(MODE_NAMES)),
            "mode": np.tile(MODE_NAMES, len(x)),
            "frequency_hz": (np.abs(lam) / (2 * np.pi)).ravel(),
            "damped_frequency_hz": (lam.imag / (2 * np.pi)).ravel(),
            "damping_ratio": (-lam.real / np.abs(lam)).ravel(),
            "motion_share": share.ravel(),
        }
    )
