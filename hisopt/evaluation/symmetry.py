"""Left-right symmetry: the symmetric and antisymmetric halves of a mirror-symmetric model.

A car and HIS that are mirror images of themselves left to right (the default car with the
roll-plane circuit, say) have dynamics that split exactly into a symmetric subsystem
(bounce, pitch, axle hop) driven by the two tracks moving together and an antisymmetric one
(roll, axle tramp) driven by them moving against each other (docs/model.md §10.8). Two
half-size eigenproblems and FRFs then replace one full-size one.

Symmetry is detected from the data, never assumed: the mirror image of every state comes from
the structure (mechanical DOFs, and the network's :func:`~hisopt.hydraulics.network.mirror_unknowns`),
and the state-space matrices must be unchanged by it to within rounding for every design.

Whether or not the model is split, the road enters through the same two *channels*: with
tracks of equal PSD ``G`` and coherence ``g``, ``S_y = G/2 [(1+g) |H_s|^2 + (1-g) |H_a|^2]``
where ``H_s = h_L + h_R`` is the response to both tracks moving together and
``H_a = h_L - h_R`` to them moving apart (each a front input plus the rear input delayed by
``tau``); :func:`channel_inputs` builds their input maps.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from hisopt.hydraulics.network import mirror_unknowns

if TYPE_CHECKING:
    from hisopt.coupled.model import CoupledModel, StateSpace

MECHANICAL_IMAGE = np.array([0, 1, 2, 4, 3, 6, 5])
"""Mirror image of each DOF ``[z_s, phi, theta, z_u1..z_u4]``: the wheels swap sides."""

MECHANICAL_SIGN = np.array([1.0, -1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
"""Roll changes sign in the mirror; heave, pitch and wheel displacements do not."""

TOLERANCE = 1e-11
"""[-] Largest relative change of the state matrix under the mirror still called symmetric."""


def channel_inputs(b: np.ndarray) -> dict[str, np.ndarray]:
    """The two road channels' input maps from the four wheel inputs ``b`` (``(..., n, 4)``,
    FL, FR, RL, RR): ``"sym"`` (both tracks together) and ``"anti"`` (left up, right down),
    each ``(..., n, 2)`` with columns front axle, rear axle."""
    fl, fr, rl, rr = (b[..., k] for k in range(4))
    return {"sym": np.stack([fl + fr, rl + rr], axis=-1), "anti": np.stack([fl - fr, rl - rr], axis=-1)}


def state_mirror(model: CoupledModel, ss: StateSpace) -> tuple[np.ndarray, np.ndarray] | None:
    """``(image, sign)`` of every state of ``ss`` under the left-right mirror, or None when the
    structure has no mirror image (the values are checked by :func:`split`)."""
    image = np.r_[MECHANICAL_IMAGE, 7 + MECHANICAL_IMAGE]
    sign = np.r_[MECHANICAL_SIGN, MECHANICAL_SIGN]
    if ss.realisation is None:
        return image, sign
    if model.his is None:
        return None
    unknown = mirror_unknowns(model.his.network)
    if unknown is None:
        return None
    kept = ss.realisation.kept
    position = {int(u): i for i, u in enumerate(kept)}
    hydraulic = []
    for u in kept[14:]:
        i = position.get(14 + int(unknown[int(u) - 14]))
        if i is None:
            return None
        hydraulic.append(i)
    return np.r_[image, hydraulic].astype(int), np.r_[sign, np.ones(len(hydraulic))]


@dataclass(frozen=True)
class Half:
    """One half of a split model: ``x = basis @ x_half`` for the states of its subspace.

    Attributes
    ----------
    a : np.ndarray
        ``(n, m, m)`` state matrix of the half
    inputs : np.ndarray
        ``(n, m, 2)`` the half's road channel (front axle, rear axle), ``B' = B0 + A B1``
    positions : np.ndarray
        ``(7, m)`` the DOFs ``X`` from the half's states
    basis : np.ndarray
        ``(k, m)`` the full states from the half's: ``x = basis @ x_half``
    """

    a: np.ndarray
    inputs: np.ndarray
    positions: np.ndarray
    basis: np.ndarray


def _bases(image: np.ndarray, sign: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal bases of the mirror's +1 and -1 eigenspaces, ``(n, n_s)`` and ``(n, n_a)``."""
    n = image.size
    sym: list[np.ndarray] = []
    anti: list[np.ndarray] = []
    r = 1.0 / np.sqrt(2.0)
    for i in range(n):
        j = int(image[i])
        if j == i:
            e = np.zeros(n)
            e[i] = 1.0
            (sym if sign[i] > 0 else anti).append(e)
        elif i < j:
            plus, minus = np.zeros(n), np.zeros(n)
            plus[i], plus[j] = r, r * sign[i]
            minus[i], minus[j] = r, -r * sign[i]
            sym.append(plus)
            anti.append(minus)
    return np.array(sym).T, np.array(anti).T


def split(ss: StateSpace, mirror: tuple[np.ndarray, np.ndarray] | None) -> dict[str, Half] | None:
    """The symmetric and antisymmetric halves of ``ss`` (keys ``"sym"``, ``"anti"``), or None
    unless every design's model equals its mirror image within :data:`TOLERANCE`.

    Parameters
    ----------
    ss : StateSpace
        a batch of state spaces, ``a`` of shape ``(n, m, m)``
    mirror : tuple[np.ndarray, np.ndarray] | None
        :func:`state_mirror` of the model
    """
    if mirror is None:
        return None
    from hisopt.evaluation.kernels import mirror_deviation

    image, sign = mirror
    a = ss.a
    if not mirror_deviation(np.ascontiguousarray(a), image, sign, 1.0) <= TOLERANCE:
        return None
    bp = ss.b0 + ss.a @ ss.b1  # B' = B0 + A B1, the input of x - B1 u
    channels = channel_inputs(bp)
    for name, b in channels.items():  # each channel must lie in its own subspace
        if not mirror_deviation(np.ascontiguousarray(b), image, sign, 1.0 if name == "sym" else -1.0) <= TOLERANCE:
            return None
    halves = {}
    for name, basis in zip(("sym", "anti"), _bases(image, sign), strict=True):
        ab = _times_basis(a, basis)  # A V, then V^T (A V): V has one or two entries per column
        halves[name] = Half(np.swapaxes(_times_basis(np.swapaxes(ab, -1, -2), basis), -1, -2), basis.T @ channels[name], basis[:7], basis)
    return halves


def _times_basis(a: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """``a @ basis`` for a basis with one or two nonzero entries per column (as :func:`_bases`
    builds): two gathers instead of a dense product."""
    first = np.argmax(basis != 0, axis=0)
    last = basis.shape[0] - 1 - np.argmax(basis[::-1] != 0, axis=0)
    w_first = basis[first, np.arange(basis.shape[1])]
    w_last = np.where(last != first, basis[last, np.arange(basis.shape[1])], 0.0)
    return a[..., first] * w_first + a[..., last] * w_last
