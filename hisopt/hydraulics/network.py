"""A layout's network structure, computed once, and its assembly for any backend.

:func:`compile_network` turns a :class:`~hisopt.hydraulics.layout.Layout` into a
:class:`Network`: the unknowns of modified nodal analysis (one pressure per node, one flow per
series branch, two for a distributed pipe), which are pressures and which flows, which carry
storage (the lumped model's dynamic states), where each port, accumulator and valve sits.
Nothing downstream recovers this structure from labels.

Assembly is one stamp table per element (docs/model.md §3.5). With ``s`` the Laplace
variable, the network equations are ``M(s) h = P q_port`` with

- ``M(s) = K0 + s K1`` for lumped elements: a node row reads ``s C p + (flows leaving) -
  (flows arriving) = injected flow``; a branch row ``s L q + R q - p_a + p_b = 0``;
- rows of the distributed pipe's transfer matrix (transcendental in ``s``) for distributed
  pipes: ``T11 p_a + T12 q_1 - p_b = 0``, ``T21 p_a + T22 q_1 - q_2 = 0``.

The lumped descriptor ``E dh/dt = A h + P q_port`` is ``E = K1`` (diagonal) and ``A = -K0``;
the port impedance is ``Z_port(s) = P^T M(s)^-1 P``. Values may be floats, numpy arrays with
batch shape ``B`` (one value per design) or CasADi expressions (:mod:`hisopt.hydraulics.backend`).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np

from hisopt.errors import ConfigError, ModelError
from hisopt.hydraulics import backend as bk
from hisopt.hydraulics import laws
from hisopt.hydraulics.layout import (
    Accumulator,
    ChamberCompliance,
    DamperValve,
    Element,
    Layout,
    Orifice,
    ParamRef,
    Pipe,
    Port,
    Valve,
)

PipeModel = Literal["lumped", "distributed"]

FLUID_PARAMETERS = ("rho", "mu", "beta")
"""Parameters every network reads besides its elements' own: oil density [kg/m^3],
viscosity [Pa s] and effective bulk modulus [Pa]."""


@dataclass(frozen=True)
class Network:
    """The compiled structure of a layout at one pipe fidelity (see the module docstring).

    Unknowns are ordered circuit by circuit: the circuit's node pressures (first-use order),
    then its branch flows (element order).

    Attributes
    ----------
    layout, fidelity
        what was compiled
    labels : tuple[str, ...]
        ``"<circuit>:p[<node>]"`` or ``"<circuit>:q[<a>-><b>]"`` per unknown
    is_flow : np.ndarray
        [-] per unknown, shape ``(n,)``
    circuit : np.ndarray
        [-] circuit index per unknown, ``(n,)``
    dynamic : np.ndarray
        [-] unknowns with storage in the lumped model (nodes with a compliance, pipe
        flows with inertance), ``(n,)``; the rest are algebraic
    elements : tuple[tuple[int, Element], ...]
        ``(circuit index, element)`` for every element, circuit by circuit
    element_rows : tuple[tuple[int, ...], ...]
        unknown rows of each element: ``(node,)`` for shunts, ``(a, b, q)`` for
        valves and lumped pipes, ``(a, b, q1, q2)`` for distributed pipes
    ports : tuple[Port, ...]
        every port, circuit by circuit; ``port_rows`` its node's row; ``port_circuit``
    """

    layout: Layout
    fidelity: PipeModel
    labels: tuple[str, ...]
    is_flow: np.ndarray
    circuit: np.ndarray
    dynamic: np.ndarray
    elements: tuple[tuple[int, Element], ...]
    element_rows: tuple[tuple[int, ...], ...]
    ports: tuple[Port, ...]
    port_rows: np.ndarray
    port_circuit: np.ndarray
    _injection: np.ndarray = field(repr=False, compare=False)

    @property
    def size(self) -> int:
        """[-] Number of unknowns."""
        return len(self.labels)

    @property
    def n_circuits(self) -> int:
        return len(self.layout.circuits)

    @property
    def injection(self) -> np.ndarray:
        """``P``: unknowns x ports, 1 where a port's flow enters its node, ``(n, n_ports)``."""
        return self._injection

    def circuit_rows(self, c: int) -> np.ndarray:
        """[-] The unknown rows of circuit ``c`` (a contiguous block)."""
        return np.flatnonzero(self.circuit == c)

    def accumulators(self) -> list[tuple[int, Accumulator, int]]:
        """``(element index, accumulator, node row)`` of every accumulator, in element order."""
        return [(k, e, self.element_rows[k][0]) for k, (_, e) in enumerate(self.elements) if isinstance(e, Accumulator)]

    def damper_valves(self) -> list[tuple[int, DamperValve, tuple[int, ...]]]:
        """``(element index, valve, (a, b, q) rows)`` of every physical damper valve, in
        element order: the valves whose flows are hydraulic outputs (docs/model.md §3.3)."""
        return [(k, e, rows) for k, e, rows in self.valves() if isinstance(e, DamperValve)]

    def flow_valves(self) -> list[tuple[int, Valve, tuple[int, ...]]]:
        """``(element index, valve, (a, b, q) rows)`` of every nonlinear valve (a damper valve or
        an orifice), in element order: the valves whose flows are hydraulic outputs
        (``valve_flow_<j>``, ``j`` in this order) and may be solved on the road."""
        return [(k, e, rows) for k, e, rows in self.valves() if isinstance(e, (DamperValve, Orifice))]

    def solved_valves(self) -> list[tuple[int, Valve, tuple[int, ...]]]:
        """``(element index, valve, (a, b, q) rows)`` of every nonlinear valve whose RMS flow is
        solved with the response (no ``flow_rms`` given), in element order."""
        return [(k, e, rows) for k, e, rows in self.flow_valves() if getattr(e, "flow_rms", 0.0) is None]

    def valves(self) -> list[tuple[int, Valve, tuple[int, ...]]]:
        """``(element index, valve, (a, b, q) rows)`` of every valve (orifices included), in
        element order."""
        return [(k, e, self.element_rows[k]) for k, (_, e) in enumerate(self.elements) if isinstance(e, Valve)]


def _branch_rows(element: Element, fidelity: PipeModel) -> int:
    if isinstance(element, Valve):
        return 1
    if isinstance(element, Pipe):
        return 2 if fidelity == "distributed" else 1
    return 0


@functools.lru_cache(maxsize=64)
def compile_network(layout: Layout, fidelity: PipeModel = "lumped") -> Network:
    """Compile ``layout``'s structure at a pipe fidelity (``"lumped"`` or ``"distributed"``).

    Raises
    ------
    ModelError
        A circuit has no compliance (an incompressible closed circuit locks the cylinders).
    """
    labels: list[str] = []
    is_flow: list[bool] = []
    circuit_of: list[int] = []
    dynamic: list[bool] = []
    elements: list[tuple[int, Element]] = []
    element_rows: list[tuple[int, ...]] = []
    port_rows: list[int] = []
    port_circuit: list[int] = []
    for c, circuit in enumerate(layout.circuits):
        start = len(labels)
        index = {name: start + i for i, name in enumerate(circuit.nodes)}
        labels += [f"{circuit.name}:p[{n}]" for n in circuit.nodes]
        is_flow += [False] * len(index)
        dynamic += [False] * len(index)
        row = len(labels)
        for element in circuit.elements:
            elements.append((c, element))
            if isinstance(element, (Accumulator, ChamberCompliance)):
                element_rows.append((index[element.node],))
                dynamic[index[element.node]] = True
                continue
            a, b = index[element.a], index[element.b]
            n_rows = _branch_rows(element, fidelity)
            rows = tuple(range(row, row + n_rows))
            element_rows.append((a, b, *rows))
            arrow = f"{element.a}->{element.b}"
            labels += [f"{circuit.name}:q[{arrow}]"] if n_rows == 1 else [f"{circuit.name}:q1[{arrow}]", f"{circuit.name}:q2[{arrow}]"]
            is_flow += [True] * n_rows
            dynamic += [isinstance(element, Pipe) and fidelity == "lumped"] * n_rows
            if isinstance(element, Pipe) and fidelity == "lumped":
                dynamic[a] = dynamic[b] = True  # half the pipe's compliance at each end
            row += n_rows
        circuit_of += [c] * (len(labels) - start)
        has_storage = any(isinstance(e, (Accumulator, ChamberCompliance, Pipe)) for e in circuit.elements)
        if not has_storage:
            raise ModelError(
                f"circuit {circuit.name!r} has no compliance (accumulator, chamber or pipe): "
                "an incompressible closed circuit locks the cylinders; add an accumulator"
            )
        for port in circuit.ports:
            port_rows.append(index[port.node])
            port_circuit.append(c)
    injection = np.zeros((len(labels), len(port_rows)))
    injection[port_rows, np.arange(len(port_rows))] = 1.0
    return Network(
        layout=layout,
        fidelity=fidelity,
        labels=tuple(labels),
        is_flow=np.array(is_flow, dtype=bool),
        circuit=np.array(circuit_of, dtype=int),
        dynamic=np.array(dynamic, dtype=bool),
        elements=tuple(elements),
        element_rows=tuple(element_rows),
        ports=layout.ports,
        port_rows=np.array(port_rows, dtype=int),
        port_circuit=np.array(port_circuit, dtype=int),
        _injection=injection,
    )


# --- parameter values --------------------------------------------------------------------------
def solved_flow_name(k: int) -> str:
    """The parameter holding the solved RMS flow [m^3/s] of the damper valve at element index
    ``k`` (:meth:`Network.solved_valves`), set by the fixed point of
    :mod:`hisopt.evaluation.valve_flows`."""
    return f"valve_flow_rms_{k}"


def resolve(ref: ParamRef, params: Mapping[str, Any], where: str = "") -> Any:
    """The value of a parameter reference: ``params[ref]`` for a name, the number itself."""
    if isinstance(ref, str):
        if ref not in params:
            raise ConfigError(f"unknown parameter {ref!r}{where}; expected one of {', '.join(sorted(params))}")
        return params[ref]
    return float(ref)


@dataclass(frozen=True)
class ElementValues:
    """Resolved element parameters of one network for a batch of designs (any backend).

    ``shunt``: [m^3/Pa] compliance of each accumulator and chamber element; ``resistance``
    [Pa s m^-3], ``inertance`` [Pa s^2 m^-3] and ``compliance`` [m^3/Pa] of each valve or
    lumped pipe; ``line``: per-metre series impedance and shunt admittance coefficients
    ``(R', L', C', length)`` of each pipe; ``gas``: ``(V, p_abs, gamma)`` of each accumulator at
    its operating point; ``orifice``: ``(R, K_q)`` of each orifice, its laminar resistance
    [Pa s m^-3] and quadratic coefficient [Pa s^2 m^-6] for the nonlinear law (its
    ``resistance`` entry is the equivalent linear resistance); ``damper``: each damper
    valve's law. Keys are element indices of :attr:`Network.elements`.
    """

    shunt: dict[int, Any]
    resistance: dict[int, Any]
    inertance: dict[int, Any]
    compliance: dict[int, Any]
    line: dict[int, tuple[Any, Any, Any, Any]]
    gas: dict[int, tuple[Any, Any, Any]]
    orifice: dict[int, tuple[Any, Any]] = field(default_factory=dict)
    damper: dict[int, tuple[Any, Any, Any, Any]] = field(default_factory=dict)
    """``(r, K, p_c, R_b)`` of each damper valve at the oil's temperature: its laminar part
    [Pa s m^-3], bleed orifice coefficient [Pa s^2 m^-6], cracking pressure [Pa] and blow-off
    resistance [Pa s m^-3] (``p_c``, ``R_b`` None without a blow-off), the arguments of
    :func:`hisopt.hydraulics.laws.damper_valve_pressure_drop`; its ``resistance`` entry is
    the equivalent linear resistance."""


def element_values(
    network: Network, params: Mapping[str, Any], static_rise: Any = None, static_pressure: Any = None, origin: tuple[int, ...] | None = None
) -> ElementValues:
    """Apply the constitutive laws to every element (see :class:`ElementValues`).

    ``params`` maps every name the layout refers to, and ``rho``, ``mu``, ``beta``, to a value
    (float, numpy array of batch shape ``B`` or CasADi expression). An accumulator is
    linearised about its precharge: gas volume ``V0`` at absolute pressure ``p0 + p_atm``
    times the optional ``gas_temperature_ratio`` ``T / T_ref`` of ``params`` (the precharge
    is given at the reference temperature; the gas fills the accumulator at any temperature:
    the paper's idealisation). ``static_pressure`` [Pa] (a charged HIS,
    :mod:`hisopt.coupled.charge`): the absolute static pressure of each circuit; each
    accumulator is then linearised there, its gas ``p0_abs V0 T / T_ref`` at the oil's
    temperature filling ``V = p0_abs V0 (T / T_ref) / p`` (:func:`hisopt.hydraulics.laws.isothermal_gas_volume`).
    Valves follow the fluid's temperature through ``params``' optional ``viscosity_ratio``,
    ``density_ratio`` and ``valve_laminar_fraction`` (:func:`hisopt.hydraulics.laws.viscous_resistance`;
    absent: 1, 1 and 1, the reference temperature).

    ``origin``: per element, its index in the network this one was contracted from
    (:meth:`~hisopt.hydraulics.coupling.HydraulicSystem.contracted`), which names its solved
    RMS flow (:func:`solved_flow_name`); None: this network's own indices.

    ``static_rise`` [Pa]: the static pressure rise of each circuit above that point (a
    payload's, :func:`hisopt.coupled.payload.static_pressure_rise`), numpy ``B + (n_circuits,)`` or a
    CasADi column; each accumulator is then linearised at its laden point, gas volume
    ``V0 - dV(dp)`` at ``p_abs0 + dp`` (docs/model.md §13). ``None``: the point itself.
    """
    rho, mu, beta = (resolve(name, params) for name in FLUID_PARAMETERS)
    thermal = (params.get("valve_laminar_fraction", 1.0), params.get("viscosity_ratio", 1.0), params.get("density_ratio", 1.0))
    out = ElementValues({}, {}, {}, {}, {}, {}, {}, {})
    for k, (c, e) in enumerate(network.elements):
        where = f" (circuit {network.layout.circuits[c].name!r})"
        if isinstance(e, Accumulator):
            v0 = resolve(e.volume, params, where)
            p_abs = laws.absolute_pressure(resolve(e.precharge, params, where))
            gamma = resolve(e.gamma, params, where)
            p_abs = laws.gas_pressure_at_temperature(p_abs, params.get("gas_temperature_ratio", 1.0))
            if static_pressure is not None:
                p_static = circuit_entry(static_pressure, c)
                v0, p_abs = laws.isothermal_gas_volume(p_static, v0 * p_abs), p_static
            if static_rise is not None:
                dp = circuit_entry(static_rise, c)
                v0, p_abs = v0 - laws.gas_volume(dp, v0, p_abs, gamma), p_abs + dp
            out.gas[k] = (v0, p_abs, gamma)
            out.shunt[k] = laws.accumulator_compliance(v0, p_abs, gamma)
        elif isinstance(e, ChamberCompliance):
            out.shunt[k] = laws.oil_compliance(resolve(e.volume, params, where), beta)
        elif isinstance(e, Orifice):
            r, kq = resolve(e.resistance, params, where), resolve(e.kq, params, where)
            r, kq = laws.viscous_resistance(r, 1.0, thermal[1], thermal[2]), laws.viscous_resistance(kq, 0.0, thermal[1], thermal[2])
            out.orifice[k] = (r, kq)
            flow = resolve(e.flow_rms if e.flow_rms is not None else solved_flow_name(k if origin is None else origin[k]), params, where)
            out.resistance[k] = laws.orifice_equivalent_resistance(r, kq, flow)
        elif isinstance(e, DamperValve):
            law = damper_law(e, params, rho, thermal[1:], where)
            out.damper[k] = law
            flow = resolve(e.flow_rms if e.flow_rms is not None else solved_flow_name(k if origin is None else origin[k]), params, where)
            out.resistance[k] = laws.damper_valve_equivalent_resistance(flow, law[1], law[2], law[3], law[0])
        elif isinstance(e, Valve):
            out.resistance[k] = laws.viscous_resistance(resolve(e.resistance, params, where), *thermal)
        else:
            length = resolve(e.length, params, where)
            d = resolve(e.diameter, params, where)
            r_m, l_m = laws.pipe_resistance_per_m(mu, d), laws.pipe_inertance_per_m(rho, d)
            c_m = laws.pipe_compliance_per_m(beta, d)
            out.line[k] = (r_m, l_m, c_m, length)
            out.resistance[k], out.inertance[k], out.compliance[k] = r_m * length, l_m * length, c_m * length
    return out


def damper_law(e: DamperValve, params: Mapping[str, Any], rho: Any, thermal: tuple[Any, Any], where: str = "") -> tuple[Any, Any, Any, Any]:
    """``(r, K, p_c, R_b)`` of a damper valve (see :class:`ElementValues`) in oil of density
    ``rho`` (at its temperature): the laminar part follows the viscosity ratio ``thermal[0]``,
    the bleed orifice the density; the blow-off's spring and opening law are the oil's
    temperature's alike (``p_c``, ``R_b`` as given)."""
    r = laws.viscous_resistance(resolve(e.resistance, params, where), 1.0, *thermal)
    kq = laws.orifice_coefficient(resolve(e.orifice_diameter, params, where), resolve(e.discharge_coefficient, params, where), rho)
    if e.cracking_pressure is None or e.blowoff_resistance is None:
        return r, kq, None, None
    return r, kq, resolve(e.cracking_pressure, params, where), resolve(e.blowoff_resistance, params, where)


def circuit_entry(per_circuit: Any, c: int) -> Any:
    """Circuit ``c``'s value of a per-circuit quantity: numpy ``B + (n_circuits,)`` gives
    ``B``; a CasADi column its ``c``-th entry."""
    return per_circuit[c] if bk.is_casadi(per_circuit) else np.asarray(per_circuit)[..., c]


# --- stamps and assembly -----------------------------------------------------------------------
Entry = bk.Entry


def stamps(network: Network, values: ElementValues) -> tuple[list[Entry], list[Entry]]:
    """``(K0, K1)`` entries of the lumped elements: ``M(s) = K0 + s K1`` (module docstring).

    Distributed pipes are left out (see :func:`line_entries`).
    """
    k0: list[Entry] = []
    k1: list[Entry] = []
    for k, (_, e) in enumerate(network.elements):
        rows = network.element_rows[k]
        if isinstance(e, (Accumulator, ChamberCompliance)):
            k1.append((rows[0], rows[0], values.shunt[k]))
            continue
        if isinstance(e, Pipe) and network.fidelity == "distributed":
            continue
        a, b, q = rows
        k0 += [(a, q, 1.0), (b, q, -1.0), (q, a, -1.0), (q, b, 1.0), (q, q, values.resistance[k])]
        if isinstance(e, Pipe):
            half = 0.5 * values.compliance[k]
            k1 += [(a, a, half), (b, b, half), (q, q, values.inertance[k])]
    return k0, k1


def line_entries(network: Network, values: ElementValues, s: Any) -> list[Entry]:
    """Entries of the distributed pipes at the Laplace variable ``s`` (module docstring)."""
    out: list[Entry] = []
    if network.fidelity != "distributed":
        return out
    for k, (_, e) in enumerate(network.elements):
        if not isinstance(e, Pipe):
            continue
        a, b, q1, q2 = network.element_rows[k]
        r_m, l_m, c_m, length = values.line[k]
        t11, t12, t21, t22 = laws.line_transfer_matrix(s * l_m + r_m, s * c_m, length)
        out += [(a, q1, 1.0), (b, q2, -1.0)]
        out += [(q1, a, t11), (q1, b, -1.0), (q1, q1, t12)]
        out += [(q2, a, t21), (q2, q1, t22), (q2, q2, -1.0)]
    return out


def network_matrix(network: Network, values: ElementValues, s: Any) -> Any:
    """``M(s)`` of the whole network (block diagonal by circuit).

    ``s`` [rad/s]: numpy shape ``(F,)`` or ``B + (F,)`` (result ``B + (F, n, n)``, complex),
    or a CasADi complex value (result a :class:`~hisopt.hydraulics.backend.Complex` matrix).
    """
    k0, k1 = stamps(network, values)
    if bk.is_casadi(s):
        entries = k0 + [(i, j, s * v) for i, j, v in k1] + line_entries(network, values, s)
        return bk.assemble((network.size, network.size), entries, like=bk.Complex(0.0, 0.0))
    s = np.asarray(s)
    col = lambda v: np.asarray(v)[..., None] if np.ndim(v) else v  # noqa: E731  per-design value x frequency
    entries = [(i, j, col(v)) for i, j, v in k0] + [(i, j, s * col(v)) for i, j, v in k1]
    lines = replace(values, line={k: tuple(col(x) for x in v) for k, v in values.line.items()})  # type: ignore[misc]
    entries += line_entries(network, lines, s)
    return bk.assemble((network.size, network.size), entries, batch=s.shape, like=0j)


def lumped_descriptor(network: Network, values: ElementValues) -> tuple[Any, Any]:
    """``(e, A)`` of the lumped descriptor ``diag(e) dh/dt = A h + P q_port``.

    numpy: ``e`` has shape ``B + (n,)`` and ``A`` ``B + (n, n)``.
    """
    if network.fidelity != "lumped":
        raise ModelError("the descriptor (state space) needs lumped pipes; distributed lines have none")
    k0, k1 = stamps(network, values)
    if any(i != j for i, j, _ in k1):
        raise ModelError("lumped storage must be diagonal")  # a stamp table error, not a user error
    n = network.size
    a = bk.assemble((n, n), [(i, j, -v) for i, j, v in k0])
    e = bk.assemble((n, 1), [(i, 0, v) for i, _, v in k1])
    if bk.is_casadi(e):
        return e, a
    return e[..., 0], a


def port_impedance(network: Network, values: ElementValues, s: Any) -> Any:
    """``Z_port(s) = P^T M(s)^-1 P``: chamber pressures per port flow (block diagonal).

    numpy: shape ``B + (F, n_ports, n_ports)``, NaN where ``M(s)`` is singular; CasADi: a
    complex matrix. Solved circuit by circuit.
    """
    m = network_matrix(network, values, s)
    n_ports = len(network.ports)
    if bk.is_casadi(m):
        blocks = []
        for c in range(network.n_circuits):
            rows = network.circuit_rows(c)
            ports = np.flatnonzero(network.port_circuit == c)
            p = network.injection[np.ix_(rows, ports)]
            index = [int(r) for r in rows]
            sub = bk.Complex(m.re[index, index], m.im[index, index])
            blocks.append((ports, bk.matmul(p.T, bk.solve(sub, p))))
        return _block_diag_casadi(blocks, n_ports)
    out = np.zeros(m.shape[:-2] + (n_ports, n_ports), dtype=complex)
    for rows, ports, sol in circuit_solutions(network, m):
        p = network.injection[np.ix_(rows, ports)]
        out[..., ports[:, None], ports[None, :]] = p.T @ sol
    return out


def circuit_solutions(network: Network, m: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """``(rows, ports, M_c^-1 P_c)`` of every circuit ``c`` of the numpy network matrix ``m``
    (``B + (F, n, n)``); NaN where a circuit's matrix is singular."""
    out = []
    for c in range(network.n_circuits):
        rows = network.circuit_rows(c)
        ports = np.flatnonzero(network.port_circuit == c)
        p = network.injection[np.ix_(rows, ports)]
        sub = m[..., rows[:, None], rows[None, :]]
        with np.errstate(all="ignore"):
            out.append((rows, ports, _solve_or_nan(sub, np.broadcast_to(p, sub.shape[:-2] + p.shape))))
    return out


def _block_diag_casadi(blocks: list[tuple[np.ndarray, Any]], n: int) -> Any:
    kind = type(blocks[0][1].re)
    re, im = kind.zeros(n, n), kind.zeros(n, n)
    for ports, z in blocks:
        idx = [int(i) for i in ports]
        re[idx, idx] = z.re
        im[idx, idx] = z.im
    return bk.Complex(re, im)


def _solve_or_nan(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Batched solve; systems that are singular (or numerically so) give NaN."""
    try:
        return np.linalg.solve(a, b)
    except np.linalg.LinAlgError:
        pass
    flat_a = a.reshape((-1,) + a.shape[-2:])
    flat_b = b.reshape((-1,) + b.shape[-2:])
    out = np.full(flat_b.shape, np.nan, dtype=np.result_type(a, b))
    ok = np.abs(np.linalg.det(flat_a)) > 0
    if ok.any():
        cond = np.linalg.cond(flat_a[ok])
        good = np.flatnonzero(ok)[np.isfinite(cond) & (cond < 1e15)]
        if good.size:
            out[good] = np.linalg.solve(flat_a[good], flat_b[good])
    return out.reshape(b.shape)


# --- coupling to the strokes ---------------------------------------------------------------------
def incidence(network: Network, top_area: Any, bottom_area: Any) -> Any:
    """``N``: ports x wheels signed chamber areas [m^2] (docs/model.md §3.2).

    ``top_area``, ``bottom_area``: [m^2] per wheel; numpy arrays of shape ``B + (4,)`` (result
    ``B + (n_ports, 4)``) or sequences of four CasADi expressions (result a matrix).
    """

    def wheel(x: Any, w: int) -> Any:
        return x[..., w] if isinstance(x, np.ndarray) else x[w]

    entries = [
        (k, port.wheel, laws.chamber_area(wheel(top_area, port.wheel), wheel(bottom_area, port.wheel), port.chamber)) for k, port in enumerate(network.ports)
    ]
    return bk.assemble((len(network.ports), 4), entries)


def total_compliance(network: Network, values: ElementValues, c: int) -> Any:
    """[m^3/Pa] All compliance of circuit ``c``: accumulators, chambers, pipe volumes."""
    total: Any = 0.0
    for k, (circuit, e) in enumerate(network.elements):
        if circuit != c:
            continue
        if isinstance(e, (Accumulator, ChamberCompliance)):
            total = total + values.shunt[k]
        elif isinstance(e, Pipe):
            total = total + values.line[k][2] * values.line[k][3]
    return total


def static_stiffness(network: Network, values: ElementValues, n_ports: Any) -> Any:
    """[N/m] Static stroke stiffness ``K_his = sum_c a_c a_c^T / C_c`` (4 x 4).

    At rest no flow passes a valve or pipe, so every node of a circuit holds one pressure:
    the circuit is one compliance ``C_c`` (:func:`total_compliance`) filled by the strokes
    through ``a_c = sum of its ports' rows of N``. This is ``lim_{s->0} D(s)`` exactly.

    Parameters
    ----------
    n_ports : Any
        [m^2] incidence ``N`` from :func:`incidence`
    """
    total: Any = 0.0
    for c in range(network.n_circuits):
        ports = [int(k) for k in np.flatnonzero(network.port_circuit == c)]
        if bk.is_casadi(n_ports):
            import casadi as ca

            a_c = ca.sum1(n_ports[ports, :]).T
            total = total + (a_c @ a_c.T) / total_compliance(network, values, c)
        else:
            a_c = np.sum(np.asarray(n_ports)[..., ports, :], axis=-2)
            comp = np.asarray(total_compliance(network, values, c))[..., None, None]
            total = total + a_c[..., :, None] * a_c[..., None, :] / comp
    return total


MIRROR_WHEEL = (1, 0, 3, 2)
"""The wheel on the other side: FL <-> FR, RL <-> RR."""


def mirror_unknowns(network: Network) -> np.ndarray | None:
    """The left-right mirror image of every unknown, or None when the layout is not mirror
    symmetric in its structure.

    A port's node maps to the node of the same chamber on the other wheel; from there the
    map follows the elements: an element maps to one of the same kind and parameter names
    between the mapped nodes (a flow keeps its orientation). Whether the values are mirror
    symmetric too is for the caller to check numerically (the parameters may differ).

    Returns
    -------
    ndarray of int, shape ``(n,)``, or None
        Unknown ``i`` maps to unknown ``out[i]`` (an involution).
    """
    by_chamber = {(port.wheel, port.chamber): int(row) for port, row in zip(network.ports, network.port_rows, strict=True)}
    node_map: dict[int, int] = {}
    for port, row in zip(network.ports, network.port_rows, strict=True):
        image = by_chamber.get((MIRROR_WHEEL[port.wheel], port.chamber))
        if image is None or node_map.setdefault(int(row), image) != image:
            return None
    signatures = [_signature(e) for _, e in network.elements]
    unmatched = set(range(len(network.elements)))
    element_map: dict[int, int] = {}
    progress = True
    while unmatched and progress:
        progress = False
        for k in sorted(unmatched):
            nodes = network.element_rows[k][: 1 if len(network.element_rows[k]) == 1 else 2]
            known = [node_map.get(n) for n in nodes]
            if all(v is None for v in known):
                continue
            candidates = [
                j
                for j in range(len(network.elements))
                if signatures[j] == signatures[k]
                and j not in element_map.values()
                and all(v is None or v == network.element_rows[j][i] for i, v in enumerate(known))
            ]
            if len(candidates) != 1:
                continue
            j = candidates[0]
            element_map[k] = j
            for i, n in enumerate(nodes):
                if node_map.setdefault(n, network.element_rows[j][i]) != network.element_rows[j][i]:
                    return None
            unmatched.discard(k)
            progress = True
    if unmatched:
        return None
    out = np.arange(network.size)
    for a, b in node_map.items():
        out[a] = b
    for k, j in element_map.items():
        rows_k, rows_j = network.element_rows[k], network.element_rows[j]
        for a, b in zip(rows_k[2:] if len(rows_k) > 1 else (), rows_j[2:] if len(rows_j) > 1 else (), strict=True):
            out[a] = b  # branch flows
    if not np.array_equal(out[out], np.arange(network.size)):
        return None
    return out


def _signature(element: Element) -> tuple[Any, ...]:
    """An element's kind and parameter references: what its mirror image must share."""
    from hisopt.hydraulics.layout import PARAMETER_FIELDS

    return (type(element).__name__, *(getattr(element, f) for f in PARAMETER_FIELDS[type(element)]))


def low_frequency_damping(network: Network, values: ElementValues, n_ports: Any) -> Any:
    """[N s/m] Low-frequency stroke damping ``C_lf = lim_{s->0} (D(s) - K_his) / s`` (4 x 4),
    exact for the lumped network (docs/model.md §12.4).

    Per circuit, the network's response to port flows ``b`` is ``h(s) = M(s)^-1 b`` with
    ``M = K0 + s K1``. ``K0`` (resistances only) is singular: statically every node of a
    circuit holds one pressure ``u`` (1 on the node rows, 0 on the flow rows), and the node
    rows sum to zero (``v = u`` is its left null vector). Expanding
    ``h = h_-1 / s + h_0 + O(s)`` gives ``h_-1 = (v.b / v.K1 u) u`` (the circuit's compliance
    filled by the net flow: ``K_his``) and ``h_0`` from ``K0 h_0 = b - K1 h_-1`` with
    ``v.K1 h_0 = 0``, solved as one bordered system. ``D(s) = s N^T P^T h(s) N`` then gives
    ``C_lf = N^T P^T H_0 N``, where ``H_0`` holds ``h_0`` for each port's unit flow. It is
    the damping the resistances add to slow stroke motion: ``delta'^T C_lf delta'`` is the
    power they dissipate while the oil shares itself among the compliances at one pressure.

    Parameters
    ----------
    n_ports : Any
        [m^2] incidence ``N`` from :func:`incidence`, numpy ``B + (n_ports, 4)``

    Returns
    -------
    numpy.ndarray
        ``B + (4, 4)``, symmetric positive semi-definite.
    """
    h0 = low_frequency_unknowns(network, values)
    z0 = network.injection.T @ h0  # ports x ports: the regular part of Z_port at s = 0
    n_arr = np.asarray(n_ports)
    return np.swapaxes(n_arr, -1, -2) @ z0 @ n_arr


def low_frequency_unknowns(network: Network, values: ElementValues) -> np.ndarray:
    """``H_0``: the regular part of ``M(s)^-1 P`` at ``s -> 0`` (every unknown per port flow),
    numpy ``B + (n, n_ports)``, of the lumped network (:func:`low_frequency_damping`).

    Its flow rows are the flows a slow port flow drives through every valve and pipe while
    the oil shares itself among the compliances at one pressure per circuit: the oil moving
    as a rigid column with the strokes (docs/model.md §8.2 names modes with them).
    """
    if network.fidelity != "lumped":
        raise ModelError("the low-frequency damping is computed on lumped pipes (HydraulicSystem.lumped())")
    k0_entries, k1_entries = stamps(network, values)
    n = network.size
    k0 = bk.assemble((n, n), k0_entries)
    k1 = bk.assemble((n, n), k1_entries)
    batch = np.broadcast_shapes(np.shape(k0)[:-2], np.shape(k1)[:-2])
    k0, k1 = np.broadcast_to(k0, batch + (n, n)), np.broadcast_to(k1, batch + (n, n))
    h0 = np.zeros(batch + (n, len(network.ports)))
    for c in range(network.n_circuits):
        rows = network.circuit_rows(c)
        ports = np.flatnonzero(network.port_circuit == c)
        a0 = k0[..., rows[:, None], rows[None, :]]
        a1 = k1[..., rows[:, None], rows[None, :]]
        u = (~network.is_flow[rows]).astype(float)
        b = network.injection[np.ix_(rows, ports)]  # unit flow at each port of the circuit
        a1u = a1 @ u  # the compliance of each node (flow rows: 0)
        alpha = (u @ b) / (a1u @ u)[..., None]  # h_-1 = alpha u per port flow
        rhs = b - a1u[..., :, None] * alpha[..., None, :]
        m = len(rows)
        bordered = np.zeros(batch + (m + 1, m + 1))
        bordered[..., :m, :m] = a0
        bordered[..., :m, m] = u
        bordered[..., m, :m] = u @ a1
        full_rhs = np.concatenate([rhs, np.zeros(batch + (1, len(ports)))], axis=-2)
        sol = np.linalg.solve(bordered, full_rhs)[..., :m, :]
        h0[..., rows[:, None], ports[None, :]] = sol
    return h0
