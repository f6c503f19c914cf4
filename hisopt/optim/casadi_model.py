"""CasADi graph of the lumped no-pipe frequency model, in real arithmetic, with exact AD.

The gradient refinement (:mod:`hisopt.optim.refine`) needs the objectives and constraints of
DESIGN section 5 as CasADi expressions of the design variables. CasADi has no complex type,
so every complex quantity is carried as a (real, imaginary) pair.

Model (DESIGN sections 1-2; paper Eq. 20-24). For the default roll-plane circuit with no pipe
dynamics and no chamber compliance the HIS adds ``G^T Z(s) G`` with ``Z(s) = K_his + s C_his``,
``K_his = k_acc (a_A a_A^T + a_B a_B^T)``, ``k_acc = gamma p_abs / V0``, ``C_his = R_v
diag(A_b^2)``. Only ``Z`` (4 x 4) depends on the design; the car without HIS, ``D0(s) = s^2 M +
s C + K``, does not. With the design-independent ``H0 = D0^-1 B``, ``R = D0^-1 G^T``, ``P = G R``
(the car's stroke receptance) and ``Q = G H0`` (computed once per frequency set in numpy)::

    X = H0 z_g - R Z delta,   delta = G X   =>   (P^-1 + Z) delta = P^-1 Q z_g

so each node of the graph solves a 4 x 4 complex symmetric system (the stroke dynamic
stiffness ``S = P^-1 + Z``) instead of the 7 x 7 complex (14 x 14 real) one: a third of the
operations. An output ``y = sum_p s^p (c_p X + d_p z_g)`` then has ``h_y = a_y - r_y Z delta``
with ``a_y = sum_p s^p (c_p H0 + d_p)``, ``r_y = sum_p s^p c_p R``, and its one-sided PSD is
the track model of :meth:`hisopt.evaluate.Evaluator.spectra`.

Scope: the lumped circuit of DESIGN section 2 without pipes and without chamber compliance
(``pipe_model = "lumped"``, no ``[his.pipes]``, ``chamber_volume = 0``), design variables
among :data:`SUPPORTED_VARIABLES`. Other problems raise :class:`~hisopt.errors.ConfigError`
from :func:`check_supported`: refinement needs this exact rational form.

Layout (one section each below): design -> HIS matrices; numeric frequency data; the model
(per-node PSD function in SX, mapped over the nodes; quantities: integrals by quadrature,
maxima over the nodes, static roll gradient); compiled functions; the spectra as a CasADi
callback with a cached Jacobian for IPOPT.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from hisopt.constants import G_MPS2, P_ATM_PA
from hisopt.errors import ConfigError
from hisopt.hydraulics.roll_plane import CIRCUIT_CHAMBERS
from hisopt.metrics import COMFORT_OUTPUTS, METRICS
from hisopt.road.spectra import isotropic_coherence
from hisopt.standards import iso_2631_1_1997 as iso2631
from hisopt.standards.iso_8608_2016 import class_gd_n0, temporal_psd
from hisopt.vehicle import (
    damping_matrix,
    mass_matrix,
    road_damping_input,
    road_stiffness_input,
    stiffness_matrix,
    stroke_matrix,
)

if TYPE_CHECKING:
    from hisopt.problem import Problem
    from hisopt.response import Output

SUPPORTED_VARIABLES = ("p0", "dA", "lam", "Rv", "dA_rear", "lam_rear", "Rv_rear", "V0", "gamma")
"""Design variables the CasADi model can differentiate with respect to."""

_HEADER = 5
"""Per-node parameters before the matrices: ``omega, cos(omega tau), sin(omega tau), G_road, coherence``."""


def check_supported(problem: "Problem") -> None:
    """Raise :class:`ConfigError` unless the problem fits the CasADi model's scope (module doc)."""
    his = problem.spec.his
    if his.pipes is not None or his.pipe_model != "lumped":
        raise ConfigError(
            "gradient refinement supports lumped circuits without pipes; remove [his.pipes] "
            "and use pipe_model = \"lumped\" (or skip refinement)",
            key="his.pipes",
        )
    if his.chamber_volume > 0:
        raise ConfigError(
            f"gradient refinement supports circuits without chamber compliance; expected "
            f"his.chamber_volume = 0, got {his.chamber_volume}",
            key="his.chamber_volume",
        )
    unknown = [n for n in problem.variable_names if n not in SUPPORTED_VARIABLES]
    if unknown:
        raise ConfigError(
            f"gradient refinement cannot vary {unknown[0]!r}; expected variables among {', '.join(SUPPORTED_VARIABLES)}",
            key=f"variables.{unknown[0]}",
        )


# --- design -> HIS matrices ----------------------------------------------------------------
def his_parameters(problem: "Problem", x: Any) -> dict[str, Any]:
    """HIS parameters with the design variables taken from ``x`` (CasADi or numpy vector).

    Rear ``dA``, ``lam``, ``Rv`` follow the front ones unless given (as
    :func:`hisopt.hydraulics.roll_plane.roll_plane_system`).
    """
    his = problem.spec.his
    values: dict[str, Any] = {name: getattr(his, name) for name in SUPPORTED_VARIABLES}
    for i, name in enumerate(problem.variable_names):
        values[name] = x[i]
    for key in ("dA", "lam", "Rv"):
        if values[f"{key}_rear"] is None:
            values[f"{key}_rear"] = values[key]
    return values


def his_matrices(problem: "Problem", x: Any) -> tuple[Any, Any]:
    """``K_his`` (4 x 4) [N/m] and the diagonal of ``C_his`` (4,) [N s/m] in stroke coordinates.

    DESIGN section 2: ``K_his = sum_circuits k_acc a a^T`` with ``a = +A_t`` (top chamber),
    ``-A_b`` (bottom chamber); ``C_his = R_v diag(A_b^2)`` (valve on each bottom line, paper
    Eq. 10). Works for CasADi symbols and plain floats alike.
    """
    v = his_parameters(problem, x)
    a_b = [v["dA"] / (1 - v["lam"])] * 2 + [v["dA_rear"] / (1 - v["lam_rear"])] * 2
    a_t = [v["lam"] * a_b[0]] * 2 + [v["lam_rear"] * a_b[2]] * 2
    k_acc = v["gamma"] * (v["p0"] + P_ATM_PA) / v["V0"]
    k_his = 0
    for chambers in CIRCUIT_CHAMBERS.values():
        a = ca.vertcat(*[a_t[w] if kind == "top" else -a_b[w] for w, kind in chambers])
        k_his = k_his + k_acc * (a @ a.T)
    rv = [v["Rv"]] * 2 + [v["Rv_rear"]] * 2
    c_his = ca.vertcat(*[rv[w] * a_b[w] ** 2 for w in range(4)])
    return k_his, c_his


# --- numeric frequency data ----------------------------------------------------------------
@dataclass(frozen=True)
class FrequencySet:
    """Design-independent numbers of a set of frequency nodes (numpy).

    Attributes
    ----------
    f_hz : [Hz] nodes, shape ``(F,)``
    weight_hz : [Hz] quadrature weights, shape ``(F,)`` (0 for nodes used only by maxima)
    params : [mixed SI] per-node parameters of :meth:`CasadiModel.psd_function`,
        shape ``(n_par, F)``
    comfort_weight : [Hz] ``weight * k_axis^2 * |W_axis(f)|^2`` per comfort output, dict of ``(F,)``
    """

    f_hz: np.ndarray
    weight_hz: np.ndarray
    params: np.ndarray
    comfort_weight: dict[str, np.ndarray]

    @property
    def size(self) -> int:
        return int(self.f_hz.size)


def _flat(a: np.ndarray) -> np.ndarray:
    """``(F, r, c)`` -> ``(r * c, F)`` in CasADi's column-major order."""
    return np.transpose(a, (0, 2, 1)).reshape(a.shape[0], -1).T


def _ldlt_solve(a_re: Any, a_im: Any, b_re: Any, b_im: Any) -> tuple[Any, Any]:
    """Solve ``A X = B`` for complex symmetric ``A`` (n x n) by ``L D L^T`` without pivoting.

    Real and imaginary parts as separate CasADi matrices; returns ``(X_re, X_im)``.
    """
    n = a_re.shape[0]
    mul = lambda a, b: (a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0])  # noqa: E731
    sub = lambda a, b: (a[0] - b[0], a[1] - b[1])  # noqa: E731

    def div(a: tuple[Any, Any], b: tuple[Any, Any]) -> tuple[Any, Any]:
        m = b[0] ** 2 + b[1] ** 2
        return ((a[0] * b[0] + a[1] * b[1]) / m, (a[1] * b[0] - a[0] * b[1]) / m)

    el: dict[tuple[int, int], tuple[Any, Any]] = {}
    d: list[tuple[Any, Any]] = []
    for j in range(n):
        dj = (a_re[j, j], a_im[j, j])
        for k in range(j):
            dj = sub(dj, mul(mul(el[j, k], el[j, k]), d[k]))
        d.append(dj)
        for i in range(j + 1, n):
            v = (a_re[i, j], a_im[i, j])
            for k in range(j):
                v = sub(v, mul(mul(el[i, k], el[j, k]), d[k]))
            el[i, j] = div(v, dj)
    cols_re, cols_im = [], []
    for c in range(b_re.shape[1]):
        y: list[tuple[Any, Any]] = []
        for i in range(n):  # L y = b
            v = (b_re[i, c], b_im[i, c])
            for k in range(i):
                v = sub(v, mul(el[i, k], y[k]))
            y.append(v)
        y = [div(y[i], d[i]) for i in range(n)]  # D z = y
        xs: list[tuple[Any, Any]] = [(0, 0)] * n
        for i in reversed(range(n)):  # L^T x = z
            v = y[i]
            for k in range(i + 1, n):
                v = sub(v, mul(el[k, i], xs[k]))
            xs[i] = v
        cols_re.append(ca.vertcat(*[v[0] for v in xs]))
        cols_im.append(ca.vertcat(*[v[1] for v in xs]))
    return ca.horzcat(*cols_re), ca.horzcat(*cols_im)


# --- the model -----------------------------------------------------------------------------
class CasadiModel:
    """Objectives and constraints of a problem as CasADi expressions (module docstring).

    Parameters
    ----------
    problem : a problem within the scope of :func:`check_supported`
    compile : compile the per-node functions the refinement evaluates (:func:`compiled`)

    Attributes
    ----------
    outputs : the evaluator's outputs, in its order (``Evaluator.outputs``)
    names : objective and constraint names, each once
    """

    def __init__(self, problem: "Problem", compile: bool = True):
        from hisopt.evaluate import Evaluator

        check_supported(problem)
        self.compile = compile
        self.problem = problem
        ev = Evaluator(problem)
        self.outputs: dict[str, "Output"] = dict(ev.outputs)
        self.output_index = dict(ev.output_index)
        self.names: tuple[str, ...] = ev.names
        self.metrics = [METRICS[n] for n in self.names]
        self.n_var = len(problem.variable_names)
        spec = problem.spec
        v = spec.vehicle
        self.tau = v.wheelbase / spec.road.speed
        self.gd_n0 = class_gd_n0(spec.road.road_class)
        self.n_par = _HEADER + 64 + 16 * len(self.outputs)
        self._psd: "ca.Function | None" = None
        self._mapped: dict[int, "ca.Function"] = {}
        self._nodes: dict[str, "ca.Function"] = {}

    # -- numeric, per frequency set -----------------------------------------------------------
    def frequency_set(self, f_hz: np.ndarray, weight_hz: np.ndarray | None = None) -> FrequencySet:
        """Numbers of the frequency nodes ``f_hz`` (F,) with quadrature weights (F,) [Hz].

        Solves the car without HIS at each node (design-independent, numpy, batched).
        """
        f = np.asarray(f_hz, dtype=float).ravel()
        w = np.zeros_like(f) if weight_hz is None else np.asarray(weight_hz, dtype=float).ravel()
        spec = self.problem.spec
        veh = spec.vehicle
        omega = 2 * np.pi * f
        s = 1j * omega
        d0 = (s**2)[:, None, None] * mass_matrix(veh) + s[:, None, None] * damping_matrix(veh) + stiffness_matrix(veh)
        b = road_stiffness_input(veh) + s[:, None, None] * road_damping_input(veh)
        g = stroke_matrix(veh)
        sol = np.linalg.solve(d0, np.concatenate([b, np.broadcast_to(g.T, d0.shape[:1] + g.T.shape)], axis=2))
        h0, r = sol[..., :4], sol[..., 4:]
        p_inv = np.linalg.inv(g @ r)  # stroke dynamic stiffness of the car without HIS
        q_prime = p_inv @ (g @ h0)
        coherence = np.zeros_like(f)
        if spec.road.coherence == "isotropic":
            coherence = isotropic_coherence(f / spec.road.speed, veh.t_f + veh.t_r)
        rows = [
            omega[None],
            np.cos(omega * self.tau)[None],
            np.sin(omega * self.tau)[None],
            temporal_psd(f, self.gd_n0, spec.road.speed)[None],
            coherence[None],
            _flat(p_inv.real),
            _flat(p_inv.imag),
            _flat(q_prime.real),
            _flat(q_prime.imag),
        ]
        for out in self.outputs.values():
            a_y = np.zeros((f.size, 4), dtype=complex)
            r_y = np.zeros((f.size, 4), dtype=complex)
            for k in range(out.c.shape[0]):
                a_y += (s**k)[:, None] * (np.einsum("j,fjw->fw", out.c[k], h0) + out.d[k])
                r_y += (s**k)[:, None] * np.einsum("j,fjw->fw", out.c[k], r)
            rows += [a_y.real.T, a_y.imag.T, r_y.real.T, r_y.imag.T]
        comfort = spec.comfort
        gains: dict[str, np.ndarray] = {}
        for axis, name in COMFORT_OUTPUTS.items():
            if name not in self.outputs:
                continue
            weighting = self.outputs[name].weighting
            gain = (
                iso2631.band_gain_squared(f[None], weighting, spec.band.f_min_hz, spec.band.f_max_hz)[0]
                if comfort.method == "band"
                else iso2631.weighting_gain_squared(f, weighting)
            )
            gains[name] = w * getattr(comfort, f"k_{axis}") ** 2 * gain
        return FrequencySet(f, w, np.vstack(rows), gains)

    # -- per-frequency PSD function (SX) --------------------------------------------------------
    def psd_function(self) -> "ca.Function":
        """``psd(k_his 4x4, c_his 4, p n_par) -> (n_out,)`` one-sided output PSDs at one node.

        ``p`` is one column of :attr:`FrequencySet.params` (not differentiated). Solves
        ``S delta = Q'`` with the stroke dynamic stiffness ``S = P^-1 + Z`` by a complex
        ``L D L^T`` factorisation without pivoting: ``S`` is complex symmetric with a positive
        definite imaginary part (every stroke carries a damper), for which Gaussian
        elimination without pivoting is stable (Higham 1998). Then forms each output's
        track PSD (paper Eq. 24, DESIGN section 3).
        """
        if self._psd is not None:
            return self._psd
        kh = ca.SX.sym("k_his", 4, 4)
        ch = ca.SX.sym("c_his", 4)
        p = ca.SX.sym("p", self.n_par)
        omega, cos_t, sin_t, g_road, coh = (p[i] for i in range(_HEADER))
        s_re, s_im, q_re, q_im = (ca.reshape(p[_HEADER + 16 * i : _HEADER + 16 * (i + 1)], 4, 4) for i in range(4))
        s_re = s_re + kh
        s_im = s_im + omega * ca.diag(ch)  # Z = K_his + j omega C_his
        d_re, d_im = _ldlt_solve(s_re, s_im, q_re, q_im)
        zd_re = kh @ d_re - omega * ca.diag(ch) @ d_im  # Z delta
        zd_im = kh @ d_im + omega * ca.diag(ch) @ d_re
        psd = []
        base = _HEADER + 64
        for i in range(len(self.outputs)):
            ar, ai, rr, ri = (p[base + 16 * i + 4 * k : base + 16 * i + 4 * (k + 1)].T for k in range(4))
            h_re = ar - (rr @ zd_re - ri @ zd_im)
            h_im = ai - (rr @ zd_im + ri @ zd_re)
            # tracks: front wheel plus the rear wheel delayed by tau, e = exp(-j omega tau)
            l_re = h_re[0] + cos_t * h_re[2] + sin_t * h_im[2]
            l_im = h_im[0] + cos_t * h_im[2] - sin_t * h_re[2]
            r_re = h_re[1] + cos_t * h_re[3] + sin_t * h_im[3]
            r_im = h_im[1] + cos_t * h_im[3] - sin_t * h_re[3]
            power = l_re**2 + l_im**2 + r_re**2 + r_im**2 + 2 * coh * (l_re * r_re + l_im * r_im)
            psd.append(g_road * power)
        self._psd = ca.Function(
            "psd", [kh, ch, p], [ca.vertcat(*psd)], ["k_his", "c_his", "p"], ["psd"], {"is_diff_in": [True, True, False]}
        )
        return self._psd

    def node_function(self, jacobian: bool = False) -> "ca.Function":
        """``node(x, p) -> psd (n_out,)[, dpsd_dx (n_out, n_var)]`` at one node, design ``x``.

        The HIS matrices are formed inside, so the Jacobian (forward AD, ``n_var``
        directions) is with respect to the design variables [variable units] directly.
        """
        key = "node_jac" if jacobian else "node"
        if key not in self._nodes:
            x = ca.SX.sym("x", self.n_var)
            p = ca.SX.sym("p", self.n_par)
            kh, ch = his_matrices(self.problem, x)
            psd = self.psd_function()(kh, ch, p)
            outs = [psd, ca.jacobian(psd, x)] if jacobian else [psd]
            self._nodes[key] = ca.Function(key, [x, p], outs, {"is_diff_in": [True, False]})
        return self._nodes[key]

    def fast_node_function(self, jacobian: bool = False) -> "ca.Function":
        """:meth:`node_function` compiled to machine code when a C compiler is available.

        The same operations in the same order (no fast-math), a few times faster than
        CasADi's virtual machine; see :func:`compiled`.
        """
        key = "fast_jac" if jacobian else "fast"
        if key not in self._nodes:
            self._nodes[key] = compiled(self.node_function(jacobian)) if self.compile else self.node_function(jacobian)
        return self._nodes[key]

    def spectra(self, x: "ca.MX", params: "ca.MX | np.ndarray") -> "ca.MX":
        """[output unit^2/Hz] Output PSDs at every node, shape ``(n_out, F)``.

        Parameters
        ----------
        x : [variable units] design, CasADi column ``(n_var, 1)``
        params : per-node parameters ``(n_par, F)`` (:attr:`FrequencySet.params`)
        """
        n = params.shape[1]
        if n not in self._mapped:
            self._mapped[n] = self.psd_function().map(n, "serial")
        kh, ch = his_matrices(self.problem, x)
        return self._mapped[n](kh, ch, params)

    # -- quantities -----------------------------------------------------------------------------
    def roll_gradient(self, x: "ca.MX") -> "ca.MX":
        """[rad/g] Static roll angle under the moment ``m_s g h_0s`` (``K + G^T K_his G``)."""
        veh = self.problem.spec.vehicle
        kh, _ = his_matrices(self.problem, x)
        g = stroke_matrix(veh)
        k = ca.DM(stiffness_matrix(veh)) + ca.DM(g.T) @ kh @ ca.DM(g)
        load = np.zeros(7)
        load[1] = veh.m_s * G_MPS2 * veh.h_0s
        return ca.solve(k, ca.DM(load))[1]

    def integrals(self, x: "ca.MX", fs: FrequencySet, spectra: "ca.MX | None" = None) -> dict[str, "ca.MX"]:
        """Quadrature quantities (``sigma_aw``, ``rms_*``) and ``roll_gradient`` on ``fs``."""
        psd = self.spectra(x, fs.params) if spectra is None else spectra
        out: dict[str, ca.MX] = {}
        for m in self.metrics:
            if m.kind == "comfort":
                total = 0
                for name in COMFORT_OUTPUTS.values():
                    total = total + psd[self.output_index[name], :] @ ca.DM(fs.comfort_weight[name])
                out[m.name] = ca.sqrt(total)
            elif m.kind == "rms":
                out[m.name] = ca.sqrt(psd[self.output_index[m.output], :] @ ca.DM(fs.weight_hz))
            elif m.kind == "static":
                out[m.name] = self.roll_gradient(x)
        return out

    def quantities(self, x: "ca.MX", fs: FrequencySet) -> dict[str, "ca.MX"]:
        """Every objective and constraint on ``fs``: integrals by quadrature, maxima over all nodes."""
        psd = self.spectra(x, fs.params)
        out = self.integrals(x, fs, psd)
        for m in self.metrics:
            if m.kind == "max":
                out[m.name] = ca.mmax(psd[self.output_index[m.output], :])
        return {name: out[name] for name in self.names}

    def function(self, fs: FrequencySet) -> "ca.Function":
        """``f(x) -> (quantities (n_q,), jacobian (n_q, n_var))`` on the fixed nodes ``fs``.

        Quantities in :attr:`names` order, physical units; the Jacobian is exact (AD).
        """
        x = ca.MX.sym("x", self.n_var)
        q = ca.vertcat(*self.quantities(x, fs).values())
        return ca.Function("quantities", [x], [q, ca.jacobian(q, x)], ["x"], ["q", "dq_dx"])


# --- compiled functions ----------------------------------------------------------------------
COMPILE_FLAGS = ("-O1", "-shared", "-fPIC")
"""C compiler flags of :func:`compiled` (no fast-math: the numbers stay those of CasADi)."""


def cache_directory() -> Path:
    """Where compiled functions are kept: ``$HISOPT_CACHE_DIR``, else ``$XDG_CACHE_HOME/hisopt``
    or ``~/.cache/hisopt``."""
    if os.environ.get("HISOPT_CACHE_DIR"):
        return Path(os.environ["HISOPT_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "hisopt"


def compiled(fn: "ca.Function") -> "ca.Function":
    """``fn`` as C code compiled to a shared library (cached by content), or ``fn`` itself.

    The C source comes from CasADi's code generator; the library is named by the SHA-256 of
    source and flags, so it is compiled once per machine and shared by processes (written to
    a temporary file, then renamed). Falls back to ``fn`` (CasADi's virtual machine: same
    numbers, slower) when no C compiler is found (``$CC``, ``cc``, ``gcc``), when compiling
    fails, or when ``HISOPT_COMPILE=0``.
    """
    if os.environ.get("HISOPT_COMPILE", "1") == "0":
        return fn
    compiler = next((c for c in (os.environ.get("CC"), "cc", "gcc") if c and shutil.which(c)), None)
    if compiler is None:
        return fn
    generator = ca.CodeGenerator(f"{fn.name()}.c", {"with_header": False})
    generator.add(fn)
    source = generator.dump()
    digest = hashlib.sha256((source + " ".join(COMPILE_FLAGS)).encode()).hexdigest()[:24]
    directory = cache_directory()
    library = directory / f"{fn.name()}_{digest}.so"
    if not library.is_file():
        try:
            directory.mkdir(parents=True, exist_ok=True)
            with tempfile.TemporaryDirectory(dir=directory) as tmp:
                c_file, so_file = Path(tmp) / "f.c", Path(tmp) / "f.so"
                c_file.write_text(source, encoding="utf-8")
                done = subprocess.run([compiler, *COMPILE_FLAGS, "-o", str(so_file), str(c_file), "-lm"], capture_output=True)
                if done.returncode != 0:
                    return fn
                os.replace(so_file, library)
        except OSError:
            return fn
    return ca.external(fn.name(), str(library))


# --- spectra as a callback with a cached AD Jacobian ---------------------------------------------
class SpectraCallback(ca.Callback):
    """``u -> PSDs (n_out, F)`` on fixed nodes, for scaled designs ``x = lower + span * u``.

    The same numbers as :meth:`CasadiModel.spectra`, evaluated node by node with
    :meth:`CasadiModel.node_function`, whose Jacobian (forward AD inside each node) is
    supplied to CasADi as this function's Jacobian. An NLP's objective, constraints and
    their derivatives then cost one sweep over the nodes per iterate instead of one per
    derivative function (IPOPT evaluates ``f``, ``g``, ``grad_f``, ``jac_g`` separately).

    Parameters
    ----------
    model : the CasADi model
    fs : the frequency nodes
    lower, span : [variable units] scaling of the design, shape ``(n_var,)``
    """

    def __init__(self, model: CasadiModel, fs: FrequencySet, lower: np.ndarray, span: np.ndarray):
        ca.Callback.__init__(self)
        self.model = model
        self.lower, self.span = np.asarray(lower, dtype=float), np.asarray(span, dtype=float)
        self.n_out, self.n_nodes = len(model.outputs), fs.size
        self.params = ca.DM(fs.params)
        self.value = model.fast_node_function().map(fs.size, "serial")
        self.value_jac = model.fast_node_function(jacobian=True).map(fs.size, "serial")
        self._cache: dict[bytes, tuple[np.ndarray, np.ndarray | None]] = {}
        self._jacobian: Any = None
        self.construct("spectra", {"enable_fd": False})

    # -- CasADi callback interface --
    def get_n_in(self) -> int:
        return 1

    def get_n_out(self) -> int:
        return 1

    def get_sparsity_in(self, i: int) -> "ca.Sparsity":
        return ca.Sparsity.dense(self.model.n_var, 1)

    def get_sparsity_out(self, i: int) -> "ca.Sparsity":
        return ca.Sparsity.dense(self.n_out, self.n_nodes)

    def eval(self, arg: list[Any]) -> list[Any]:
        return [self.evaluate(np.array(arg[0]).ravel(), jacobian=False)[0]]

    def has_jacobian(self, *args: Any) -> bool:
        return True

    def get_jacobian(self, name: str, inames: list[str], onames: list[str], opts: dict[str, Any]) -> "ca.Function":
        self._jacobian = _SpectraJacobian(name, self, opts)
        return self._jacobian

    # -- numbers --
    def evaluate(self, u: np.ndarray, jacobian: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """PSDs ``(n_out, F)`` and, if asked, ``d vec(PSD) / du`` ``(n_out F, n_var)``."""
        key = np.asarray(u, dtype=float).tobytes()
        hit = self._cache.get(key)
        if hit is not None and (hit[1] is not None or not jacobian):
            return hit
        x = self.lower + self.span * u
        if jacobian:
            psd, jac = self.value_jac(x, self.params)
            jac = np.array(jac).reshape(self.n_out, self.n_nodes, -1, order="C")
            jac = np.transpose(jac, (1, 0, 2)).reshape(self.n_nodes * self.n_out, -1) * self.span
            result = (np.array(psd), jac)
        else:
            result = (np.array(self.value(x, self.params)), None)
        # IPOPT alternates between an iterate and its trial points: keep the last few.
        self._cache[key] = result
        while len(self._cache) > 8:
            self._cache.pop(next(iter(self._cache)))
        return result


class _SpectraJacobian(ca.Callback):
    """Jacobian of :class:`SpectraCallback`: ``(u, nominal output) -> (n_out F, n_var)``."""

    def __init__(self, name: str, parent: SpectraCallback, opts: dict[str, Any]):
        ca.Callback.__init__(self)
        self.parent = parent
        self.construct(name, opts)

    def get_n_in(self) -> int:
        return 2

    def get_n_out(self) -> int:
        return 1

    def get_sparsity_in(self, i: int) -> "ca.Sparsity":
        return self.parent.get_sparsity_in(0) if i == 0 else self.parent.get_sparsity_out(0)

    def get_sparsity_out(self, i: int) -> "ca.Sparsity":
        return ca.Sparsity.dense(self.parent.n_out * self.parent.n_nodes, self.parent.model.n_var)

    def eval(self, arg: list[Any]) -> list[Any]:
        return [self.parent.evaluate(np.array(arg[0]).ravel(), jacobian=True)[1]]
