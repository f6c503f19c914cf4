"""CasADi graph of a problem's frequency model, in real arithmetic, with exact AD.

The gradient refinement (:mod:`hisopt.optim.gradient.refine`) needs the objectives and constraints as
CasADi expressions of the design variables. They are compiled from the same physics core as
the numpy evaluator (docs/model.md §11): the problem's layout and laws with CasADi symbols as
parameter values (:meth:`hisopt.problem.Problem.hydraulic_system`) give the HIS stroke
dynamic stiffness ``D(j omega) = j omega N^T Z_port N`` of any network, lumped or
distributed, solved node by node; CasADi has no complex type, so every complex quantity is a
(real, imaginary) pair (:class:`hisopt.hydraulics.backend.Complex`).

The car without HIS, ``D0(s) = s^2 M + s C + K`` (:func:`hisopt.vehicle.dynamic_stiffness_matrix`),
does not depend on the design. With the design-independent ``H0 = D0^-1 B``, ``R = D0^-1 G^T``,
``P = G R`` (the car's stroke receptance) and ``Q = G H0`` (computed once per frequency set in
numpy)::

    X = H0 z_g - R D delta,   delta = G X   =>   (P^-1 + D) delta = P^-1 Q z_g

so each node solves a 4 x 4 complex symmetric system (the stroke dynamic stiffness
``S = P^-1 + D``) instead of the 7 x 7 one. An output ``y = sum_p s^p (c_p X + d_p z_g)`` then
has ``h_y = a_y - r_y D delta`` with ``a_y = sum_p s^p (c_p H0 + d_p)``,
``r_y = sum_p s^p c_p R``, and its one-sided PSD is the track kernel of
:mod:`hisopt.evaluation.psd`.

Layout (one section each below): numeric frequency data; the model (per-node PSD function in
SX, mapped over the nodes; quantities by the shared metric dispatch); compiled functions;
the spectra as a CasADi callback with a cached Jacobian for IPOPT.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import casadi as ca
import numpy as np

from hisopt.coupled.buildability import STATIC_RULES, static_rule_elements, symbolic_usage
from hisopt.coupled.model import CoupledModel, coupled_stiffness
from hisopt.coupled.operating_point import accumulator_quantities
from hisopt.errors import RunError
from hisopt.evaluation.psd import channel_power, comfort_gain_squared, reduce_metrics, roll_gradient
from hisopt.hydraulics import backend as bk
from hisopt.metrics import COMFORT_OUTPUTS, METRICS
from hisopt.road.spectra import isotropic_coherence
from hisopt.standards.iso_8608_2016 import class_gd_n0, temporal_psd
from hisopt.vehicle import (
    dynamic_stiffness_matrix,
    road_damping_input,
    road_stiffness_input,
    stiffness_matrix,
    stroke_matrix,
)

if TYPE_CHECKING:
    from hisopt.coupled.response import Output
    from hisopt.problem import Problem

SX_MAX_UNKNOWNS = 8
"""Largest circuit (unknowns) whose node function is expanded to scalar SX and compiled."""

_HEADER = 5
"""Per-node parameters before the matrices: ``omega, cos(omega tau), sin(omega tau), G_road, coherence``."""


# --- numeric frequency data ----------------------------------------------------------------
@dataclass(frozen=True)
class FrequencySet:
    """Design-independent numbers of a set of frequency nodes (numpy).

    Attributes
    ----------
    f_hz : np.ndarray
        [Hz] nodes, shape ``(F,)``
    weight_hz : np.ndarray
        [Hz] quadrature weights, shape ``(F,)`` (0 for nodes used only by maxima)
    params : np.ndarray
        [mixed SI] per-node parameters of :meth:`CasadiModel.psd_function`,
        shape ``(n_par, F)``
    comfort_weight : dict[str, np.ndarray]
        [Hz] ``weight * |W(f)|^2`` per comfort output (its weighting), dict of ``(F,)``
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
def check_valve_flows_given(problem: Problem) -> None:
    """Refuse damper valves whose RMS flows are solved with the response (no ``[his]
    valve_flow_rms``): they are a fixed point of the spectra (docs/model.md §3.3), which the
    CasADi model does not solve; with the flow given, a valve is a resistance like any other.

    Raises
    ------
    RunError
        Naming the valves and the way out (``--method slp``, or a given ``valve_flow_rms``).
    """
    solved = problem.network().solved_valves()
    if solved:
        raise RunError(
            f"--method ipopt: the CasADi model does not solve the RMS flows of the {len(solved)} damper valves "
            "([his] valve_flow_rms not given: a fixed point of the response, docs/model.md §3.3); "
            "expected --method slp (the default), which refines on the evaluator, or a given [his] valve_flow_rms"
        )


class CasadiModel:
    """Objectives and constraints of a problem as CasADi expressions (module docstring).

    Parameters
    ----------
    problem : Problem
        any problem the evaluator accepts (any layout, pipes lumped or distributed)
    compile : bool, optional
        compile the per-node functions the refinement evaluates (:func:`compiled`)

    Attributes
    ----------
    outputs : dict[str, Output]
        the evaluator's outputs, in its order (``Evaluator.outputs``)
    names : tuple[str, ...]
        objective and constraint names, each once
    """

    def __init__(self, problem: Problem, compile: bool = True):
        from hisopt.evaluation.evaluate import Evaluator

        self.compile = compile
        self.problem = problem
        ev = Evaluator(problem)
        swing = [m.name for m in ev.metrics if m.kind == "swing"]
        if swing:  # the condensed stroke model has no hydraulic unknowns to read the oil volumes from
            raise RunError(
                f"--method ipopt: the CasADi model has no accumulator oil volumes for {swing[0]}; "
                "expected --method slp (the default), which refines on the evaluator"
            )
        road_rules = [m.name for m in ev.metrics if m.kind == "build" and m.name not in STATIC_RULES]
        if road_rules:  # the road's swing of the chambers' pressures and the wheel modes are the evaluator's
            raise RunError(
                f"--method ipopt: the CasADi model computes only the static buildability rules ({', '.join(STATIC_RULES)}), not {road_rules[0]}; "
                "expected --method slp (the default), which refines on the evaluator"
            )
        check_valve_flows_given(problem)
        self.outputs: dict[str, Output] = dict(ev.outputs)
        self.output_index = dict(ev.output_index)
        self.names: tuple[str, ...] = ev.names
        self.metrics = [METRICS[n] for n in self.names]
        self.n_var = len(problem.variable_names)
        spec = problem.spec
        v = problem.vehicle
        self.tau = v.wheelbase / spec.road.speed
        self.gd_n0 = class_gd_n0(spec.road.road_class)
        self.n_par = _HEADER + 64 + 16 * len(self.outputs)
        self._psd: ca.Function | None = None
        self._mapped: dict[int, ca.Function] = {}
        self._nodes: dict[str, ca.Function] = {}

    # -- numeric, per frequency set -----------------------------------------------------------
    def frequency_set(self, f_hz: np.ndarray, weight_hz: np.ndarray | None = None) -> FrequencySet:
        """Numbers of the frequency nodes ``f_hz`` (F,) with quadrature weights (F,) [Hz].

        Solves the car without HIS at each node (design-independent, numpy, batched).
        """
        f = np.asarray(f_hz, dtype=float).ravel()
        w = np.zeros_like(f) if weight_hz is None else np.asarray(weight_hz, dtype=float).ravel()
        spec = self.problem.spec
        veh = self.problem.vehicle
        omega = 2 * np.pi * f
        s = 1j * omega
        d0 = dynamic_stiffness_matrix(veh, s)
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
        gains = {
            name: w * comfort_gain_squared(f, self.outputs[name].weighting, spec.comfort, spec.band.f_min_hz, spec.band.f_max_hz)  # type: ignore[arg-type]
            for name in COMFORT_OUTPUTS.values()
            if name in self.outputs
        }
        return FrequencySet(f, w, np.vstack(rows), gains)

    # -- per-frequency functions ----------------------------------------------------------------
    def stroke_stiffness(self, x: Any, omega: Any) -> bk.Complex:
        """[N/m] The HIS's ``D(j omega)`` (4 x 4) at design ``x`` (CasADi), from the physics core."""
        params = {name: x[i] for i, name in enumerate(self.problem.variable_names)}
        return bk.as_complex(self.problem.hydraulic_system(params).stroke_impedance(bk.jomega(omega)))

    @property
    def symbolic(self) -> Any:
        """``ca.SX`` for small networks (expanded, compiled to C), ``ca.MX`` for large ones.

        A network's linear solve is expanded into scalar operations in ``SX``, which is
        fastest for the paper's circuit (five unknowns per circuit) but grows with the cube of
        the unknowns; pipes give a circuit 13 to 17 unknowns, which ``MX`` keeps as one
        numeric solve per node (and CasADi differentiates through it).
        """
        net = self.problem.network()
        largest = max(int(np.sum(net.circuit == c)) for c in range(net.n_circuits))
        return ca.SX if largest <= SX_MAX_UNKNOWNS else ca.MX

    def psd_function(self) -> ca.Function:
        """``psd(d_re 4x4, d_im 4x4, p n_par) -> (n_out,)`` output PSDs at one node from the HIS's
        stroke dynamic stiffness ``D`` (SX).

        ``p`` is one column of :attr:`FrequencySet.params` (not differentiated). Solves
        ``S delta = Q'`` with the stroke dynamic stiffness ``S = P^-1 + D`` by a complex
        ``L D L^T`` factorisation without pivoting: ``S`` is complex symmetric (reciprocity)
        with a positive definite imaginary part (every stroke carries a damper), for which
        Gaussian elimination without pivoting is stable (Higham 1998). Then forms each
        output's PSD from its road channels (:func:`hisopt.evaluation.psd.channel_power`).
        """
        if self._psd is not None:
            return self._psd
        dr, di = ca.SX.sym("d_re", 4, 4), ca.SX.sym("d_im", 4, 4)
        p = ca.SX.sym("p", self.n_par)
        omega, cos_t, sin_t, g_road, coh = (p[i] for i in range(_HEADER))
        s_re, s_im, q_re, q_im = (ca.reshape(p[_HEADER + 16 * i : _HEADER + 16 * (i + 1)], 4, 4) for i in range(4))
        del omega
        delta = bk.Complex(*_ldlt_solve(s_re + dr, s_im + di, q_re, q_im))
        zd = bk.matmul(bk.Complex(dr, di), delta)  # D delta
        psd = []
        base = _HEADER + 64
        for i in range(len(self.outputs)):
            ar, ai, rr, ri = (p[base + 16 * i + 4 * k : base + 16 * i + 4 * (k + 1)].T for k in range(4))
            h_re = ar - (rr @ zd.re - ri @ zd.im)
            h_im = ai - (rr @ zd.im + ri @ zd.re)
            sym = ((h_re[0] + h_re[1], h_im[0] + h_im[1]), (h_re[2] + h_re[3], h_im[2] + h_im[3]))
            anti = ((h_re[0] - h_re[1], h_im[0] - h_im[1]), (h_re[2] - h_re[3], h_im[2] - h_im[3]))
            psd.append(g_road * channel_power(sym, anti, cos_t, sin_t, coh))
        self._psd = ca.Function("psd", [dr, di, p], [ca.vertcat(*psd)], ["d_re", "d_im", "p"], ["psd"], {"is_diff_in": [True, True, False]})
        return self._psd

    def node_function(self, jacobian: bool = False) -> ca.Function:
        """``node(x, p) -> psd (n_out,)[, dpsd_dx (n_out, n_var)]`` at one node, design ``x``.

        The Jacobian (forward AD, ``n_var`` directions) is with respect to the design
        variables [variable units].
        """
        key = "node_jac" if jacobian else "node"
        if key not in self._nodes:
            sym = self.symbolic
            x = sym.sym("x", self.n_var)
            p = sym.sym("p", self.n_par)
            d = self.stroke_stiffness(x, p[0])
            psd = self.psd_function()(d.re, d.im, p)
            outs = [psd, ca.jacobian(psd, x)] if jacobian else [psd]
            self._nodes[key] = ca.Function(key, [x, p], outs, {"is_diff_in": [True, False]})
        return self._nodes[key]

    def fast_node_function(self, jacobian: bool = False) -> ca.Function:
        """:meth:`node_function` compiled to machine code when a C compiler is available.

        The same operations in the same order (no fast-math), a few times faster than
        CasADi's virtual machine; see :func:`compiled`.
        """
        key = "fast_jac" if jacobian else "fast"
        if key not in self._nodes:
            fn = self.node_function(jacobian)
            self._nodes[key] = compiled(fn) if self.compile and self.symbolic is ca.SX else fn
        return self._nodes[key]

    def spectra(self, x: ca.MX, params: ca.MX | np.ndarray) -> ca.MX:
        """[output unit^2/Hz] Output PSDs at every node, shape ``(n_out, F)``.

        Parameters
        ----------
        x : ca.MX
            [variable units] design, CasADi column ``(n_var, 1)``
        params : ca.MX | np.ndarray
            per-node parameters ``(n_par, F)`` (:attr:`FrequencySet.params`)
        """
        n = params.shape[1]
        if n not in self._mapped:
            self._mapped[n] = self.node_function().map(n, "serial")
        return self._mapped[n](x, params)

    # -- quantities -----------------------------------------------------------------------------
    def roll_gradient(self, x: ca.MX) -> ca.MX:
        """[rad/g] Static roll angle under the moment ``m_s g h_0s`` (``K + G^T K_his G``; with the
        body's gravity moment as ``[handling] gravity_moment`` says, docs/model.md §6.4)."""
        veh = self.problem.vehicle
        params = {name: x[i] for i, name in enumerate(self.problem.variable_names)}
        k_his = self.problem.hydraulic_system(params).static_stiffness()
        return roll_gradient(coupled_stiffness(stiffness_matrix(veh), veh, k_his), veh, self.problem.spec.handling.gravity_moment)

    def accumulators(self, x: ca.MX) -> dict[str, ca.MX]:
        """[-] The accumulators' static quantities (:func:`hisopt.coupled.operating_point.accumulator_quantities`)."""
        params = {name: x[i] for i, name in enumerate(self.problem.variable_names)}
        return accumulator_quantities(self.problem.hydraulic_system(params))

    def build_rule(self, x: ca.MX, name: str) -> ca.MX:
        """[-] A static buildability rule's usage (:func:`hisopt.coupled.buildability.static_rule_elements`)."""
        params = {name: x[i] for i, name in enumerate(self.problem.variable_names)}
        model = CoupledModel(self.problem.vehicle, self.problem.hydraulic_system(params))
        elements, limit = static_rule_elements(model, self.problem.spec.build_limits)[name]
        return symbolic_usage(name, elements, limit)

    def _reduce(self, x: ca.MX, fs: FrequencySet, psd: ca.MX, with_maxima: bool, transient: Any = None) -> dict[str, ca.MX]:
        def integral(output: str, weighting: str | None) -> ca.MX:
            weights = fs.weight_hz if weighting is None else fs.comfort_weight[output]
            return psd[self.output_index[output], :] @ ca.DM(weights)

        def maximum(output: str) -> ca.MX:
            return ca.mmax(psd[self.output_index[output], :])

        metrics = [m for m in self.metrics if with_maxima or m.kind != "max"]
        return reduce_metrics(
            metrics,
            self.problem.spec.comfort,
            lambda name: self.outputs[name].weighting,  # type: ignore[arg-type,return-value]
            integral,
            maximum,
            lambda name: self.roll_gradient(x) if name == "roll_gradient" else self.accumulators(x)[name],
            transient,
            None,
            lambda name: self.build_rule(x, name),
        )

    def integrals(self, x: ca.MX, fs: FrequencySet, spectra: ca.MX | None = None, transient: Any = None) -> dict[str, ca.MX]:
        """Quadrature quantities (``sigma_aw``, ``rms_*``), ``roll_gradient`` and, given
        ``transient`` (name -> expression, :class:`~hisopt.optim.gradient.transient_callback.TransientCallback`),
        the transient roll quantities on ``fs``."""
        psd = self.spectra(x, fs.params) if spectra is None else spectra
        return self._reduce(x, fs, psd, with_maxima=False, transient=transient)

    def quantities(self, x: ca.MX, fs: FrequencySet) -> dict[str, ca.MX]:
        """Every objective and constraint on ``fs``: integrals by quadrature, maxima over all nodes."""
        out = self._reduce(x, fs, self.spectra(x, fs.params), with_maxima=True)
        return {name: out[name] for name in self.names}

    def function(self, fs: FrequencySet) -> ca.Function:
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


def compiled(fn: ca.Function) -> ca.Function:
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
    model : CasadiModel
        the CasADi model
    fs : FrequencySet
        the frequency nodes
    lower, span : np.ndarray
        [variable units] scaling of the design, shape ``(n_var,)``
    """

    def __init__(self, model: CasadiModel, fs: FrequencySet, lower: np.ndarray, span: np.ndarray):
        ca.Callback.__init__(self)
        self.model = model
        self.lower, self.span = np.asarray(lower, dtype=float), np.asarray(span, dtype=float)
        # not n_out / n_nodes: those are methods of every CasADi Function
        self.outputs_count, self.nodes_count = len(model.outputs), fs.size
        # Numeric calls go through CasADi's zero-copy buffers: converting a DM result to numpy
        # costs more than evaluating the compiled nodes.
        self.params = np.asfortranarray(fs.params)
        self._x = np.zeros(model.n_var)
        self._psd = np.zeros(self.outputs_count * self.nodes_count)
        self._jac = np.zeros(self.outputs_count * self.nodes_count * model.n_var)
        args = [self._x, self.params]  # the design is shared by the nodes (not repeated per node)
        self.value = _buffered(model.fast_node_function().map("value", "serial", fs.size, [0], []), args, [self._psd])
        self.value_jac = _buffered(model.fast_node_function(jacobian=True).map("value_jac", "serial", fs.size, [0], []), args, [self._psd, self._jac])
        self._cache: dict[bytes, tuple[np.ndarray, np.ndarray | None]] = {}
        self._jacobian: Any = None
        self.construct("spectra", {"enable_fd": False})

    # -- CasADi callback interface --
    def get_n_in(self) -> int:
        return 1

    def get_n_out(self) -> int:
        return 1

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(self.model.n_var, 1)

    def get_sparsity_out(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(self.outputs_count, self.nodes_count)

    def eval(self, arg: Sequence[Any]) -> list[Any]:
        return [self.evaluate(np.array(arg[0]).ravel(), jacobian=False)[0]]

    def has_jacobian(self, *args: Any) -> bool:
        return True

    def get_jacobian(self, name: str, inames: Sequence[str], onames: Sequence[str], opts: Mapping[str, Any]) -> ca.Function:
        self._jacobian = JacobianCallback(name, self, opts)
        return self._jacobian

    # -- numbers --
    def evaluate(self, u: np.ndarray, jacobian: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """PSDs ``(n_out, F)`` and, if asked, ``d vec(PSD) / du`` ``(n_out F, n_var)``."""
        key = np.asarray(u, dtype=float).tobytes()
        hit = self._cache.get(key)
        if hit is not None and (hit[1] is not None or not jacobian):
            return hit
        self._x[:] = self.lower + self.span * u
        # column-major buffers: psd (n_out, F); the map's Jacobian (n_out, F n_var), column f n_var + v
        if jacobian:
            self.value_jac()
            jac = self._jac.reshape(self.nodes_count, self.model.n_var, self.outputs_count)
            jac = np.transpose(jac, (0, 2, 1)).reshape(self.nodes_count * self.outputs_count, -1) * self.span
            result = (self._psd.reshape(self.nodes_count, self.outputs_count).T.copy(), jac)
        else:
            self.value()
            result = (self._psd.reshape(self.nodes_count, self.outputs_count).T.copy(), None)
        # IPOPT alternates between an iterate and its trial points: keep the last few.
        self._cache[key] = result
        while len(self._cache) > 8:
            self._cache.pop(next(iter(self._cache)))
        return result


def _buffered(fn: ca.Function, args: list[np.ndarray], results: list[np.ndarray]) -> Callable[[], None]:
    """A call of ``fn`` reading ``args`` and writing ``results`` in place (float arrays whose
    memory is each argument's column-major data; they must outlive the call)."""
    buffer, call = fn.buffer()
    # CasADi's stubs name the buffer's size, which its Python wrapper takes from the memoryview
    set_arg: Any = buffer.set_arg
    set_res: Any = buffer.set_res
    for i, a in enumerate(args):
        assert a.flags.f_contiguous, "CasADi reads a matrix column by column"
        set_arg(i, memoryview(cast(Any, a.reshape(-1, order="F"))))
    for i, r in enumerate(results):
        set_res(i, memoryview(cast(Any, r)))

    def run() -> None:
        call()

    run.buffer = buffer  # type: ignore[attr-defined]  # keeps the buffer alive with the call
    return run


class JacobianCallback(ca.Callback):
    """The Jacobian of a one-input, one-output callback whose ``evaluate(u, jacobian=True)``
    returns ``(value, d vec(value) / du)``: ``(u, nominal output) -> (numel out, numel u)``
    (:class:`SpectraCallback`, :class:`hisopt.optim.gradient.transient_callback.TransientCallback`)."""

    def __init__(self, name: str, parent: Any, opts: Mapping[str, Any]):
        ca.Callback.__init__(self)
        self.parent = parent
        self.construct(name, dict(opts))

    def get_n_in(self) -> int:
        return 2

    def get_n_out(self) -> int:
        return 1

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        return self.parent.get_sparsity_in(0) if i == 0 else self.parent.get_sparsity_out(0)

    def get_sparsity_out(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(self.parent.get_sparsity_out(0).numel(), self.parent.get_sparsity_in(0).numel())

    def eval(self, arg: Sequence[Any]) -> list[Any]:
        return [self.parent.evaluate(np.array(arg[0]).ravel(), jacobian=True)[1]]
