"""Mode names from kinetic energy, the oil's included, and the wheel modes of a batch of designs.

A mode is named by where its kinetic energy sits (docs/model.md §8.2). The oil in a pipe
carries ``1/2 L q^2`` (``L = rho l / A``, the pipe's inertance): a hose's oil column moves
``A_chamber / A_hose`` times faster than the stroke, so it adds ``rho l A_chamber^2 / A_hose``
to the wheel's mass (about 80 kg per rear corner of ``problems/roll_plane_his_parts.toml``'s
2.5 m hoses). Each mode's motion is therefore split, in the kinetic-energy inner product, into

- its *rigid-oil* part: the body and wheels moving with the oil they drive through the pipes
  as a rigid column (the flows a slow stroke drives, :func:`rigid_oil_flows`), whose
  effective masses are the car's plus the oil's, ``M + T^T L T``; and
- the rest: oil moving against the hydraulic compliance relative to the car (an oil column).

The seven mechanical names go to the modes whose rigid-oil motion holds the most energy
(:func:`name_slots`); every other oscillating mode is an oil column. Without pipes the split
is the car's motion alone and the names are those of the car's kinetic energy.

:func:`wheel_modes` gives the four wheel modes of every design of a batch at once: one
batched eigen-decomposition, the naming vectorised over designs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hisopt.coupled.model import CoupledModel, StateSpace
from hisopt.coupled.roots import refine_roots
from hisopt.hydraulics.network import low_frequency_unknowns
from hisopt.vehicle import stroke_matrix

MODE_NAMES = ("bounce", "roll", "pitch", "front_axle_hop", "front_axle_tramp", "rear_axle_hop", "rear_axle_tramp")
"""Mechanical mode names, in table order (docs/model.md §8.2)."""

MODE_ALIASES: dict[str, str] = {
    "wheel_hop_fl": "front_axle_hop",
    "wheel_hop_fr": "front_axle_tramp",
    "wheel_hop_rl": "rear_axle_hop",
    "wheel_hop_rr": "rear_axle_tramp",
}
"""Older wheel-mode names (alias -> name); :func:`hisopt.coupled.modal.canonical_mode_name` accepts either."""

WHEEL_MODE_SLOTS = tuple(MODE_NAMES.index(name) for name in MODE_ALIASES.values())
"""[-] The mode of each wheel FL, FR, RL, RR (its alias ``wheel_hop_<wheel>``), as indices of
:data:`MODE_NAMES`: front axle hop, front axle tramp, rear axle hop, rear axle tramp."""

_R = 1 / np.sqrt(2)
MOTION_BASIS = np.array(
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
"""Orthonormal basis of the 7 DOFs by motion pattern (each axle's wheels as sum and
difference); row ``k`` is the motion coordinate of ``MODE_NAMES[k]``."""


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


def motion_coordinates(shapes: np.ndarray, mass_diag: np.ndarray) -> np.ndarray:
    """[sqrt(kg) x shape unit] Mass-weighted shapes in the motion basis.

    Parameters
    ----------
    shapes : np.ndarray
        [m, rad] mode shapes over ``DOF_NAMES`` (displacements or velocities), ``B + (7, m)``
    mass_diag : np.ndarray
        [kg, kg m^2] diagonal of the mass matrix, ``B + (7,)``

    Returns
    -------
    np.ndarray
        ``B + (7, m)``: bounce, roll, pitch, front hop, front tramp, rear hop, rear tramp;
        ``|u|^2`` per coordinate is the kinetic energy of that motion (for velocity shapes).
    """
    return MOTION_BASIS @ (np.sqrt(mass_diag)[..., :, None] * shapes)


def _closeness(u0: np.ndarray, u1: np.ndarray, angle: float) -> np.ndarray:
    """[-] Closeness of each mode to the direction ``angle`` in the ``(u0, u1)`` plane (0 where
    the mode has neither motion)."""
    num = np.abs(np.cos(angle) * u0 + np.sin(angle) * u1) ** 2
    den = np.abs(u0) ** 2 + np.abs(u1) ** 2
    return np.divide(num, den, out=np.zeros(np.shape(num)), where=den > 0)


def name_slots(u: np.ndarray, budget: np.ndarray, candidate: np.ndarray | None = None) -> np.ndarray:
    """[-] Each mode's index in :data:`MODE_NAMES` (``-1``: none), batched over designs.

    Two steps, both on kinetic energy:

    1. Group: each mode goes to one of four groups, left-right symmetric body (bounce,
       pitch), antisymmetric body (roll), symmetric wheels (axle hops), antisymmetric wheels
       (axle tramps), on its *score* in each: the energy of the group's motions as a share of
       the mode's energy budget (``budget``: the motions' energies plus the oil's relative
       motion, so oil columns score low everywhere). The seven places are filled greedily,
       the largest score first among the groups with a place left and the modes not yet
       placed. A left-right symmetric car's modes are exactly symmetric or antisymmetric and
       body and wheel modes lie a decade apart in frequency, so the groups never change with
       the design.
    2. Within a two-mode group: the mode closer to a reference direction in the plane of the
       group's two motions takes the first name. Body: the direction is pure bounce, so
       ``bounce`` is the mode with the larger bounce share and ``pitch`` the other (where the
       two modes of this car exchange character, p0 near 0.65 MPa at the baseline, the names
       exchange with it; :func:`hisopt.coupled.modal.track_modes` follows curves instead).
       Wheels: the direction is 22.5 degrees from front towards rear in phase,
       ``(cos 22.5, sin 22.5)`` in (front, rear) coordinates. A car whose axles differ has
       front- and rear-dominated wheel modes (near 0 and 90 degrees): the front-dominated one
       is ``front_axle_*``. A car with identical wheel stations front and rear (the default
       car) has wheel modes in which both axles move equally, front and rear in phase (+45
       degrees) or opposite (-45 degrees), for every design: the in-phase one is
       ``front_axle_*``, the opposite one (for tramps the wheel warp, untouched by a
       roll-plane HIS) ``rear_axle_*``. Both cases lie 22.5 degrees from the decision
       boundary, so neither flips with the design.

    Parameters
    ----------
    u : np.ndarray
        [sqrt(kg) m/s] velocity shapes in motion coordinates, ``(b, 7, m)`` (for a pipe
        network those of each mode's rigid-oil motion, :class:`ModeSet`)
    budget : np.ndarray
        [J] each mode's energy budget, ``(b, m)``
    candidate : np.ndarray, optional
        [-] the modes that may take a name, ``(b, m)`` (default: all)

    Returns
    -------
    np.ndarray
        ``(b, m)`` int
    """
    b, _, m = u.shape
    energy = np.abs(u) ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        score = np.stack([energy[:, list(g.coords)].sum(1) / budget for g in _GROUPS], axis=1)  # (b, groups, m)
    open_mode = np.ones((b, m), dtype=bool) if candidate is None else np.asarray(candidate, dtype=bool).copy()
    capacity = np.tile([len(g.names) for g in _GROUPS], (b, 1))
    group = np.full((b, m), -1)
    rows = np.arange(b)
    for _ in range(len(MODE_NAMES)):
        allowed = (capacity[:, :, None] > 0) & open_mode[:, None, :] & np.isfinite(score)
        flat = np.where(allowed, score, -np.inf).reshape(b, -1)
        pick = np.argmax(flat, axis=1)
        ok = np.isfinite(flat[rows, pick])
        g, mode = np.divmod(pick, m)
        group[rows[ok], mode[ok]] = g[ok]
        capacity[rows[ok], g[ok]] -= 1
        open_mode[rows[ok], mode[ok]] = False
    slots = np.full((b, m), -1)
    for gi, g in enumerate(_GROUPS):
        member = group == gi
        first = MODE_NAMES.index(g.names[0])
        if len(g.names) == 1:
            slots[member] = first
            continue
        close = _closeness(u[:, g.coords[0]], u[:, g.coords[1]], g.angle)
        best = np.argmax(np.where(member, close, -np.inf), axis=1)
        is_first = np.zeros((b, m), dtype=bool)
        is_first[rows, best] = True
        single = member.sum(1) == 1  # one mode of the pair: the first name only if it lies nearer
        is_first[single] = (member & (close > 0.5))[single]
        slots[member & is_first] = first
        slots[member & ~is_first] = MODE_NAMES.index(g.names[1])
    return slots


def rigid_oil_flows(model: CoupledModel, ss: StateSpace) -> tuple[np.ndarray, np.ndarray]:
    """The states of ``ss`` that are pipe flows and the flows the body and wheels drive through
    them when the oil moves as a rigid column.

    The rigid-oil flows are the network's flows under slow stroke motion (:func:`low_frequency_unknowns`:
    the oil shares itself among the compliances at one pressure per circuit), per velocity of
    each DOF: ``T = H_0[pipe rows] N G``. For a hose from a chamber to its accumulator ``T``
    is the chamber's area on its wheel (less the tiny share the hose's own compliance keeps).

    Parameters
    ----------
    model : CoupledModel
        the model whose :meth:`~hisopt.coupled.model.CoupledModel.state_space` ``ss`` is
    ss : StateSpace
        its state space

    Returns
    -------
    states : np.ndarray
        [-] the pipe-flow states' indices, ``(k,)``
    flows : np.ndarray
        [m^3/s per m/s or rad/s] ``B + (k, 7)``
    """
    if model.his is None or ss.realisation is None:
        return np.zeros(0, dtype=int), np.zeros(ss.a.shape[:-2] + (0, 7))
    lumped = model if model.pipe_model == "lumped" else CoupledModel(model.vehicle, model.his.lumped())
    inner = lumped.groups()[0][1]  # the model the realisation was built on (shorts merged)
    his = inner.his
    assert his is not None
    network = his.network
    kept = np.asarray(ss.realisation.kept)
    states = np.flatnonzero((kept >= 14) & network.is_flow[np.maximum(kept - 14, 0)])
    if not states.size:
        return states, np.zeros(ss.a.shape[:-2] + (0, 7))
    h0 = low_frequency_unknowns(network, his.values)[..., kept[states] - 14, :]
    return states, h0 @ np.asarray(his.incidence) @ stroke_matrix(inner.vehicle)


@dataclass(frozen=True)
class ModeSet:
    """The modes of a batch of designs with their kinetic energies and names (module docstring).

    Attributes
    ----------
    lam : np.ndarray
        [rad/s] every root, ``(b, n)``
    vec : np.ndarray
        its state vector, ``(b, n, n)``
    oscillating : np.ndarray
        [-] one root of each oscillating pair (positive imaginary part), ``(b, n)``
    shapes : np.ndarray
        [sqrt(kg) m/s] the car's motion in motion coordinates (:func:`motion_coordinates`),
        ``(b, 7, n)``
    u : np.ndarray
        [sqrt(kg) m/s] the rigid-oil motion in motion coordinates, each DOF weighted by its
        effective mass (its own plus the oil it drives), ``(b, 7, n)``
    wheel_energy : np.ndarray
        [J] each wheel's rigid-oil energy (effective mass times speed squared), ``(b, 4, n)``
    budget : np.ndarray
        [J] ``sum |u|^2`` plus the energy of the oil's motion relative to the rigid-oil
        motion, ``(b, n)``: what the names' shares are of
    total : np.ndarray
        [J] the whole kinetic energy (car and oil), ``(b, n)``
    mechanical : np.ndarray
        [-] the car's share of ``total``, ``(b, n)``
    pipe_energy : np.ndarray
        [J] each pipe's oil energy ``L |q|^2``, ``(b, k, n)``
    pipe_axle : np.ndarray
        [-] per pipe the axle whose wheels drive its oil most (0 front, 1 rear; -1: none), ``(b, k)``
    slots : np.ndarray
        [-] each root's index in :data:`MODE_NAMES` (-1: none; oscillating roots only), ``(b, n)``
    """

    lam: np.ndarray
    vec: np.ndarray
    oscillating: np.ndarray
    shapes: np.ndarray
    u: np.ndarray
    wheel_energy: np.ndarray
    budget: np.ndarray
    total: np.ndarray
    mechanical: np.ndarray
    pipe_energy: np.ndarray
    pipe_axle: np.ndarray
    slots: np.ndarray


def mode_set(model: CoupledModel, tol: float = 1e-8) -> ModeSet:
    """Every mode of every design of ``model`` (one batched eigen-decomposition), named.

    Raises
    ------
    hisopt.errors.ModelError
        The batch's designs short different valves (:meth:`CoupledModel.groups`: take
        its groups one at a time).
    """
    ss = model.state_space()
    a = np.asarray(ss.a)
    n = a.shape[-1]
    a = a.reshape(-1, n, n)
    b = a.shape[0]
    weights = np.broadcast_to(np.asarray(ss.kinetic_weights), np.shape(ss.a)[:-1]).reshape(b, n)
    states, flows = rigid_oil_flows(model, ss)
    flows = np.broadcast_to(flows, np.shape(ss.a)[:-2] + flows.shape[-2:]).reshape(b, states.size, 7)
    mass = np.broadcast_to(np.diagonal(model.mass, axis1=-2, axis2=-1), np.shape(ss.a)[:-2] + (7,)).reshape(b, 7)
    lam, vec = np.linalg.eig(a)
    scale = np.abs(lam).max(axis=1, keepdims=True)
    oscillating = lam.imag > tol * scale  # real (overdamped) roots and the conjugates left out
    total = np.einsum("bi,bim->bm", weights, np.abs(vec) ** 2)
    v = vec[:, 7:14, :]
    inertance = weights[:, states]  # (b, k)
    q = vec[:, states, :]
    if states.size:
        t_l = np.swapaxes(flows, 1, 2) * inertance[:, None, :]  # (b, 7, k)
        m_eff = mass[:, :, None] * np.eye(7) + t_l @ flows
        rigid = np.linalg.solve(m_eff, mass[:, :, None] * v + t_l @ q)  # the projection in the energy inner product
        projected = np.einsum("bim,bij,bjm->bm", rigid.conj(), m_eff, rigid).real
        eff = np.diagonal(m_eff, axis1=1, axis2=2)
    else:  # no oil that moves: the car's own motion and masses
        rigid, projected, eff = v, total, mass
    u = motion_coordinates(rigid, eff)
    relative = np.clip(total - projected, 0.0, None)
    budget = (np.abs(u) ** 2).sum(1) + relative
    wheel_energy = eff[:, 3:, None] * np.abs(rigid[:, 3:]) ** 2
    wheel_drive = np.abs(flows[:, :, 3:])  # (b, k, 4)
    axle = np.where(wheel_drive.max(2) > 0, np.argmax(wheel_drive, axis=2) // 2, -1)
    return ModeSet(
        lam=lam,
        vec=vec,
        oscillating=oscillating,
        shapes=motion_coordinates(v, mass),
        u=u,
        wheel_energy=wheel_energy,
        budget=budget,
        total=total,
        # NaN for a mode without kinetic energy (a real root in pressures and strokes alone,
        # e.g. an accumulator relaxing through its valve): no share to state, and no warning
        mechanical=np.divide(np.einsum("bi,bim->bm", mass, np.abs(v) ** 2), total, out=np.full(total.shape, np.nan), where=total > 0),
        pipe_energy=inertance[:, :, None] * np.abs(q) ** 2,
        pipe_axle=axle,
        slots=name_slots(u, budget, oscillating),
    )


def wheel_modes(model: CoupledModel, tol: float = 1e-8) -> tuple[np.ndarray, np.ndarray]:
    """[Hz], [-] The four wheel modes of every design of ``model``: natural frequency and damping ratio.

    Column ``w`` (FL, FR, RL, RR) is the mode named for that wheel (its alias
    ``wheel_hop_<wheel>``, :data:`WHEEL_MODE_SLOTS`): front axle hop, front axle tramp, rear
    axle hop, rear axle tramp, named with the oil's added mass (docs/model.md §8.2); its
    undamped natural frequency ``|lambda| / 2 pi`` and damping ratio ``-Re(lambda) / |lambda|``.
    Where no oscillating mode carries that name (fewer than seven oscillating modes: the
    wheel's motion overdamped, or locked by the hydraulics into a mode the names did not
    reach), the column is that wheel's mode with the largest share of that wheel's energy
    among the roots not named (an overdamped root has damping ratio 1), so a rule on the
    wheel modes sees it anyway. Roots of distributed pipes are refined on the transcendental
    model (:func:`hisopt.coupled.roots.refine_roots`).

    Vectorised over designs: one batched eigen-decomposition per pattern of shorted valves
    (:meth:`~hisopt.coupled.model.CoupledModel.groups`), the naming on arrays.

    Parameters
    ----------
    model : CoupledModel
        a batch of designs (:meth:`hisopt.problem.Problem.model`), or one design

    Returns
    -------
    frequency_hz : np.ndarray
        [Hz] ``(n_designs, 4)``
    damping_ratio : np.ndarray
        [-] ``(n_designs, 4)``
    """
    parts = []
    for rows, group in model.groups():
        modes = mode_set(group, tol)
        b, n = modes.lam.shape
        slot_of = np.asarray(WHEEL_MODE_SLOTS)
        named = modes.slots[:, None, :] == slot_of[None, :, None]  # (b, 4, n)
        scale = np.abs(modes.lam).max(axis=1, keepdims=True)
        spare = (modes.slots < 0) & (modes.lam.imag > -tol * scale)  # one root per pair, unnamed
        with np.errstate(invalid="ignore", divide="ignore"):
            share = modes.wheel_energy / modes.budget[:, None, :]
        fallback = np.argmax(np.where(spare[:, None, :], np.nan_to_num(share), -np.inf), axis=2)
        pick = np.where(named.any(2), np.argmax(named, axis=2), fallback)  # (b, 4)
        lam = np.take_along_axis(modes.lam, pick, axis=1)
        if group.pipe_model == "distributed" and group.his is not None:
            lam = refine_roots(group, lam if b > 1 else lam[0]).reshape(b, 4)
        parts.append((rows, lam))
    if len(parts) == 1:
        lam = parts[0][1]
    else:
        lam = np.empty((sum(len(r) for r, _ in parts), 4), dtype=complex)
        for rows, part in parts:
            lam[rows] = part
    magnitude = np.abs(lam)
    return magnitude / (2 * np.pi), -lam.real / magnitude
