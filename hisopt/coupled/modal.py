"""Modal analysis of the coupled model (paper Eq. 4-5, Table 1).

Lumped circuits: exact, from the eigenvalues of the state-space realisation. Distributed
pipes: the lumped roots refined by Newton's method on ``det K_dyn(s) = 0`` using
``d ln det K / ds = tr(K^-1 dK/ds)``.

Mode names (docs/model.md §8.2) come from the mode shape alone (:func:`name_modes`), so a
physical mode keeps its name across designs and with or without HIS; along a sequence of
designs (a sweep) :func:`track_modes` follows each mode continuously instead.

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
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from hisopt.arguments import integer, number, problem_argument
from hisopt.constants import DOF_NAMES
from hisopt.coupled.model import CoupledModel
from hisopt.errors import ConfigError
from hisopt.units import attach_units

MODE_NAMES = ("bounce", "roll", "pitch", "front_axle_hop", "front_axle_tramp", "rear_axle_hop", "rear_axle_tramp")
"""Mechanical mode names, in table order (docs/model.md §8.2)."""

MODE_ALIASES: dict[str, str] = {
    "wheel_hop_fl": "front_axle_hop",
    "wheel_hop_fr": "front_axle_tramp",
    "wheel_hop_rl": "rear_axle_hop",
    "wheel_hop_rr": "rear_axle_tramp",
}
"""Older wheel-mode names (alias -> name); :func:`canonical_mode_name` accepts either."""

_SHAPE_COLUMNS = tuple(f"shape_{n}" for n in DOF_NAMES)

# Orthonormal basis of the 7 DOFs by motion pattern (wheel pairs of an axle as sum and
# difference); rows are the "motion coordinates" of a mass-weighted mode shape.
_R = 1 / np.sqrt(2)
_MOTION_BASIS = np.array(
    [
        [1, 0, 0, 0, 0, 0, 0],  # 0 body bounce
        [0, 1, 0, 0, 0, 0, 0],  # 1 body roll
        [0, 0, 1, 0, 0, 0, 0],  # 2 body pitch
        [0, 0, 0, _R, _R, 0, 0],  # 3 front axle hop (wheels in phase)
        [0, 0, 0, _R, -_R, 0, 0],  # 4 front axle tramp (wheels in anti-phase)
        [0, 0, 0, 0, 0, _R, _R],  # 5 rear axle hop
        [0, 0, 0, 0, 0, _R, -_R],  # 6 rear axle tramp
    ]
)
_COORDINATE = {name: i for i, name in enumerate(MODE_NAMES)}  # the basis rows are in name order


@dataclass(frozen=True)
class _Group:
    """Modes sharing a left-right symmetry and body-or-wheel character.

    ``coords``: the motion coordinates spanning the group; ``names``: one per mode; for a
    two-mode group the first name goes to the mode closest to the direction ``angle`` [rad]
    in the plane of the two coordinates.
    """

    coords: tuple[int, ...]
    names: tuple[str, ...]
    angle: float


_GROUPS = (
    _Group((0, 2), ("bounce", "pitch"), 0.0),  # left-right symmetric, body
    _Group((1,), ("roll",), 0.0),  # antisymmetric, body
    _Group((3, 5), ("front_axle_hop", "rear_axle_hop"), np.pi / 8),  # symmetric, wheels
    _Group((4, 6), ("front_axle_tramp", "rear_axle_tramp"), np.pi / 8),  # antisymmetric, wheels
)


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


def motion_coordinates(shapes: np.ndarray, mass_diag: np.ndarray) -> np.ndarray:
    """[sqrt(kg) x shape unit] Mass-weighted shapes in the motion basis.

    Parameters
    ----------
    shapes : np.ndarray
        [m, rad] mode shapes over ``DOF_NAMES`` (displacements or velocities), ``(7, m)``
    mass_diag : np.ndarray
        [kg, kg m^2] diagonal of the mass matrix, ``(7,)``

    Returns
    -------
    np.ndarray
        ``(7, m)`` complex: bounce, roll, pitch, front hop, front tramp, rear hop, rear tramp;
        ``|u|^2`` per coordinate is the kinetic energy of that motion (for velocity shapes).
    """
    return _MOTION_BASIS @ (np.sqrt(mass_diag)[:, None] * shapes)


def _first_in_pair(u0: np.ndarray, u1: np.ndarray, angle: float) -> np.ndarray:
    """[-] Closeness of each mode to the direction ``angle`` in the ``(u0, u1)`` plane, ``(m,)``."""
    return np.abs(np.cos(angle) * u0 + np.sin(angle) * u1) ** 2 / (np.abs(u0) ** 2 + np.abs(u1) ** 2)


def name_modes(u: np.ndarray, total_energy: np.ndarray) -> list[str | None]:
    """Name each mode from its shape (``None``: not one of the seven mechanical modes).

    Two steps, both on kinetic energy:

    1. Group: each mode goes to one of four groups, left-right symmetric body (bounce,
       pitch), antisymmetric body (roll), symmetric wheels (axle hops), antisymmetric wheels
       (axle tramps), by an optimal one-to-one assignment of modes to the seven places on
       each mode's energy in the group's motions (as a share of its total kinetic energy,
       fluid included, so fluid modes of pipes stay unnamed). A left-right symmetric car's
       modes are exactly symmetric or antisymmetric and body and wheel modes lie a decade
       apart in frequency, so the groups never change with the design.
    2. Within a two-mode group: the mode closer to a reference direction in the plane of the
       group's two motions takes the first name. Body: the direction is pure bounce, so
       ``bounce`` is the mode with the larger bounce share and ``pitch`` the other (where the
       two modes of this car exchange character, p0 near 0.65 MPa at the baseline, the names
       exchange with it; :func:`track_modes` follows curves instead). Wheels: the direction
       is 22.5 degrees from front towards rear in phase, ``(cos 22.5, sin 22.5)`` in (front,
       rear) coordinates. A car whose axles differ has front- and rear-dominated wheel modes
       (near 0 and 90 degrees): the front-dominated one is ``front_axle_*``. A car with
       identical wheel stations front and rear (the default car) has wheel modes in which
       both axles move equally, front and rear in phase (+45 degrees) or opposite (-45
       degrees), for every design: the in-phase one is ``front_axle_*``, the opposite one
       (for tramps the wheel warp, untouched by a roll-plane HIS) ``rear_axle_*``. Both
       cases lie 22.5 degrees from the decision boundary, so neither flips with the design.

    Parameters
    ----------
    u : np.ndarray
        [sqrt(kg) m/s] velocity shapes in motion coordinates (:func:`motion_coordinates`),
        ``(7, m)``
    total_energy : np.ndarray
        [J] kinetic energy of each mode including fluid inertance, ``(m,)``

    Returns
    -------
    list[str | None]
        A name of :data:`MODE_NAMES` or ``None`` per mode (``m`` entries).
    """
    energy = np.abs(u) ** 2
    slots = [(g, k) for g in _GROUPS for k in range(len(g.names))]
    score = np.array([energy[list(g.coords)].sum(0) / total_energy for g, _ in slots])
    rows, cols = linear_sum_assignment(-score)
    members: dict[int, list[int]] = {}
    for r, c in zip(rows, cols, strict=True):
        members.setdefault(_GROUPS.index(slots[r][0]), []).append(int(c))
    names: list[str | None] = [None] * u.shape[1]
    for gi, modes in members.items():
        g = _GROUPS[gi]
        if len(g.names) == 1:
            names[modes[0]] = g.names[0]
            continue
        closeness = _first_in_pair(u[g.coords[0], modes], u[g.coords[1], modes], g.angle)
        first = int(np.argmax(closeness)) if len(modes) == 2 else (0 if closeness[0] > 0.5 else -1)
        for k, mode in enumerate(modes):
            names[mode] = g.names[0] if k == first else g.names[1]
    return names


def _describe(name: str, u: np.ndarray) -> tuple[str, float]:
    """Motion description of a named mode and the energy share of the motion its name says."""
    energy = np.abs(u) ** 2
    share = float(energy[_COORDINATE[name]] / energy.sum())
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


@dataclass(frozen=True)
class _Modes:
    """Oscillating modes of one design: roots ``(m,)``, state vectors ``(n, m)``, names."""

    lam: np.ndarray
    vec: np.ndarray
    u: np.ndarray
    total_energy: np.ndarray
    names: list[str | None]

    def named(self) -> tuple[np.ndarray, np.ndarray]:
        """Roots ``(7,)`` and motion coordinates ``(7, 7)`` in :data:`MODE_NAMES` order (NaN if absent)."""
        lam = np.full(len(MODE_NAMES), np.nan, dtype=complex)
        u = np.full((7, len(MODE_NAMES)), np.nan, dtype=complex)
        for c, name in enumerate(self.names):
            if name is not None:
                lam[MODE_NAMES.index(name)], u[:, MODE_NAMES.index(name)] = self.lam[c], self.u[:, c]
        return lam, u


def _modes_from(a: np.ndarray, weights: np.ndarray, mass_diag: np.ndarray, tol: float) -> _Modes:
    """Oscillating modes (one root of each conjugate pair) of a single state matrix ``a``."""
    lam, vec = np.linalg.eig(a)
    scale = np.abs(lam).max()
    keep = lam.imag > tol * scale  # real (overdamped) roots dropped
    lam, vec = lam[keep], vec[:, keep]
    total = (weights[:, None] * np.abs(vec) ** 2).sum(0)
    u = motion_coordinates(vec[7:14], mass_diag)
    return _Modes(lam, vec, u, total, name_modes(u, total))


def _state(model: CoupledModel) -> tuple[np.ndarray, np.ndarray]:
    """State matrices ``(b, n, n)`` and kinetic weights ``(b, n)`` of a model, batch flattened."""
    ss = model.state_space()
    a = np.asarray(ss.a)
    weights = np.broadcast_to(np.asarray(ss.kinetic_weights), a.shape[:-1])
    return a.reshape((-1,) + a.shape[-2:]), weights.reshape((-1, a.shape[-1]))


def modal_table(model: CoupledModel, tol: float = 1e-8) -> pd.DataFrame:
    """Modes of a single-design model as a table, mechanical modes first.

    Columns: ``mode`` (:data:`MODE_NAMES`; fluid-dominated modes of pipes are
    ``hydraulic_<k>``), ``frequency_hz`` (undamped, ``|s| / 2 pi``), ``damped_frequency_hz``,
    ``damping_ratio``, ``dominant`` (DOF with the largest kinetic-energy share), ``motion``
    (what the mode does: bounce and pitch shares of the body's energy; for wheel modes the
    front and rear axles' shares and whether they move in the same or opposite sense),
    ``motion_share`` (share of the mode's mechanical kinetic energy in the motion its name
    says, e.g. 0.5 for each axle of the default car's tramps), ``mechanical_share`` (mechanical
    part of the kinetic energy) and the mode shape ``shape_<dof>`` normalised to a largest
    entry of +1 (paper Sec. II-A).

    Names come from the shape by the rule of :func:`name_modes`: symmetry and body or wheel
    character fix the group (bounce/pitch, roll, axle hops, axle tramps); within a group,
    bounce is the mode with the larger bounce share, and of two wheel modes the
    front-dominated one, or, when both axles move equally (identical wheel stations front
    and rear), the one with front and rear in phase, is ``front_axle_*``. Older names are
    aliases (:data:`MODE_ALIASES`).
    """
    a, weights = _state(model)
    if a.shape[0] != 1:
        raise ValueError("modal_table expects a single design; pass one design at a time")
    modes = _modes_from(a[0], weights[0], np.diag(model.mass), tol)
    lam, vec = modes.lam, modes.vec
    mechanical = (weights[0, 7:14, None] * np.abs(vec[7:14]) ** 2).sum(0) / modes.total_energy
    if model.pipe_model == "distributed" and model.his is not None:
        lam = refine_roots(model, lam)
    records: list[dict[str, Any]] = []
    hydraulic = 0
    for c in np.argsort(np.abs(lam), kind="stable"):
        shape = vec[:7, c] / vec[np.argmax(np.abs(vec[:7, c])), c]
        name = modes.names[c]
        if name is None:
            hydraulic += 1
            name, motion, share = f"hydraulic_{hydraulic}", "fluid", 0.0
        else:
            motion, share = _describe(name, modes.u[:, c])
        e = np.diag(model.mass) * np.abs(vec[:7, c]) ** 2
        records.append(
            {
                "mode": name,
                "frequency_hz": np.abs(lam[c]) / (2 * np.pi),
                "damped_frequency_hz": lam[c].imag / (2 * np.pi),
                "damping_ratio": -lam[c].real / np.abs(lam[c]),
                "dominant": DOF_NAMES[int(np.argmax(e))],
                "motion": motion,
                "motion_share": share,
                "mechanical_share": mechanical[c],
                **dict(zip(_SHAPE_COLUMNS, shape.real, strict=True)),
            }
        )
    table = pd.DataFrame.from_records(records)
    rank = {n: i for i, n in enumerate(MODE_NAMES)}
    order = [rank.get(n, len(rank)) for n in table["mode"]]
    return table.iloc[np.lexsort((table["frequency_hz"].to_numpy(), order))].reset_index(drop=True)


def mechanical_mode_shapes(model: CoupledModel, tol: float = 1e-8) -> tuple[np.ndarray, np.ndarray]:
    """Roots and complex shapes of the seven mechanical modes of a single-design model.

    The names are :func:`modal_table`'s (the same rule); the shapes are for comparing with
    measured motion (:func:`mac`), e.g. drop-test pairing (:mod:`hisopt.simulation.droptest`).

    Returns
    -------
    roots : np.ndarray
        [rad/s] ``(7,)`` in :data:`MODE_NAMES` order (of the lumped realisation; NaN where
        a mode is overdamped)
    shapes : np.ndarray
        [sqrt(kg) m/s] mass-weighted velocity shapes in motion coordinates
        (:func:`motion_coordinates`), ``(7, 7)``, column ``j`` mode ``MODE_NAMES[j]`` (NaN if absent)
    """
    a, weights = _state(model)
    if a.shape[0] != 1:
        raise ValueError("mechanical_mode_shapes expects a single design; pass one design at a time")
    return _modes_from(a[0], weights[0], np.diag(model.mass), tol).named()


def _log_det_slope(k: np.ndarray, dk: np.ndarray) -> np.ndarray:
    """``tr(K^-1 dK/ds)`` of a batch ``(..., 7, 7)``; ``inf`` (a Newton step of 0) where ``K``
    is singular to working precision: there ``s`` is a root already (Newton lands on one
    exactly now and then), and one such root must not fail the whole batch."""
    try:
        return np.trace(np.linalg.solve(k, dk), axis1=-2, axis2=-1)
    except np.linalg.LinAlgError:
        out = np.empty(k.shape[:-2], dtype=complex)
        for i in np.ndindex(out.shape):  # rare: only a batch with an exactly singular K
            try:
                out[i] = np.trace(np.linalg.solve(k[i], dk[i]))
            except np.linalg.LinAlgError:
                out[i] = np.inf
        return out


def refine_roots(model: CoupledModel, roots: np.ndarray, iterations: int = 30) -> np.ndarray:
    """Newton refinement of roots of ``det K_dyn(s)`` (batched over the roots).

    The step is ``-1 / tr(K^-1 dK/ds)`` with ``dK/ds`` from a complex central difference.

    Parameters
    ----------
    roots : np.ndarray
        ``(R,)`` roots of a one-design model, or ``(n, R)``, row ``i`` design ``i``'s
    """
    s = np.asarray(roots, dtype=complex).copy()
    for _ in range(iterations):
        h = 1e-6 * np.abs(s)
        k = model.dynamic_stiffness(s)
        dk = (model.dynamic_stiffness(s + h) - model.dynamic_stiffness(s - h)) / (2 * h)[..., None, None]
        step = -1.0 / _log_det_slope(k, dk).reshape(s.shape)
        s = s + step
        if np.all(np.abs(step) < 1e-12 * np.abs(s)):
            break
    return s


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
    mass_diag = np.diag(problem.model(x[:1], his=his).mass)

    def sets(xs: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        a, weights = _state(problem.model(xs, his=his))
        if a.shape[0] == 1 and len(xs) > 1:  # reference vehicle: one model for every design
            a, weights = np.repeat(a, len(xs), 0), np.repeat(weights, len(xs), 0)
        return [_modes_from(a[i], weights[i], mass_diag, 1e-8).named() for i in range(len(xs))]

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
    own = np.array([_COORDINATE[n] for n in MODE_NAMES])
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
