"""The road channels' responses of a batch of models: from poles and residues (compiled
kernel), by direct solve, or mixed (docs/model.md §10).

Whatever the path, the road enters through two channels (:mod:`hisopt.evaluation.symmetry`): both
tracks together and apart, each a front input plus the rear input delayed by the wheelbase.
A :class:`Channels` object gives their FRFs at any frequency and the outputs' PSDs on one or
several roads (:class:`RoadCase`); the evaluator (:mod:`hisopt.evaluation.evaluate`) integrates and
searches those.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from hisopt.evaluation.pole_residue import PoleResidue, balance
from hisopt.evaluation.psd import channel_power
from hisopt.evaluation.symmetry import channel_inputs, split, state_mirror

if TYPE_CHECKING:
    from hisopt.coupled.model import CoupledModel, StateSpace
    from hisopt.coupled.response import Output

Pair = tuple[np.ndarray, np.ndarray]


@dataclass(frozen=True)
class RoadCase:
    """One road as the channels' PSDs need it: the rear-wheel delay ``tau`` [s], the tracks'
    coherence at the frequencies (None: independent) and the PSD's power law ``(G_1, w)``."""

    tau: float
    coherence: np.ndarray | None
    road: tuple[float, float]


class Channels(Protocol):
    """A batch of models' road channels (:mod:`hisopt.evaluation.symmetry`), as FRFs or as PSDs."""

    def __call__(self, omega: np.ndarray) -> dict[str, Pair]:
        """The channels' output FRFs at ``s = j omega`` [rad/s] (n, F): ``{"sym": (re, im),
        "anti": (re, im)}``, each (n, F, 2 axles, n_out)."""
        ...

    def power(
        self, f_hz: np.ndarray, tau: float, coherence: np.ndarray | None, output_of: np.ndarray | None = None, road: tuple[float, float] | None = None
    ) -> np.ndarray:
        """Output PSDs per unit road PSD at ``f_hz`` (n, F), ``(n_out, n, F)``, times the road
        PSD ``G_1 f^-w`` if ``road = (G_1, w)`` is given (``output_of``: per column, the one
        output needed there, or -1 for all; the others may be left 0)."""
        ...

    def powers(self, f_hz: np.ndarray, roads: list[RoadCase], output_of: np.ndarray | None = None) -> np.ndarray:
        """:meth:`power` on several roads at once, ``(R, n_out, n, F)``, the FRFs computed once."""
        ...


def frf_power(channels: dict[str, Pair], f_hz: np.ndarray, tau: float, coherence: np.ndarray | None) -> np.ndarray:
    """Output PSDs per unit road PSD ``(n, F, n_out)`` from the channels' FRFs (numpy;
    :func:`hisopt.evaluation.psd.channel_power`)."""
    phase = 2 * np.pi * f_hz * tau
    (s_re, s_im), (a_re, a_im) = channels["sym"], channels["anti"]
    return channel_power(
        ((s_re[..., 0, :], s_im[..., 0, :]), (s_re[..., 1, :], s_im[..., 1, :])),
        ((a_re[..., 0, :], a_im[..., 0, :]), (a_re[..., 1, :], a_im[..., 1, :])),
        np.cos(phase)[..., None],
        np.sin(phase)[..., None],
        None if coherence is None else coherence[..., None],
    )


CONDITION_LIMIT = 1e8
"""[-] Eigenvalue condition number (balanced) beyond which poles and residues are not trusted:
such a design's responses come from the direct solve, its poles from :func:`repair_poles`."""


def eigen_conditioning(a: np.ndarray) -> np.ndarray:
    """[-] Largest eigenvalue condition number ``||v_k|| ||w_k||`` of each balanced state
    matrix ``(n, k, k)``, ``(n,)``: as :attr:`hisopt.evaluation.pole_residue.PoleResidue.conditioning`
    computes it, for a path that needs the poles but not the residues (distributed pipes)."""
    d = balance(a)
    vec = np.linalg.eig(a * (d[:, None, :] / d[:, :, None]))[1]
    return np.max(np.linalg.norm(np.linalg.inv(vec), axis=-1), axis=-1)


def repair_poles(model: CoupledModel, lam: np.ndarray, f_hi_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """[rad/s] Poles below ``4 f_hi`` refined by Newton's method on ``det K_dyn(s)`` (the 7x7
    dynamic stiffness, well conditioned where the state matrix is not, e.g. with pipes of
    micrometres), and whether every one converged (the others are flagged, never guessed).

    Parameters
    ----------
    model : CoupledModel
        the designs' models; ``lam`` their state matrices' eigenvalues ``(n, k)``
    """
    from hisopt.coupled.modal import refine_roots

    near = np.isfinite(lam) & (np.abs(lam) < 2 * np.pi * 4 * f_hi_hz)
    start = np.where(near, lam, 2j * np.pi * f_hi_hz)  # far poles stay as they are
    with np.errstate(all="ignore"):
        try:
            refined = refine_roots(model, start)
            check = refine_roots(model, refined, iterations=1)
        except np.linalg.LinAlgError:
            return lam, np.zeros(len(lam), dtype=bool)
    converged = np.isfinite(check) & (np.abs(check - refined) <= 1e-8 * np.abs(refined))
    ok = np.all(converged | ~near, axis=1)
    return np.where(near, refined, lam), ok


class ModalChannels:
    """The road channels' FRFs of a lumped model from poles and residues.

    A mirror-symmetric batch (:func:`hisopt.evaluation.symmetry.split`) gets one half-size pole-residue
    form per channel; any other one form with both channels' inputs over all poles.
    """

    def __init__(self, model: CoupledModel, ss: StateSpace, outputs: dict[str, Output], feed: dict[str, list[np.ndarray]] | None = None):
        outs = list(outputs.values())
        feed = channel_feedthrough(outs) if feed is None else feed
        halves = split(ss, state_mirror(model, ss))
        # outputs over [X, V_acc]: the accumulators' oil volumes are rows of the states too
        volumes = model.hydraulic_states(ss)[..., : max(o.c.shape[1] for o in outs) - 7, :] if any(o.c.shape[1] > 7 for o in outs) else None
        if halves is not None:
            self.forms = {name: PoleResidue(h.a, h.inputs, _with_volumes(h.positions, volumes, h.basis), outs, feed[name]) for name, h in halves.items()}
            self.lam = np.concatenate([f.lam for f in self.forms.values()], axis=1)
            self.conditioning = np.maximum(self.forms["sym"].conditioning, self.forms["anti"].conditioning)
        else:
            chan = channel_inputs(ss.b0 + ss.a @ ss.b1)
            inputs = np.concatenate([chan["sym"], chan["anti"]], axis=-1)
            both = [np.concatenate([s_, a_], axis=-1) for s_, a_ in zip(feed["sym"], feed["anti"], strict=True)]
            form = PoleResidue(ss.a, inputs, _with_volumes(np.eye(ss.a.shape[-1])[:7], volumes, None), outs, both)
            self.forms = {"both": form}
            self.lam = form.lam
            self.conditioning = form.conditioning
        self.n_out = len(outs)
        self._arguments = self._kernel_arguments()

    def _kernel_arguments(self) -> tuple[tuple[np.ndarray, ...], ...]:
        if "both" in self.forms:  # one form, the channels' inputs side by side
            return (self.forms["both"].kernel_terms([0, 1]), self.forms["both"].kernel_terms([2, 3]))
        return (self.forms["sym"].kernel_terms([0, 1]), self.forms["anti"].kernel_terms([0, 1]))

    def power(
        self, f_hz: np.ndarray, tau: float, coherence: np.ndarray | None, output_of: np.ndarray | None = None, road: tuple[float, float] | None = None
    ) -> np.ndarray:
        return self.powers(f_hz, [RoadCase(tau, coherence, road or (1.0, 0.0))], output_of)[0]

    def powers(self, f_hz: np.ndarray, roads: list[RoadCase], output_of: np.ndarray | None = None) -> np.ndarray:
        from hisopt.evaluation.kernels import channel_psd

        f_hz = np.ascontiguousarray(f_hz, dtype=float)
        out = np.empty((len(roads), self.n_out) + f_hz.shape)
        coherent = [r.coherence for r in roads if r.coherence is not None]
        if coherent and len(coherent) < len(roads):  # some roads' tracks are independent: coherence 0
            coherent = [np.zeros(f_hz.shape) if r.coherence is None else r.coherence for r in roads]
        g = np.ascontiguousarray(coherent, dtype=float) if coherent else np.empty((0, 0, 0))
        which = np.full(f_hz.shape[1], -1, dtype=np.int64) if output_of is None else np.asarray(output_of, dtype=np.int64)
        tau = np.array([r.tau for r in roads], dtype=float)
        law = np.array([r.road for r in roads], dtype=float).reshape(len(roads), 2)
        channel_psd(f_hz, tau, g, *self._arguments, which, law, out)
        return out

    def __call__(self, omega: np.ndarray) -> dict[str, Pair]:
        if "both" in self.forms:
            re, im = self.forms["both"](omega)
            return {"sym": (re[..., :2, :], im[..., :2, :]), "anti": (re[..., 2:, :], im[..., 2:, :])}
        return {name: form(omega) for name, form in self.forms.items()}


def _with_volumes(positions: np.ndarray, volumes: np.ndarray | None, basis: np.ndarray | None) -> np.ndarray:
    """The position map ``(7, m)``, with the accumulators' oil volumes ``(n, E, k)`` (over the
    full states; ``basis`` ``(k, m)``: a half's states) as rows after it, ``(n, 7 + E, m)``."""
    if volumes is None:
        return positions
    rows = volumes if basis is None else volumes @ basis
    return np.concatenate([np.broadcast_to(positions, (len(rows),) + positions.shape), rows], axis=-2)


class DirectOutputs:
    """The road channels' FRFs by direct solve of the dynamic stiffness (any pipe model; the
    reference path)."""

    def __init__(self, model: CoupledModel, outputs: dict[str, Output]):
        self.model = model
        self.outputs = outputs
        self.names = tuple(outputs)

    def __call__(self, omega: np.ndarray, output: int | None = None) -> dict[str, Pair]:
        """Channel FRFs at ``s = j omega`` [rad/s] (n, F), as :data:`Channels` gives them
        (``output``: only that one, ``n_out = 1``)."""
        s = 1j * np.asarray(omega)
        h_x = self.model.frequency_response(s)
        outputs = list(self.outputs.values())
        chosen = outputs if output is None else [outputs[output]]
        if any(o.c.shape[1] > 7 for o in chosen):  # outputs over [X, V_acc, Q_valve]
            h_x = np.concatenate([h_x, self.model.hydraulic_response(s, h_x)], axis=-2)
        wheels = np.stack([o.frf(h_x, s) for o in chosen], axis=-1)  # (n, F, 4, n_out)
        fl, fr, rl, rr = (wheels[..., k, :] for k in range(4))
        sym, anti = np.stack([fl + fr, rl + rr], axis=-2), np.stack([fl - fr, rl - rr], axis=-2)
        return {"sym": (sym.real, sym.imag), "anti": (anti.real, anti.imag)}

    def power(
        self, f_hz: np.ndarray, tau: float, coherence: np.ndarray | None, output_of: np.ndarray | None = None, road: tuple[float, float] | None = None
    ) -> np.ndarray:
        power = np.moveaxis(frf_power(self(2 * np.pi * f_hz), f_hz, tau, coherence), -1, 0)
        return power if road is None else road[0] * f_hz ** -road[1] * power

    def powers(self, f_hz: np.ndarray, roads: list[RoadCase], output_of: np.ndarray | None = None) -> np.ndarray:
        frf = self(2 * np.pi * f_hz)  # once for all the roads
        return np.stack([r.road[0] * f_hz ** -r.road[1] * np.moveaxis(frf_power(frf, f_hz, r.tau, r.coherence), -1, 0) for r in roads])


def road_channels(model: CoupledModel, outputs: dict[str, Output], feed: dict[str, list[np.ndarray]] | None = None) -> tuple[np.ndarray, Channels, np.ndarray]:
    """The road channels of ``outputs`` of a batch of models sharing one state space (one of
    :meth:`hisopt.coupled.model.CoupledModel.groups`), as the evaluator takes them: poles and
    residues (:class:`ModalChannels`), the direct solve (:class:`DirectOutputs`) for the designs
    whose form is not trusted (eigenvector conditioning above :data:`CONDITION_LIMIT`) and for
    distributed pipes.

    Returns
    -------
    lam, channels, flagged : tuple[np.ndarray, Channels, np.ndarray]
        [rad/s] the state matrices' eigenvalues ``(n, k)`` (of the lumped twin for distributed
        pipes), the channels, and per design whether its poles are not trusted (the evaluator
        repairs those, :func:`repair_poles`)
    """
    ss = model.state_space()
    if model.pipe_model == "distributed":  # the lumped twin's poles place the nodes
        return np.linalg.eigvals(ss.a), DirectOutputs(model, outputs), eigen_conditioning(ss.a) > CONDITION_LIMIT
    modal = ModalChannels(model, ss, outputs, feed)
    flagged = modal.conditioning > CONDITION_LIMIT  # eigenvectors too ill-conditioned for accurate residues
    channels: Channels = MixedChannels(modal, DirectOutputs(model.subset(flagged), outputs), flagged) if np.any(flagged) else modal
    return modal.lam, channels, flagged


class MixedChannels:
    """Channels from ``fast`` except for the designs flagged in ``use_slow``, from ``slow``."""

    def __init__(self, fast: Channels, slow: DirectOutputs, use_slow: np.ndarray):
        self.fast, self.slow, self.use_slow = fast, slow, use_slow

    def __call__(self, omega: np.ndarray) -> dict[str, Pair]:
        out = self.fast(omega)
        exact = self.slow(omega[self.use_slow])
        for name, (re, im) in out.items():
            re[self.use_slow], im[self.use_slow] = exact[name]
        return out

    def power(
        self, f_hz: np.ndarray, tau: float, coherence: np.ndarray | None, output_of: np.ndarray | None = None, road: tuple[float, float] | None = None
    ) -> np.ndarray:
        out = self.fast.power(f_hz, tau, coherence, output_of, road)
        g = None if coherence is None else coherence[self.use_slow]
        out[:, self.use_slow] = self.slow.power(f_hz[self.use_slow], tau, g, None, road)
        return out

    def powers(self, f_hz: np.ndarray, roads: list[RoadCase], output_of: np.ndarray | None = None) -> np.ndarray:
        out = self.fast.powers(f_hz, roads, output_of)
        slow = [RoadCase(r.tau, None if r.coherence is None else r.coherence[self.use_slow], r.road) for r in roads]
        out[:, :, self.use_slow] = self.slow.powers(f_hz[self.use_slow], slow)
        return out


def channel_feedthrough(outputs: list[Output]) -> dict[str, list[np.ndarray]]:
    """Each output's road feedthrough ``d`` on the two channels' inputs (front, rear axle)."""
    return {name: [channel_inputs(o.d[:, None, :])[name][:, 0, :] for o in outputs] for name in ("sym", "anti")}
