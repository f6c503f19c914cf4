"""Time-domain simulation of the lumped car + HIS model (paper Section VI; docs/model.md §3).

Two fidelity levels share one road input (any ``(n_t, 4)`` wheel profile, read between samples
by :class:`hisopt.road.interpolation.RoadInput`) and one result, :class:`TimeResponse`:

- ``"linear"``: the exact lumped state space ``dx/dt = A x + B0 u + B1 du/dt`` of
  :meth:`hisopt.coupled.model.CoupledModel.state_space`, integrated as
  ``d(x - B1 u)/dt = A (x - B1 u) + (B0 + A B1) u`` so a road step needs no impulse; every
  pressure and flow comes back through the realisation's inverse map;
- ``"nonlinear"``: :class:`hisopt.simulation.nonlinear_model.NonlinearModel` (gas law in absolute
  pressure, quadratic orifices, physical damper valves by their own law, tyre lift-off); the
  linear mode takes each damper valve at the equivalent resistance the model was built with.

All states are deviations from the static equilibrium on a flat road (``z_g = 0``), where
the accumulators sit at their operating point. Outputs are SI.

References
----------
Paper Eq. (1)-(6), (10), (15)-(21); docs/model.md §1-§4.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Literal, get_args

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp

from hisopt.arguments import of_type, one_of
from hisopt.constants import DOF_NAMES, G_MPS2, P_ATM_PA, WHEEL_NAMES
from hisopt.coupled.buildability import circuit_pressures, port_values
from hisopt.coupled.model import CoupledModel, StateSpace
from hisopt.errors import ConfigError, ModelError
from hisopt.road.interpolation import Interpolation, RoadInput
from hisopt.simulation.nonlinear_model import GAS_VOLUME_LIMIT, NonlinearModel, accumulators, single_design
from hisopt.vehicle import body_to_corners, road_damping_input, road_stiffness_input, stroke_matrix

if TYPE_CHECKING:
    from hisopt.plotting import Figure

ROLL_DOF = 1
"""Index of the roll angle among the DOFs (``hisopt.constants.DOF_NAMES``)."""

SimulationMode = Literal["linear", "nonlinear"]
"""``"linear"``: exact lumped state space; ``"nonlinear"``: gas law, orifices, tyre lift-off."""

SolverMethod = Literal["auto", "RK45", "DOP853", "Radau", "BDF", "LSODA"]
"""``scipy.integrate.solve_ivp`` method; ``"auto"`` is LSODA (stiffness detected on the fly)."""


def _linear_matrices(ss: StateSpace) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return (
        single_design(np.asarray(ss.a), 2, "state matrix"),
        single_design(np.asarray(ss.b0), 2, "input matrix"),
        single_design(np.asarray(ss.b1), 2, "input-rate matrix"),
    )


def state_scales(
    a: np.ndarray,
    b0: np.ndarray,
    b1: np.ndarray,
    output: np.ndarray | None = None,
    f_hz: ArrayLike = (0.5, 1.5, 3.0, 11.0),
) -> NDArray[np.float64]:
    """Typical magnitude of each state per metre of road input (for absolute tolerances).

    The largest ``|(C x)_i(j w)|`` over a few frequencies spanning the body and wheel modes
    and over the four wheel inputs, ``x(j w) = (j w I - A)^-1 (B0 + j w B1)``.

    Parameters
    ----------
    a, b0, b1
        State-space matrices, shapes ``(n, n)``, ``(n, 4)``, ``(n, 4)``.
    output
        Map ``C`` ``(n_out, n)`` to the quantities wanted (default: the states).
    f_hz
        [Hz] Probe frequencies.

    Returns
    -------
    ndarray, shape ``(n_out,)``
        [quantity unit / m] Scales, positive.
    """
    s = 2j * np.pi * np.asarray(f_hz, dtype=float)[:, None, None]
    n = a.shape[-1]
    x = np.linalg.solve(s * np.eye(n) - a, b0 + s * b1)
    if output is not None:
        x = output @ x
    scale = np.abs(x).max(axis=(0, 2))
    return np.where(scale > 0, scale, scale.max())


@dataclass(frozen=True)
class TimeResponse:
    """A simulated time history; SI units, samples at the road input times.

    Shapes: ``t_s`` ``(n_t,)``; ``road_m``, ``stroke_m``, ``tyre_force_n`` ``(n_t, 4)`` (FL,
    FR, RL, RR); ``displacement``, ``velocity``, ``acceleration`` ``(n_t, 7)`` in DOF order
    ``[z_s, phi, theta, z_u1..z_u4]`` (m or rad, per s, per s^2); accumulator arrays
    ``(n_t, n_acc)``.
    """

    t_s: NDArray[np.float64]
    road_m: NDArray[np.float64]
    displacement: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    stroke_m: NDArray[np.float64]
    """[m] Suspension stroke ``delta = G X``, extension positive."""
    tyre_force_n: NDArray[np.float64]
    """[N] Dynamic tyre load ``k_t (z_u - z_g) + c_t (dz_u - dz_g)`` (docs/model.md §5.1)."""
    accumulator_pressure_pa: NDArray[np.float64]
    """[Pa] Gauge accumulator pressure, precharge plus dynamic rise."""
    accumulator_volume_m3: NDArray[np.float64]
    """[m^3] Oil stored in each accumulator (gas volume lost)."""
    accumulator_names: tuple[str, ...]
    corners: NDArray[np.float64]
    """``T_z`` (4, 3): body points above the wheels from ``[z_s, phi, theta]``."""
    mode: SimulationMode
    valve_flow_m3s: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0)))
    """[m^3/s] Flow through each physical damper valve, from its node ``a`` to ``b``, ``(n_t, n_valves)``
    (the network's :meth:`~hisopt.hydraulics.network.Network.damper_valves` order, as the
    frequency domain's ``valve_flow_<j>``)."""
    valve_drop_pa: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0)))
    """[Pa] Pressure drop ``p_a - p_b`` across each damper valve, ``(n_t, n_valves)``."""
    valve_names: tuple[str, ...] = ()
    """``"<circuit>:<from>-><to>"`` of each damper valve."""
    port_pressure_pa: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0)))
    """[Pa] Gauge pressure in each cylinder chamber (port), static plus dynamic, ``(n_t, n_ports)``
    in the network's port order (the frequency domain's ``port_pressure_<i>`` is the dynamic part)."""
    strut_force_n: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0)))
    """[N] The fluid's force on each strut, extension positive, static plus dynamic,
    ``-N^T p_gauge`` (docs/model.md §21), ``(n_t, 4)``."""

    @property
    def corner_acceleration(self) -> NDArray[np.float64]:
        """[m/s^2] Vertical body acceleration above each wheel, ``T_z [z_s, phi, theta]''``, ``(n_t, 4)``."""
        return self.acceleration[:, :3] @ self.corners.T

    def to_frame(self) -> pd.DataFrame:
        """All signals in one table (SI), one row per sample.

        Columns: ``time``; ``road_<w>``; DOF displacements ``z_s, phi, theta, z_u1..z_u4``,
        velocities ``d<dof>``, accelerations ``dd<dof>``; ``a_body_<w>`` (body corners),
        ``stroke_<w>``, ``tyre_force_<w>``; ``p_acc_<name>`` (gauge), ``dv_acc_<name>``;
        ``valve_flow_<j>``, ``valve_drop_<j>`` of each damper valve; ``p_port_<i>`` (gauge) of
        each chamber and ``strut_force_<w>`` of each strut.
        """
        cols: dict[str, np.ndarray] = {"time": self.t_s}
        cols |= {f"road_{w}": self.road_m[:, i] for i, w in enumerate(WHEEL_NAMES)}
        cols |= {n: self.displacement[:, i] for i, n in enumerate(DOF_NAMES)}
        cols |= {f"d{n}": self.velocity[:, i] for i, n in enumerate(DOF_NAMES)}
        cols |= {f"dd{n}": self.acceleration[:, i] for i, n in enumerate(DOF_NAMES)}
        corner = self.corner_acceleration
        cols |= {f"a_body_{w}": corner[:, i] for i, w in enumerate(WHEEL_NAMES)}
        cols |= {f"stroke_{w}": self.stroke_m[:, i] for i, w in enumerate(WHEEL_NAMES)}
        cols |= {f"tyre_force_{w}": self.tyre_force_n[:, i] for i, w in enumerate(WHEEL_NAMES)}
        cols |= {f"p_acc_{n}": self.accumulator_pressure_pa[:, i] for i, n in enumerate(self.accumulator_names)}
        cols |= {f"dv_acc_{n}": self.accumulator_volume_m3[:, i] for i, n in enumerate(self.accumulator_names)}
        cols |= {f"valve_flow_{j}": self.valve_flow_m3s[:, j] for j in range(len(self.valve_names))}
        cols |= {f"valve_drop_{j}": self.valve_drop_pa[:, j] for j in range(len(self.valve_names))}
        cols |= {f"p_port_{i}": self.port_pressure_pa[:, i] for i in range(self.port_pressure_pa.shape[1])}
        if self.strut_force_n.size:
            cols |= {f"strut_force_{w}": self.strut_force_n[:, i] for i, w in enumerate(WHEEL_NAMES)}
        frame = pd.DataFrame(cols)
        frame.attrs["units"] = {name: signal_unit(name) for name in frame.columns}
        return frame

    def plot_signals(self, columns: tuple[str, ...] = ("z_s", "phi", "theta"), fig: Figure | None = None) -> Figure:
        """Stacked time histories of columns of :meth:`to_frame`, one panel each.

        Drawn by :func:`hisopt.plotting.timeseries.signals_figure`.

        Parameters
        ----------
        columns
            Column names of :meth:`to_frame` (SI units).
        fig
            Figure to add the traces to (its subplot grid must have ``len(columns)`` rows);
            ``None`` makes a new one.
        """
        frame = self.to_frame()
        unknown = [c for c in columns if c not in frame.columns]
        if unknown:
            raise ConfigError(f"unknown signal(s) {unknown}; expected columns of to_frame(), e.g. {list(frame.columns[:8])}")
        from hisopt.plotting.timeseries import signals_figure

        return signals_figure(frame, columns, frame.attrs["units"], self.mode, fig)

    def plot_pressures(self, fig: Figure | None = None) -> Figure:
        """Gauge accumulator pressures [MPa] against time (:func:`hisopt.plotting.timeseries.pressures_figure`)."""
        from hisopt.plotting.timeseries import pressures_figure

        return pressures_figure(self.t_s, self.accumulator_pressure_pa, self.accumulator_names, self.mode, fig)


def signal_unit(column: str) -> str:
    """[-] SI unit of a column of :meth:`TimeResponse.to_frame`."""
    dof = {name: ("rad" if name in ("phi", "theta") else "m") for name in DOF_NAMES}
    if column in dof:
        return dof[column]
    if column.startswith("dd") and column[2:] in dof:
        return f"{dof[column[2:]]}/s^2"
    if column.startswith("d") and column[1:] in dof:
        return f"{dof[column[1:]]}/s"
    prefixes = {
        "time": "s",
        "road_": "m",
        "a_body_": "m/s^2",
        "stroke_": "m",
        "tyre_force_": "N",
        "p_acc_": "Pa",
        "dv_acc_": "m^3",
        "valve_flow_": "m^3/s",
        "valve_drop_": "Pa",
        "p_port_": "Pa",
        "strut_force_": "N",
    }
    return next(unit for prefix, unit in prefixes.items() if column.startswith(prefix))


# --- simulation ---------------------------------------------------------------------------


def _integrate(
    fun: Callable[[float, np.ndarray], np.ndarray],
    y0: np.ndarray,
    road: RoadInput,
    method: str,
    rtol: float,
    atol: np.ndarray,
    jac: Callable[[float, np.ndarray], np.ndarray],
) -> np.ndarray:
    """``solve_ivp`` over the road record with outputs at its samples, ``(n, n_t)``: ``y0``
    stacks the states of every road of a batch, one integrator (one step size) for all."""
    options: dict[str, object] = {}
    if method in ("Radau", "BDF", "LSODA"):  # explicit methods warn about an unused jac
        options["jac"] = jac
    sol = solve_ivp(
        fun,
        (float(road.t_s[0]), float(road.t_s[-1])),
        y0,
        method=method,
        t_eval=road.t_s,
        rtol=rtol,
        atol=atol,
        max_step=float(np.diff(road.t_s).min()),  # resolve every input segment
        **options,
    )
    if not sol.success:
        raise ModelError(f"time integration failed ({method}): {sol.message}")
    return sol.y


@dataclass(frozen=True)
class Nonlinearities:
    """Which nonlinearities a ``"nonlinear"`` simulation switches on (each alone off names its
    share of a gap to the linear model, :mod:`hisopt.simulation.verification`).

    Attributes
    ----------
    gas_law : bool
        [-] the polytropic gas law in absolute pressure (off: each accumulator at its
        linearised compliance, with no bottoming out)
    valve_law : bool
        [-] quadratic orifices, physical damper valves and ``valve_kq`` by their laws (off: each
        at the equivalent resistance the model was built with)
    tyre_liftoff : bool
        [-] the tyre pushes but never pulls
    """

    gas_law: bool = True
    valve_law: bool = True
    tyre_liftoff: bool = False

    @property
    def any(self) -> bool:
        return self.gas_law or self.valve_law or self.tyre_liftoff


BodyForce = ArrayLike | Callable[[Any], ArrayLike] | None
"""[N, N m] External generalised force on the 7 DOFs: constant ``(7,)``, or a function of time
giving ``(7,)`` at a float and ``(n, 7)`` at ``n`` times (a manoeuvre), or None."""


def _force_reader(body_force: BodyForce, t_s: np.ndarray) -> Callable[[Any], np.ndarray]:
    """``body_force`` as a function of time: ``(7,)`` at a float, ``(n, 7)`` at an array."""
    if body_force is None or not callable(body_force):
        force = np.zeros(7) if body_force is None else np.asarray(body_force, dtype=float)
        if force.shape != (7,) or not np.all(np.isfinite(force)):
            raise ConfigError(f"expected body_force of shape (7,) [N, N m], finite, got shape {force.shape}")
        return lambda t: force if np.ndim(t) == 0 else np.broadcast_to(force, (np.size(t), 7))
    history = np.asarray(body_force(t_s), dtype=float)
    if history.shape != (t_s.size, 7) or not np.all(np.isfinite(history)):
        raise ConfigError(f"expected body_force(t) of shape ({t_s.size}, 7) [N, N m] at the record's times, finite, got shape {history.shape}")
    return lambda t: np.asarray(body_force(t), dtype=float)


def simulate(
    model: CoupledModel,
    t_s: ArrayLike,
    road_m: ArrayLike,
    mode: SimulationMode = "linear",
    *,
    valve_kq: float = 0.0,
    tyre_liftoff: bool = False,
    interpolation: Interpolation = "pchip",
    method: SolverMethod = "auto",
    rtol: float = 1e-8,
    body_force: BodyForce = None,
    gravity_moment: bool = False,
    gas_law: bool = True,
    valve_law: bool = True,
) -> TimeResponse:
    """Simulate the car (with or without HIS) driven by road displacements at the wheels.

    The car starts at rest in its static equilibrium on a flat road; a profile that does not
    start at 0 therefore begins with a transient.

    Parameters
    ----------
    model
        Single-design lumped model (``pipe_model="lumped"``; distributed pipes have no
        finite state space).
    t_s
        [s] Increasing sample times, shape ``(n_t,)``; outputs are given at these times.
    road_m
        [m] Road displacement under FL, FR, RL, RR, shape ``(n_t, 4)`` (e.g. from
        :func:`hisopt.road.random_profile`, :func:`~hisopt.road.step_profile`,
        :func:`~hisopt.road.bump_profile`), read between samples as ``interpolation`` says.
    mode
        ``"linear"`` (exact state space) or ``"nonlinear"`` (gas law, options below).
    valve_kq
        [Pa s^2 m^-6] Quadratic orifice coefficient ``K_q`` of every linear valve (``Rv``),
        ``dp = R_v q + K_q q |q|`` (nonlinear mode only). Orifice elements and physical damper
        valves follow their own laws in nonlinear mode (docs/model.md §3.10) and their
        equivalent resistances in linear mode.
    tyre_liftoff
        [-] Let wheels leave the road when the dynamic load exceeds the static load
        (nonlinear mode only).
    interpolation
        ``"pchip"`` (default; keeps steps monotone), ``"cubic"`` (smoothest: fastest and
        most faithful for sampled random roads) or ``"linear"`` (:data:`Interpolation`).
    method
        Integrator of ``scipy.integrate.solve_ivp``; ``"auto"`` is LSODA, which switches
        between Adams and BDF as stiffness requires (exact Jacobian in linear mode).
        Explicit ``"DOP853"`` is often fastest for smooth (``"cubic"``) random roads.
    rtol
        [-] Relative tolerance; absolute tolerances follow from each state's typical size.
    body_force
        [N, N m] External generalised force on the 7 DOFs ``[z_s, phi, theta, z_u1..z_u4]``
        (:data:`BodyForce`): constant ``(7,)`` from ``t_s[0]`` (a step: e.g. the roll moment
        ``m_s a_y h_0s`` of a lateral acceleration, :mod:`hisopt.evaluation.transient`), or a
        function of time (a manoeuvre, :mod:`hisopt.simulation.manoeuvres`). Default none.
    gravity_moment
        [-] The body's weight adds ``m_s g h_0s phi`` to the roll moment as it rolls
        (``[handling] gravity_moment``, docs/model.md §6.4), as the transient quantities take it.
    gas_law, valve_law
        [-] Nonlinear mode: the gas law and the valves' laws on (default) or off
        (:class:`Nonlinearities`).

    Returns
    -------
    TimeResponse
    """
    return simulate_batch(
        model,
        t_s,
        np.asarray(road_m, dtype=float)[None],
        mode,
        valve_kq=valve_kq,
        interpolation=interpolation,
        method=method,
        rtol=rtol,
        body_force=body_force,
        gravity_moment=gravity_moment,
        nonlinearities=Nonlinearities(gas_law, valve_law, tyre_liftoff),
    )[0]


def simulate_batch(
    model: CoupledModel,
    t_s: ArrayLike,
    roads_m: ArrayLike,
    mode: SimulationMode = "linear",
    *,
    valve_kq: float = 0.0,
    interpolation: Interpolation = "pchip",
    method: SolverMethod = "auto",
    rtol: float = 1e-8,
    body_force: BodyForce = None,
    gravity_moment: bool = False,
    nonlinearities: Nonlinearities | None = None,
) -> list[TimeResponse]:
    """:func:`simulate` on ``k`` roads at once, ``roads_m`` ``(k, n_t, 4)``: one integrator
    advances every road's states together (one right-hand side evaluation per stage for all,
    the step size the hardest road needs), one :class:`TimeResponse` per road.
    ``nonlinearities`` (nonlinear mode): default :class:`Nonlinearities` (gas and valve laws,
    no tyre lift-off); other arguments as :func:`simulate`."""
    of_type(model, CoupledModel, "model", "a CoupledModel (a problem's model(design))")
    one_of(method, get_args(SolverMethod), "method")
    switches = Nonlinearities() if nonlinearities is None else nonlinearities
    if model.pipe_model != "lumped":
        raise ConfigError(f"time simulation needs pipe_model='lumped', got {model.pipe_model!r}")
    if mode not in ("linear", "nonlinear"):
        raise ConfigError(f"unknown mode {mode!r}; expected 'linear' or 'nonlinear'")
    if mode == "linear" and (valve_kq != 0.0 or switches.tyre_liftoff):
        raise ConfigError("valve_kq and tyre_liftoff need mode='nonlinear'")
    if not valve_kq >= 0.0:
        raise ConfigError(f"expected valve_kq >= 0 [Pa s^2 m^-6], got {valve_kq!r}")
    if not 0.0 < rtol < 1.0:
        raise ConfigError(f"expected 0 < rtol < 1, got {rtol!r}")
    roads = np.asarray(roads_m, dtype=float)
    if roads.ndim != 3 or roads.shape[0] < 1:
        raise ConfigError(f"expected roads_m of shape (k, n_t, 4), got {roads.shape}")
    road = RoadInput(t_s, np.moveaxis(roads, 0, -1), interpolation)
    force = _force_reader(body_force, road.t_s)
    ((_, contracted),) = model.groups()  # a single design: one group
    quadratic = valve_kq > 0.0 or (mode == "nonlinear" and switches.valve_law and has_nonlinear_valve(model))
    if contracted is not model and quadratic:
        raise ModelError(
            "a valve with R_v = 0 between two oil volumes has no linear resistance for the orifice law to start from; "
            "give it R_v > 0 or set valve_kq = 0 (or simulate orifices and damper valves in linear mode)"
        )
    model = contracted  # zero-resistance valves between oil volumes merged (exact shorts)
    ss = model.state_space()
    u_scale = max(float(np.abs(road.z_m).max()), 1e-6)
    from hisopt.evaluation.transient import moment_per_acceleration  # on use: the evaluation layer's convention

    gravity = gravity_moment * G_MPS2 * moment_per_acceleration(model.car)  # [N m/rad]
    # LSODA switches between Adams (non-stiff) and BDF (stiff: chamber or pipe compliance)
    # by itself, and one evaluation per step suits steps capped at the input spacing.
    chosen = "LSODA" if method == "auto" else method
    if mode == "linear":
        return _simulate_linear(model, ss, road, chosen, rtol, u_scale, force, gravity)
    kq = valve_kq if switches.valve_law else 0.0
    return _simulate_nonlinear(model, ss, road, chosen, rtol, u_scale, kq, switches, force, gravity)


def has_nonlinear_valve(model: CoupledModel) -> bool:
    """Whether the model's network has a physical damper valve or an orifice element with a
    quadratic coefficient."""
    if model.his is None:
        return False
    values = model.his.values
    return bool(values.damper) or any(bool(np.any(np.asarray(kq) > 0.0)) for _, kq in values.orifice.values())


def _stacked(n: int, k: int) -> Callable[[np.ndarray], np.ndarray]:
    """The ``(n, k)`` view of a batch's stacked state ``(n k,)`` (state-major)."""
    return lambda y: y.reshape(n, k)


def _block_jacobian(blocks: list[np.ndarray]) -> np.ndarray:
    """The stacked state's Jacobian from each road's ``(n, n)`` block (state-major stacking)."""
    k = len(blocks)
    n = blocks[0].shape[0]
    out = np.zeros((n, k, n, k))
    for j, block in enumerate(blocks):
        out[:, j, :, j] = block
    return out.reshape(n * k, n * k)


def _simulate_linear(
    model: CoupledModel, ss: StateSpace, road: RoadInput, method: str, rtol: float, u_scale: float, force: Callable[[Any], np.ndarray], gravity: float
) -> list[TimeResponse]:
    a, b0, b1 = _linear_matrices(ss)
    a = a.copy()
    inv_mass = 1.0 / np.diag(model.mass)
    a[7 + ROLL_DOF, ROLL_DOF] += gravity * inv_mass[ROLL_DOF]  # the weight's moment as the body rolls
    forcing = b0 + a @ b1  # input matrix of the shifted state x - B1 u
    n, k = a.shape[0], road.z_m.shape[2]
    view = _stacked(n, k)

    def fun(t: float, y: np.ndarray) -> np.ndarray:
        dy = a @ view(y) + forcing @ road.value(t)
        dy[7:14] += (force(t) * inv_mass)[:, None]
        return dy.reshape(-1)

    scales = state_scales(a, b0, b1)
    push = np.zeros(n)
    push[7:14] = np.abs(force(road.t_s)).max(axis=0) * inv_mass
    if np.any(push):  # the force's own static response sets the states' sizes too
        static = np.abs(np.linalg.solve(a, push))
        scales = np.maximum(scales * u_scale, static) / u_scale
    atol = np.repeat(1e-3 * rtol * u_scale * scales, k)
    jac = _block_jacobian([a] * k)
    y = _integrate(fun, np.zeros(n * k), road, method, rtol, atol, lambda t, y: jac).reshape(n, k, -1)
    pushes = np.zeros((n, road.t_s.size))
    pushes[7:14] = (force(road.t_s) * inv_mass).T
    realisation = None if model.his is None or ss.realisation is None else single_design(ss.realisation.full_map(), 2, "realisation")
    out = []
    for j in range(k):
        u, du = road.z_m[..., j].T, road.sampled_rate()[..., j].T
        x = y[:, j] + b1 @ u
        dx = a @ x + b0 @ u + b1 @ du + pushes
        names: tuple[str, ...] = ()
        p = np.zeros((0, x.shape[1]))
        vol = np.zeros_like(p)
        if model.his is not None and realisation is not None:
            acc = accumulators(model.his)
            p = realisation[14 + acc.rows] @ x
            vol = acc.compliance[:, None] * p  # linearised gas law
            names = acc.names
            p = p + acc.p0_gauge[:, None]
        response = _response(model, road, j, x[:7], x[7:14], dx[7:14], p, vol, names, "linear")
        if realisation is not None:
            response = _with_hydraulics(response, model, realisation[14:] @ x)
        out.append(response)
    return out


def _simulate_nonlinear(
    model: CoupledModel,
    ss: StateSpace,
    road: RoadInput,
    method: str,
    rtol: float,
    u_scale: float,
    valve_kq: float,
    switches: Nonlinearities,
    force: Callable[[Any], np.ndarray],
    gravity: float,
) -> list[TimeResponse]:
    net = NonlinearModel(model, valve_kq, switches.tyre_liftoff, gas_law=switches.gas_law, valve_law=switches.valve_law, gravity_moment=gravity)
    a, b0, b1 = _linear_matrices(ss)
    # The nonlinear state is every dynamic unknown of the descriptor: the realisation's T.
    expand = np.eye(a.shape[0]) if ss.realisation is None else single_design(ss.realisation.expand, 2, "realisation")
    scale = state_scales(a, b0, b1, expand) * u_scale
    # Accumulator nodes integrate volume: their typical size is compliance x pressure.
    scale[14 + net.acc_state] *= net.e_dyn[net.acc_state]
    has_ct = bool(np.any(net.ct))
    n, k = net.n_states, road.z_m.shape[2]
    view = _stacked(n, k)
    zeros = np.zeros((4, k))
    inv_mass = (1.0 / np.diag(model.mass))[:, None]

    def fun(t: float, y: np.ndarray) -> np.ndarray:
        du = road.rate(t) if has_ct else zeros
        dy = net.rate(view(y), road.value(t), du)
        dy[7:14] += force(t)[:, None] * inv_mass
        return dy.reshape(-1)

    def jac(t: float, y: np.ndarray) -> np.ndarray:
        u, du, yy = road.value(t), (road.rate(t) if has_ct else zeros), view(y)
        return _block_jacobian([net.jacobian(yy[:, j], u[:, j], du[:, j]) for j in range(k)])

    y = _integrate(fun, np.tile(net.initial_state()[:, None], (1, k)).reshape(-1), road, method, rtol, np.repeat(1e-3 * rtol * scale, k), jac)
    y = y.reshape(n, k, -1)
    if net.gas_law and net.volume_margin(y[14:].reshape(n - 14, k * y.shape[2])) >= GAS_VOLUME_LIMIT * (1.0 - 1e-9):
        raise ModelError("an accumulator bottomed out (oil filled its gas volume): reduce the input or raise V0")
    out = []
    pushes = force(road.t_s).T * inv_mass
    for j in range(k):
        u, du = road.z_m[..., j].T, road.sampled_rate()[..., j].T
        dy, h = net.derivative(y[:, j], u, du)
        dy[7:14] += pushes
        p_nodes = h[net.dyn][net.acc_state]
        p = np.zeros((len(net.acc.names), y.shape[2]))
        vol = np.zeros_like(p)
        for i_node, accs in enumerate(net.node_accs):
            for i in accs:
                p[i] = p_nodes[i_node]
                vol[i] = net.gas_volume(p_nodes[i_node], int(i))
        p = p + net.acc.p0_gauge[:, None]
        response = _response(model, road, j, y[:7, j], y[7:14, j], dy[7:14], p, vol, net.acc.names, "nonlinear")
        if model.his is not None:
            response = _with_hydraulics(response, model, h)
        if switches.tyre_liftoff:  # report the clipped tyre force, as the model applied it
            tyre = -net.tyre_force(y[:7, j], y[7:14, j], u, du).T
            response = replace(response, tyre_force_n=tyre)
        out.append(response)
    return out


def _with_hydraulics(response: TimeResponse, model: CoupledModel, h: np.ndarray) -> TimeResponse:
    """``response`` with each damper valve's flow and drop, each chamber's pressure and each
    strut's fluid force from the descriptor unknowns ``h`` ``(n_h, n_t)`` of ``model``'s network."""
    from hisopt.evaluation.valve_states import valve_labels  # on use: it loads the evaluator

    assert model.his is not None
    his = model.his
    net = his.network
    rows = np.array([r for _, _, r in net.damper_valves()], dtype=int).reshape(-1, 3)
    flow, drop = h[rows[:, 2]].T, (h[rows[:, 0]] - h[rows[:, 1]]).T
    static = single_design(port_values(his, circuit_pressures(his)), 1, "static pressure") - P_ATM_PA
    ports = h[net.port_rows].T + static  # gauge: the atmosphere pushes on the rod's end
    incidence = single_design(np.asarray(his.incidence, dtype=float), 2, "cylinder incidence")
    return replace(
        response,
        valve_flow_m3s=flow,
        valve_drop_pa=drop,
        valve_names=valve_labels(net),
        port_pressure_pa=ports,
        strut_force_n=-ports @ incidence,
    )


def _response(
    model: CoupledModel,
    road: RoadInput,
    column: int,
    x: np.ndarray,
    v: np.ndarray,
    acc: np.ndarray,
    p: np.ndarray,
    vol: np.ndarray,
    names: tuple[str, ...],
    mode: SimulationMode,
) -> TimeResponse:
    """Assemble a :class:`TimeResponse` from ``(7, n_t)`` mechanical histories on road ``column``."""
    veh = model.vehicle
    kt = np.diag(road_stiffness_input(veh)[3:])
    ct = np.diag(road_damping_input(veh)[3:])
    z, dz = road.z_m[..., column], road.sampled_rate()[..., column]
    tyre = kt * (x[3:].T - z) + ct * (v[3:].T - dz)
    return TimeResponse(
        t_s=road.t_s,
        road_m=z,
        displacement=x.T,
        velocity=v.T,
        acceleration=acc.T,
        stroke_m=(stroke_matrix(veh) @ x).T,
        tyre_force_n=tyre,
        accumulator_pressure_pa=p.T,
        accumulator_volume_m3=vol.T,
        accumulator_names=names,
        corners=body_to_corners(veh),
        mode=mode,
    )


__all__ = [
    "BodyForce",
    "Nonlinearities",
    "RoadInput",
    "SimulationMode",
    "SolverMethod",
    "TimeResponse",
    "simulate",
    "simulate_batch",
    "state_scales",
]
