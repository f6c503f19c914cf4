"""Layouts (issue 15, docs/model.md §12): the catalogue against closed forms, custom layouts
in problem files, their validation, and every engine on every layout.

Closed forms (per unit stroke pattern u, FL FR RL RR; ``k = gamma p_abs0 / V``, ``C = V /
(gamma p_abs0)``, per axle ``S = A_t + A_b``, ``dA = A_b - A_t``), written by hand from each
layout's description, not from the network code:

- static stiffness ``u^T K u = sum_c (a_c . u)^2 / C_c`` with each circuit's signed chamber
  areas ``a_c`` (``+A_t`` top, ``-A_b`` bottom) and total compliance ``C_c``;
- low-frequency damping ``u^T C_lf u = sum over valves of R (flow through it per unit
  stroke velocity)^2``: a bottom-chamber valve carries its chamber's flow ``A_b``, an
  accumulator valve the circuit's net flow ``a_c . u``, a link valve between two
  accumulators ``(C_r a_f - C_f a_r) . u / (C_f + C_r)``.
"""

from __future__ import annotations

import numpy as np
import pytest

import hisopt
from hisopt.hydraulics.catalogue import CATALOGUE_NAMES, catalogue, his_parameter_values
from hisopt.hydraulics.coupling import HydraulicSystem
from hisopt.hydraulics.layout import Accumulator
from hisopt.hydraulics.network import compile_network
from hisopt.hydraulics.roll_plane import roll_plane_layout
from hisopt.problem import problem_from_dict
from hisopt.studies.layout_cases import catalogue_case
from hisopt.studies.screening import STROKE_PATTERNS, mode_stiffness, pattern_matrix
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT

P_ATM = 101325.0
PATTERNS = list(STROKE_PATTERNS)


def random_parameters(rng: np.random.Generator) -> dict[str, float]:
    """Random values of every parameter a catalogue layout reads (front and rear differ)."""
    return {
        "p0": rng.uniform(0.0, 4e6), "V0": rng.uniform(0.3e-3, 2e-3), "gamma": rng.uniform(1.0, 1.4),
        "dA": rng.uniform(1e-4, 25e-4), "lam": rng.uniform(0.1, 0.8), "dA_rear": rng.uniform(1e-4, 25e-4),
        "lam_rear": rng.uniform(0.1, 0.8), "Rv": rng.uniform(0.0, 2e6), "Rv_rear": rng.uniform(0.0, 2e6),
        "Rv_acc": rng.uniform(1e6, 1e9), "Rv_link": rng.uniform(1e6, 1e9),
        "V0_front": rng.uniform(0.2e-3, 1e-3), "V0_rear": rng.uniform(0.2e-3, 1e-3),
    }  # fmt: skip


def system(name: str, params: dict[str, float]) -> HydraulicSystem:
    values = {**params, "rho": 870.0, "mu": 0.03, "beta": 1.5e9}
    return HydraulicSystem(compile_network(catalogue()[name].layout(), "lumped"), values)


def closed_form(name: str, p: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """(stiffness, damping) per unit stroke pattern [N/m], [N s/m] (module docstring)."""
    ab_f, ab_r = p["dA"] / (1 - p["lam"]), p["dA_rear"] / (1 - p["lam_rear"])
    at_f, at_r = p["lam"] * ab_f, p["lam_rear"] * ab_r
    comp = lambda v: v / (p["gamma"] * (p["p0"] + P_ATM))  # noqa: E731
    u = pattern_matrix()
    # bottom-chamber valves carry their chamber's flow A_b on every wheel with a bottom valve
    bottom = np.array([p["Rv"] * ab_f**2, p["Rv"] * ab_f**2, p["Rv_rear"] * ab_r**2, p["Rv_rear"] * ab_r**2])
    a_a, a_b = np.array([at_f, -ab_f, at_r, -ab_r]), np.array([-ab_f, at_f, -ab_r, at_r])  # roll-plane circuits
    links = []  # (resistance, flow per unit velocity: a vector over the wheels)
    if name in ("roll_plane", "roll_plane_accumulator_valves"):
        circuits = [(a_a, comp(p["V0"])), (a_b, comp(p["V0"]))]
        if name == "roll_plane_accumulator_valves":
            links = [(p["Rv_acc"], a_a), (p["Rv_acc"], a_b)]
    elif name == "roll_plane_twin_accumulator":
        c_f, c_r = comp(p["V0_front"]), comp(p["V0_rear"])
        circuits = [(a_a, c_f + c_r), (a_b, c_f + c_r)]
        for a in (a_a, a_b):
            a_front, a_rear = a * [1, 1, 0, 0], a * [0, 0, 1, 1]
            links.append((p["Rv_link"], (c_r * a_front - c_f * a_rear) / (c_f + c_r)))
    elif name == "pitch_plane":
        circuits = [(np.array([at_f, at_f, -ab_r, -ab_r]), comp(p["V0"])), (np.array([-ab_f, -ab_f, at_r, at_r]), comp(p["V0"]))]
    elif name == "axle_roll":
        circuits = [(a * mask, comp(p["V0"])) for a in (a_a, a_b) for mask in (np.array([1, 1, 0, 0]), np.array([0, 0, 1, 1]))]
    elif name == "side_front_rear":
        c = comp(p["V0"])
        left, right = np.array([-ab_f, 0, -ab_r, 0]), np.array([0, -ab_f, 0, -ab_r])
        circuits = [(left, 2 * c), (right, 2 * c)]
        links = [(p["Rv_link"], (a * [1, 1, 0, 0] - a * [0, 0, 1, 1]) / 2) for a in (left, right)]
    else:
        raise AssertionError(name)
    stiffness = np.array([sum((a @ uk) ** 2 / cc for a, cc in circuits) for uk in u])
    damping = np.array([bottom @ uk**2 + sum(r * (f @ uk) ** 2 for r, f in links) for uk in u])
    return stiffness, damping


# --- closed forms ------------------------------------------------------------------------------
@pytest.mark.parametrize("name", CATALOGUE_NAMES)
def test_mode_stiffness_and_damping_equal_the_closed_form_for_random_parameters(name):
    rng = np.random.default_rng(CATALOGUE_NAMES.index(name))
    u = pattern_matrix()
    for _ in range(12):
        p = random_parameters(rng)
        his = system(name, p)
        k = np.diag(u @ his.static_stiffness() @ u.T)
        c = np.diag(u @ his.low_frequency_damping() @ u.T)
        k_ref, c_ref = closed_form(name, p)
        scale_k, scale_c = np.abs(k_ref).max(), np.abs(c_ref).max()
        np.testing.assert_allclose(k, k_ref, rtol=1e-12, atol=1e-12 * scale_k, err_msg=name)
        np.testing.assert_allclose(c, c_ref, rtol=1e-10, atol=1e-12 * scale_c, err_msg=name)


def test_closed_forms_with_equal_axles_are_the_issues_statements():
    """roll_plane adds 2 k (2 S)^2 to roll and nothing to pitch or warp; pitch_plane the
    converse for pitch and roll; axle_roll adds to roll and warp alike."""
    p = random_parameters(np.random.default_rng(5)) | {"dA_rear": 7e-4, "lam_rear": 0.4, "dA": 7e-4, "lam": 0.4}
    k_acc = p["gamma"] * (p["p0"] + P_ATM) / p["V0"]
    s = p["dA"] / (1 - p["lam"]) * (1 + p["lam"])
    u = pattern_matrix()
    k = {n: dict(zip(PATTERNS, np.diag(u @ system(n, p).static_stiffness() @ u.T), strict=True)) for n in CATALOGUE_NAMES}
    assert k["roll_plane"]["roll"] == pytest.approx(2 * k_acc * (2 * s) ** 2, rel=1e-12)
    assert k["roll_plane"]["bounce"] == pytest.approx(2 * k_acc * (2 * p["dA"]) ** 2, rel=1e-12)
    assert abs(k["roll_plane"]["pitch"]) < 1e-9 * k["roll_plane"]["roll"] and abs(k["roll_plane"]["warp"]) < 1e-9 * k["roll_plane"]["roll"]
    assert k["pitch_plane"]["pitch"] == pytest.approx(2 * k_acc * (2 * s) ** 2, rel=1e-12)
    assert abs(k["pitch_plane"]["roll"]) < 1e-9 * k["pitch_plane"]["pitch"] and abs(k["pitch_plane"]["warp"]) < 1e-9 * k["pitch_plane"]["pitch"]
    assert k["axle_roll"]["roll"] == pytest.approx(4 * k_acc * s**2, rel=1e-12)
    assert k["axle_roll"]["warp"] == pytest.approx(k["axle_roll"]["roll"], rel=1e-12)


@pytest.mark.parametrize("name", CATALOGUE_NAMES)
def test_low_frequency_damping_is_the_limit_of_im_d_over_omega(name):
    """The bordered solve against the network's own D(j omega) at small omega, with pipes and
    chamber volumes (the catalogue's pipe and chamber transformation)."""
    p = random_parameters(np.random.default_rng(3)) | {
        "pipe_diameter": 0.011, "pipe_length_front": 1.2, "pipe_length_rear": 2.7, "chamber_volume": 1.5e-4,
        "rho": 870.0, "mu": 0.03, "beta": 1.5e9,
    }  # fmt: skip
    his = HydraulicSystem(compile_network(catalogue()[name].layout(pipes=True, chamber=True), "lumped"), p)
    c = his.low_frequency_damping()
    d = his.stroke_impedance(np.array([1e-3j, 2e-3j]))
    slope = (d[1].imag / 2e-3 - d[0].imag / 1e-3) / 3e-6  # the O(omega^2) term, fitted out
    np.testing.assert_allclose(d[0].imag / 1e-3 - slope * 1e-6, c, rtol=1e-8, atol=1e-8 * np.abs(c).max())
    k0 = (4 * d[0].real - d[1].real) / 3  # K - M omega^2, the omega^2 term fitted out
    np.testing.assert_allclose(k0, his.static_stiffness(), rtol=1e-9, atol=1e-9 * np.abs(his.static_stiffness()).max())


def test_pipes_and_chamber_volumes_join_each_circuit_compliance():
    """With [his.pipes] and chamber volumes a circuit's static compliance also holds every
    pipe's and chamber's oil: K = sum_c a_c a_c^T / (C_acc + sum A_pipe l / beta + n V_ch / beta)."""
    p = random_parameters(np.random.default_rng(8)) | {
        "pipe_diameter": 0.012, "pipe_length_front": 1.1, "pipe_length_rear": 2.9, "chamber_volume": 2e-4,
        "rho": 870.0, "mu": 0.03, "beta": 1.5e9, "dA_rear": 0.0, "lam_rear": 0.0,
    }  # fmt: skip
    p["dA_rear"], p["lam_rear"] = p["dA"], p["lam"]
    his = HydraulicSystem(compile_network(catalogue()["pitch_plane"].layout(pipes=True, chamber=True), "lumped"), p)
    ab = p["dA"] / (1 - p["lam"])
    at = p["lam"] * ab
    pipe = np.pi * 0.012**2 / 4 / 1.5e9
    c_c = p["V0"] / (p["gamma"] * (p["p0"] + P_ATM)) + pipe * (2 * 1.1 + 2 * 2.9) + 4 * 2e-4 / 1.5e9
    u = pattern_matrix()
    k = np.diag(u @ his.static_stiffness() @ u.T)
    np.testing.assert_allclose(k[2], 2 * (2 * (at + ab)) ** 2 / c_c, rtol=1e-12)  # pitch
    np.testing.assert_allclose(k[0], 2 * (2 * p["dA"]) ** 2 / c_c, rtol=1e-12)  # bounce


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_accumulator_valve_is_a_damper_in_parallel_with_the_gas_spring(seed):
    """docs/model.md §12.3: with incompressible oil the accumulator valve and the gas spring
    carry the same flow, so their pressures add: per unit stroke pattern the dynamic stiffness
    is the closed form's ``k + j omega c`` at every frequency (Kelvin-Voigt; the valve never
    cuts the gas spring off). The network's D(j omega) comes from solving a few nodes per
    frequency, conditioned at most ~omega Rv_acc C_acc <= 1e3 here: ~1e-13 relative, so 1e-10."""
    p = random_parameters(np.random.default_rng(40 + seed))
    his = system("roll_plane_accumulator_valves", p)
    k, c = closed_form("roll_plane_accumulator_valves", p)
    omega = 2 * np.pi * np.geomspace(0.01, 1000.0, 25)
    u = pattern_matrix()
    d = np.einsum("pi,fij,pj->fp", u, his.stroke_impedance(1j * omega), u)
    want = k[None, :] + 1j * omega[:, None] * c[None, :]
    np.testing.assert_allclose(d, want, rtol=1e-10, atol=1e-10 * np.abs(want).max())


def test_gas_volume_of_each_catalogue_layout():
    """docs/model.md §15.1: two accumulators of V0 in roll_plane, its accumulator-valve
    variant and pitch_plane; the twin layout's four halves add up to the same (V0_front +
    V0_rear per circuit); axle_roll and side_front_rear carry four accumulators of V0, twice the
    gas, each as its description says."""
    p = random_parameters(np.random.default_rng(9))
    want = {
        "roll_plane": 2 * p["V0"],
        "roll_plane_accumulator_valves": 2 * p["V0"],
        "pitch_plane": 2 * p["V0"],
        "roll_plane_twin_accumulator": 2 * (p["V0_front"] + p["V0_rear"]),
        "axle_roll": 4 * p["V0"],
        "side_front_rear": 4 * p["V0"],
    }
    for name in CATALOGUE_NAMES:
        volumes = [e.volume for c in catalogue()[name].layout().circuits for e in c.elements if isinstance(e, Accumulator)]
        assert sum(p[v] if isinstance(v, str) else v for v in volumes) == pytest.approx(want[name], rel=1e-15), name


# --- the car: modes --------------------------------------------------------------------------------
def _frequencies(problem: hisopt.Problem, his: bool = True) -> dict[str, float]:
    modes = hisopt.modal_analysis(problem, his=his)
    return dict(zip(modes["mode"], modes["frequency_hz"], strict=True))


def test_pitch_plane_leaves_roll_and_raises_pitch_roll_plane_the_converse():
    """On the default car pitch_plane leaves the roll frequency within 2 % and raises pitch.
    roll_plane raises roll; its pitch stroke stiffness is zero, but on this car (l_f != l_r)
    body pitch also moves the bounce pattern, which roll_plane stiffens (docs/model.md §3.6),
    and the pitch mode falls 8 %; on a car with the axles equally far from the CG it stays
    within 2 %."""
    default = hisopt.load_problem(DEFAULT_PROBLEM)
    ref = _frequencies(default, his=False)
    pitch = _frequencies(default.with_values(layout="pitch_plane"))
    roll = _frequencies(default)
    assert abs(pitch["roll"] / ref["roll"] - 1) < 0.02 and pitch["pitch"] > 1.3 * ref["pitch"]
    assert roll["roll"] > 1.3 * ref["roll"] and roll["pitch"] == pytest.approx(0.917 * ref["pitch"], rel=0.01)
    data = default.spec.model_dump(by_alias=True)
    data["vehicle"] |= {"l_f": 1.3, "l_r": 1.3}
    balanced = problem_from_dict(data)
    ref_b, roll_b, pitch_b = _frequencies(balanced, his=False), _frequencies(balanced), _frequencies(balanced.with_values(layout="pitch_plane"))
    assert abs(roll_b["pitch"] / ref_b["pitch"] - 1) < 0.02 and roll_b["roll"] > 1.3 * ref_b["roll"]
    assert abs(pitch_b["roll"] / ref_b["roll"] - 1) < 0.02 and pitch_b["pitch"] > 1.3 * ref_b["pitch"]


# --- custom layouts ----------------------------------------------------------------------------
def test_catalogue_data_file_of_roll_plane_is_the_builders_layout():
    assert catalogue()["roll_plane"].base == roll_plane_layout()
    for pipes in (False, True):
        for chamber in (False, True):
            assert catalogue()["roll_plane"].layout(pipes, chamber) == roll_plane_layout(pipes, chamber)


def test_custom_roll_plane_gives_identical_objectives():
    catalogue_problem = hisopt.load_problem(DEFAULT_PROBLEM)
    custom = hisopt.load_problem(ROOT / "problems" / "layout_custom_roll_plane.toml")
    assert custom.spec.his.layout == "custom" and custom.layout().circuits == catalogue_problem.layout().circuits
    rng = np.random.default_rng(4)
    x = np.vstack([catalogue_problem.baseline, catalogue_problem.lower + (catalogue_problem.upper - catalogue_problem.lower) * rng.random((5, 4))])
    a, b = catalogue_problem.evaluate(x), custom.evaluate(x)
    for name in catalogue_problem.objective_names:
        np.testing.assert_array_equal(a[name].to_numpy(), b[name].to_numpy())


def custom_problem(circuits: list[dict], parameters: dict | None = None, variables: dict | None = None) -> hisopt.Problem:
    data = hisopt.load_problem(DEFAULT_PROBLEM).spec.model_dump(by_alias=True)
    data["his"] |= {"layout": "custom", "circuits": circuits, "parameters": parameters or {}}
    if not any(e.get("resistance") == "Rv" for c in circuits for e in c["elements"]):
        del data["variables"]["Rv"]  # a variable the layout does not read is refused
    data["variables"] |= variables or {}
    return problem_from_dict(data)


def _circuit(name: str, chambers: dict[str, str], elements: list[dict]) -> dict:
    nodes = list(dict.fromkeys([*chambers.values(), *[n for e in elements for n in (e.get("node"), e.get("from"), e.get("to")) if n]]))
    return {"name": name, "nodes": nodes, "chambers": chambers, "elements": elements}


def test_any_element_parameter_can_be_a_design_variable():
    """A custom layout's accumulator precharge and pipe diameter as design variables: their
    rules come from the element fields (a precharge >= 0, a diameter > 0) and the derivative
    of the static stiffness with the precharge is the closed form's."""
    circuits = [
        _circuit("A", {"1t": "A", "2b": "A.2b", "3t": "A", "4b": "A.4b"}, [
            {"type": "accumulator", "node": "A", "precharge": "p_A"},
            {"type": "valve", "from": "A.2b", "to": "A", "resistance": "Rv"},
            {"type": "pipe", "from": "A.4b", "to": "A", "length": 2.5, "diameter": "d_rear"},
        ]),
        _circuit("B", {"1b": "B.1b", "2t": "B", "3b": "B.3b", "4t": "B"}, [
            {"type": "accumulator", "node": "B"},
            {"type": "valve", "from": "B.1b", "to": "B", "resistance": "Rv"},
            {"type": "pipe", "from": "B.3b", "to": "B", "length": 2.5, "diameter": "d_rear"},
        ]),
    ]  # fmt: skip
    variables = {"p_A": {"lower": 0.0, "upper": 4e6}, "d_rear": {"lower": 0.006, "upper": 0.02}}
    p = custom_problem(circuits, {"p_A": 1.5e6, "d_rear": 0.012}, variables)
    assert p.variable_names[-2:] == ("p_A", "d_rear") and p.baseline[-2:].tolist() == [1.5e6, 0.012]
    assert p.parameter_rule("p_A").text == "p_A >= 0" and p.parameter_rule("d_rear").text == "d_rear > 0"
    x = np.vstack([p.baseline, p.baseline])
    x[1, -2] = 3.0e6
    df = p.evaluate(x)
    assert df["status"].tolist() == ["ok", "ok"] and df["sigma_aw"].iloc[0] != df["sigma_aw"].iloc[1]
    bad = p.evaluate(np.vstack([p.baseline * [1, 1, 1, 1, 1, -1]]), log=False)
    assert bad["status"].tolist() == ["invalid"] and "d_rear = -0.012 breaks d_rear > 0" in bad["reason"].iloc[0]
    from hisopt.units import variable_units

    assert variable_units(p)["p_A"] == "Pa" and variable_units(p)["d_rear"] == "m"


def test_orifice_linear_resistance_is_its_statistical_linearisation():
    """An orifice's frequency-domain resistance is R + 2 sqrt(2/pi) K_q q_rms: the valve of the
    same resistance gives the same model, and its damping on a bottom line is R_eq A_b^2."""
    kq, q_rms, r = 3e11, 2e-4, 2e5
    r_eq = r + 2 * np.sqrt(2 / np.pi) * kq * q_rms
    # E[(K_q q|q| - c q)^2] is least at c = r_eq - r for Gaussian q (sampled check)
    q = np.random.default_rng(2).normal(0.0, q_rms, 400_000)
    c_fit = np.sum(kq * q * np.abs(q) * q) / np.sum(q * q)
    assert c_fit == pytest.approx(r_eq - r, rel=1e-2)

    def layout(bottom: dict) -> list[dict]:
        return [
            _circuit("A", {"1t": "A", "2b": "A.2b", "3t": "A", "4b": "A.4b"}, [
                {"type": "accumulator", "node": "A"}, {**bottom, "from": "A.2b", "to": "A"}, {**bottom, "from": "A.4b", "to": "A"}]),
            _circuit("B", {"1b": "B.1b", "2t": "B", "3b": "B.3b", "4t": "B"}, [
                {"type": "accumulator", "node": "B"}, {**bottom, "from": "B.1b", "to": "B"}, {**bottom, "from": "B.3b", "to": "B"}]),
        ]  # fmt: skip

    orifice = custom_problem(layout({"type": "orifice", "resistance": r, "kq": kq, "flow_rms": q_rms}))
    valve = custom_problem(layout({"type": "valve", "resistance": r_eq}))
    a, b = orifice.evaluate(orifice.baseline), valve.evaluate(valve.baseline)
    for name in orifice.objective_names:
        assert a[name].iloc[0] == pytest.approx(b[name].iloc[0], rel=1e-12)
    c = orifice.hydraulic_system({}).low_frequency_damping()
    assert c[0, 0] == pytest.approx(r_eq * (10e-4 / 0.5) ** 2, rel=1e-12)


def test_orifice_in_the_nonlinear_time_domain_is_the_valve_law_with_its_own_kq():
    """An orifice (R, K_q) in the nonlinear model equals a plain valve R with the global
    valve_kq = K_q (same equations, other code path); with K_q = 0 it is the linear model."""
    from hisopt.road import step_profile
    from hisopt.simulation.timedomain import simulate

    kq = 4e11

    def layout(bottom: dict) -> list[dict]:
        return [
            _circuit("A", {"1t": "A", "2b": "A.2b", "3t": "A", "4b": "A.4b"}, [
                {"type": "accumulator", "node": "A"}, {**bottom, "from": "A.2b", "to": "A"}, {**bottom, "from": "A.4b", "to": "A"}]),
            _circuit("B", {"1b": "B.1b", "2t": "B", "3b": "B.3b", "4t": "B"}, [
                {"type": "accumulator", "node": "B"}, {**bottom, "from": "B.1b", "to": "B"}, {**bottom, "from": "B.3b", "to": "B"}]),
        ]  # fmt: skip

    t = np.linspace(0.0, 1.5, 601)
    road = step_profile(t, 0.02, t0_s=0.1, wheels=("fl",), rise_time_s=0.05)
    valve = custom_problem(layout({"type": "valve", "resistance": 8e5})).model()
    orifice = custom_problem(layout({"type": "orifice", "resistance": 8e5, "kq": kq})).model()
    linear_orifice = custom_problem(layout({"type": "orifice", "resistance": 8e5, "kq": 0.0})).model()
    a = simulate(orifice, t, road, "nonlinear", rtol=1e-9).to_frame()
    b = simulate(valve, t, road, "nonlinear", valve_kq=kq, rtol=1e-9).to_frame()
    c = simulate(linear_orifice, t, road, "nonlinear", rtol=1e-9).to_frame()
    d = simulate(valve, t, road, "nonlinear", rtol=1e-9).to_frame()
    for col in ("z_s", "phi", "theta", "z_u1"):
        np.testing.assert_allclose(a[col], b[col], rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(c[col], d[col], rtol=1e-6, atol=1e-9)
    assert np.abs(a["phi"] - c["phi"]).max() > 1e-3 * np.abs(c["phi"]).max()  # the orifice law acts


# --- a layout's extra parameters ---------------------------------------------------------------
def test_layout_parameters_default_from_the_catalogue_and_can_be_variables(tmp_path):
    p = hisopt.load_problem(ROOT / "problems" / "layout_roll_plane_accumulator_valves.toml")
    assert "Rv_acc" in p.variable_names and p.parameter_rule("Rv_acc").text == "Rv_acc >= 0"
    q = p.with_values(Rv_acc=3e8)  # --set reaches [his.parameters]
    assert q.spec.his.parameters["Rv_acc"] == 3e8 and q.baseline[p.variable_names.index("Rv_acc")] == 3e8
    out = run_cli("evaluate", ROOT / "problems" / "layout_roll_plane_accumulator_valves.toml", "--set", "Rv_acc=0")
    assert out.code == 0, out.stderr
    default = hisopt.load_problem(DEFAULT_PROBLEM).evaluate(hisopt.load_problem(DEFAULT_PROBLEM).baseline)
    shown = float(out.stdout.split("sigma_aw [m/s^2]")[1].split("│")[1])
    assert shown == pytest.approx(default["sigma_aw"].iloc[0], rel=1e-3)  # Rv_acc = 0: the paper's layout


def test_mode_stiffness_table_has_units_and_every_layout():
    table = mode_stiffness()
    assert table["layout"].tolist() == list(CATALOGUE_NAMES)
    assert table.attrs["units"]["k_roll"] == "N/m" and table.attrs["units"]["c_warp"] == "N s/m"
    roll = table.set_index("layout")
    assert roll.loc["pitch_plane", "k_roll"] == 0.0 and roll.loc["roll_plane", "k_pitch"] == 0.0
    assert roll.loc["roll_plane", "k_roll"] == pytest.approx(211_814, rel=1e-4)  # 2 k (2 S)^2 at the default
    custom = mode_stiffness(hisopt.load_problem(ROOT / "problems" / "layout_custom_roll_plane.toml"))
    assert custom["layout"].iloc[-1] == "custom"
    np.testing.assert_allclose(custom.iloc[-1][["k_bounce", "k_roll", "c_roll"]].to_numpy(dtype=float),
                               custom.iloc[0][["k_bounce", "k_roll", "c_roll"]].to_numpy(dtype=float), rtol=1e-12)  # fmt: skip


def test_hisopt_layouts_prints_the_table_with_units():
    out = run_cli("layouts")
    assert out.code == 0, out.stderr
    for name in CATALOGUE_NAMES:
        assert name in out.stdout
    assert "[kN/m]" in out.stdout and "[N s/m]" in out.stdout and "211.8" in out.stdout
    own = run_cli("layouts", ROOT / "problems" / "layout_custom_roll_plane.toml")
    assert own.code == 0 and "custom" in own.stdout


def test_hisopt_layouts_on_a_charged_problem_is_its_models_stiffness():
    # issue 40: the envelope problem's HIS is charged ([his.charge]): at its own load case
    # (20 C = the charge temperature, unladen, X = 0) each circuit sits at its charge
    # pressure p_c = p0_abs / phi with gas V = phi V0 in each accumulator, so by hand
    # C = V / (gamma p_c) = phi^2 V0 / (gamma p0_abs) and (lumped pipes, no other compliance)
    # k_roll = 2 (2 S)^2 / C, k_bounce = 2 (2 dA)^2 / C with S = A_t + A_b (module docstring).
    path = ROOT / "problems" / "roll_plane_his_envelope.toml"
    with pytest.warns(hisopt.PlausibilityWarning):  # its -20 C case's extrapolated viscosity
        problem = hisopt.load_problem(path)
    his = problem.spec.his
    phi, p0_abs = his.charge.gas_fraction, his.p0 + P_ATM
    compliance = phi**2 * his.V0 / (his.gamma * p0_abs)
    a_b = his.dA / (1.0 - his.lam)
    by_hand = {"k_roll": 2 * (2 * (his.lam * a_b + a_b)) ** 2 / compliance, "k_bounce": 2 * (2 * his.dA) ** 2 / compliance}
    table = mode_stiffness(problem).set_index("layout")
    for name, value in by_hand.items():
        assert table.loc["roll_plane", name] == pytest.approx(value, rel=1e-9)
    assert table.loc["roll_plane", "k_roll"] == pytest.approx(432_273, rel=1e-5)  # twice the uncharged 211.8 kN/m: phi^2 ~ 1/2
    # the stiffness of the model the evaluator builds (its K_his) for every layout of the table
    u = pattern_matrix()
    for name in ("roll_plane", "axle_roll"):
        space = problem if name == his.layout else catalogue_case(problem, name).problem
        k_his = u @ np.asarray(space.model().his.static_stiffness())[0] @ u.T
        np.testing.assert_allclose(table.loc[name, [f"k_{p}" for p in PATTERNS]].to_numpy(dtype=float), np.diag(k_his), rtol=1e-12)
    out = run_cli("layouts", path)
    assert out.code == 0, out.stderr
    assert "432.3" in out.stdout and "211.8" not in out.stdout
    # an uncharged problem keeps the precharge's stiffness: C = V0 / (gamma p0_abs)
    plain = mode_stiffness(hisopt.load_problem(ROOT / "problems" / "roll_plane_his_handling.toml")).set_index("layout")
    assert plain.loc["roll_plane", "k_roll"] == pytest.approx(2 * (2 * (0.5 * 20e-4 + 20e-4)) ** 2 * 1.4 * (2e6 + P_ATM) / 1e-3, rel=1e-9)


# --- every layout through the engines ---------------------------------------------------------
LAYOUT_FILES = sorted((ROOT / "problems").glob("layout_*.toml"))


def test_one_problem_file_per_catalogue_layout():
    layouts = {hisopt.load_problem(f).spec.his.layout for f in LAYOUT_FILES} | {hisopt.load_problem(DEFAULT_PROBLEM).spec.his.layout}
    assert set(CATALOGUE_NAMES) | {"custom"} == layouts


@pytest.mark.parametrize("path", LAYOUT_FILES, ids=[f.stem for f in LAYOUT_FILES])
def test_layout_problem_files_evaluate_and_optimize(path, tmp_path):
    from hisopt.optim.run import optimize

    p = hisopt.load_problem(path)
    df = p.evaluate(p.baseline)
    assert df["status"].iloc[0] == "ok" and np.isfinite(df[list(p.objective_names)].to_numpy()).all()
    run = optimize(p, pop_size=8, generations=2, seed=1)
    assert len(run.front) >= 1


@pytest.mark.parametrize("name", ["roll_plane_twin_accumulator", "side_front_rear"])
def test_sweep_regions_response_and_drop_tests_on_a_layout(name):
    from hisopt.simulation.droptest import run_drop_tests
    from hisopt.studies.spectra import response_spectra
    from hisopt.studies.sweeps import regions, sweep

    p = hisopt.load_problem(ROOT / "problems" / f"layout_{name}.toml")
    s = sweep(p, "Rv_link", 4)
    assert np.isfinite(s.to_frame().select_dtypes("number").to_numpy()).all()
    r = regions(p, ("p0", "Rv_link"), 3)
    assert len(r.to_frame()) == 9
    spectra = response_spectra(p).frame
    assert np.isfinite(spectra.select_dtypes("number").to_numpy()).all()
    tests = run_drop_tests(p, [2e6], 0.03)
    assert all(np.isfinite(t.row()["frequency_time_hz"]) for t in tests)


def test_layout_schematic_draws_every_chamber_and_element():
    from hisopt.report.schematic import layout_schematic

    for name in CATALOGUE_NAMES:
        p = hisopt.load_problem(DEFAULT_PROBLEM).with_values(layout=name)
        fig = layout_schematic(p.layout(), his_parameter_values(p.spec.his))
        traces = {t.name: t for t in fig.data if t.name}
        layout = p.layout()
        assert len(traces["chamber"].x) == len(layout.ports)
        n_acc = sum(type(e).__name__ == "Accumulator" for c in layout.circuits for e in c.elements)
        n_valve = sum(type(e).__name__ == "Valve" for c in layout.circuits for e in c.elements)
        assert len(traces["accumulator"].x) == n_acc and len(traces["valve"].x) == n_valve
        assert all(f"circuit {c.name}" in traces for c in layout.circuits)
        assert any("p0 = 2 MPa" in text for text in traces["accumulator"].text)


# --- bad layouts: one clear line, exit 2 -----------------------------------------------------------
CUSTOM_TEXT = (ROOT / "problems" / "layout_custom_roll_plane.toml").read_text(encoding="utf-8")
B_ACC = '    { type = "accumulator", node = "B", volume = "V0", precharge = "p0", gamma = "gamma" },\n'
B_RR = '{ type = "valve", from = "B.3b", to = "B", resistance = "Rv_rear" }'
BAD_LAYOUTS: dict[str, tuple[list[tuple[str, str]], str]] = {
    "chamber used twice": ([('2t = "B"', '2b = "B"')],
        "his.circuits: chamber '2b' is used by circuit 'A' and again by circuit 'B'; expected each chamber in at most one circuit"),
    "open circuit": ([(B_ACC, "")], "his.circuits.1: circuit 'B': has no compliance (accumulator, pipe or oil volume)"),
    "unknown node": ([(B_RR, B_RR.replace('to = "B"', 'to = "C"'))],
        "his.circuits.1: circuit 'B': valve 'B.3b' -> 'C': unknown node 'C'; expected one of the declared nodes B.1b, B, B.3b"),
    "unknown variable": ([(B_RR, B_RR.replace("Rv_rear", "Rv_back"))],
        "his.circuits: circuit 'B', valve 'B.3b' -> 'B': resistance refers to the unknown parameter 'Rv_back'; expected a number, a [his] value"),
    "dangling element": ([('nodes = ["B.1b", "B", "B.3b"]', 'nodes = ["B.1b", "B", "B.3b", "B.x"]'),
                          (B_ACC, B_ACC + '    { type = "valve", from = "B", to = "B.x" , resistance = "Rv" },\n')],
        "his.circuits.1: circuit 'B': valve 'B' -> 'B.x' dangles: nothing else connects to node 'B.x'"),
    "unused node": ([('nodes = ["B.1b", "B", "B.3b"]', 'nodes = ["B.1b", "B", "B.3b", "B.x"]')], "node 'B.x' is declared but nothing connects to it"),
    "two parts": ([('nodes = ["B.1b", "B", "B.3b"]', 'nodes = ["B.1b", "B", "B.3b", "B.y", "B.z"]'),
                   (B_ACC, B_ACC + '    { type = "valve", from = "B.y", to = "B.z" , resistance = "Rv" },\n'
                            '    { type = "accumulator", node = "B.y" },\n    { type = "accumulator", node = "B.z" },\n')],
        "falls apart into unconnected parts {B.1b, B, B.3b} and {B.y, B.z}; expected one connected circuit"),
    "unknown chamber": ([('chambers = { 1b = "B.1b"', 'chambers = { 5b = "B.1b"')], "unknown chamber '5b' in chambers; expected one of 1t, 1b"),
    "valve with a volume": ([(B_RR, B_RR.replace("resistance", "volume"))], "his.circuits.1.elements.2: a valve takes from, to, resistance; got 'volume'"),
    "negative number": ([(B_RR, B_RR.replace('"Rv_rear"', "-5.0"))], "resistance: expected resistance >= 0 for a valve, got -5.0"),
    "unknown type": ([('{ type = "valve", from = "B.3b"', '{ type = "damper", from = "B.3b"')],
        "his.circuits.1.elements.2.type: expected 'accumulator', 'compliance'"),
    "circuits without custom": ([('layout = "custom"', 'layout = "roll_plane"')],
        "his.circuits: circuits are given but layout = 'roll_plane'; expected layout = \"custom\""),
    "unknown layout": ([('layout = "custom"', 'layout = "roll_planar"')], "his.layout: unknown layout 'roll_planar'; expected one of roll_plane, "),
    "parameter not read": ([('layout = "custom"', 'layout = "custom"\nparameters = { Rv_acc = 1e8 }')], "his.parameters.Rv_acc: not read by layout 'custom'"),
    "parameter named like a [his] value": ([('layout = "custom"', 'layout = "custom"\nparameters = { V0 = 1e-3 }')],
        "his.parameters.V0: 'V0' is a [his] value; set it in [his] itself"),
}  # fmt: skip


@pytest.mark.parametrize("case", BAD_LAYOUTS, ids=list(BAD_LAYOUTS))
def test_bad_custom_layouts_give_one_clear_line_and_exit_2(case, tmp_path):
    edits, expected = BAD_LAYOUTS[case]
    text = CUSTOM_TEXT
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    path = tmp_path / "bad.toml"
    path.write_text(text, encoding="utf-8")
    out = run_cli("evaluate", path)
    assert out.code == 2, out
    assert len(out.error_lines) == 1 and "Traceback" not in out.stderr, out.stderr
    assert out.error_lines[0].startswith(f"error: {path}: ") and expected in out.error_lines[0], out.error_lines[0]


def test_design_variables_of_a_layout_are_checked_against_it(tmp_path):
    text = (ROOT / "problems" / "layout_roll_plane_twin_accumulator.toml").read_text(encoding="utf-8")
    path = tmp_path / "twin.toml"
    path.write_text(text.replace("Rv_link = { lower = 1.0e6", "V0 = { lower = 1e-4, upper = 1e-3 }\nRv_link = { lower = 1.0e6"), encoding="utf-8")
    out = run_cli("evaluate", path)
    assert out.code == 2 and out.error_lines == [
        f"error: {path}: variables.V0: not read by layout 'roll_plane_twin_accumulator', so it would do nothing; "
        "expected one of p0, dA, lam, Rv, dA_rear, lam_rear, Rv_rear, bore, rod, bore_rear, rod_rear, gamma, V0_front, V0_rear, Rv_link"
    ]
    path.write_text(text.replace("Rv_link = { lower = 1.0e6", "Rv_link = { lower = -1.0e6"), encoding="utf-8")
    out = run_cli("evaluate", path)
    assert out.code == 2 and "variables.Rv_link: expected bounds inside the parameter's range Rv_link >= 0, got lower bound -1e+06" in out.stderr
    path.write_text(text.replace("Rv_link = 5.0e8   #", "Rv_link = -5.0e8   #"), encoding="utf-8")
    out = run_cli("evaluate", path)
    assert out.code == 2 and "his.parameters.Rv_link: expected Rv_link >= 0 (it is the resistance of a valve), got -5e+08" in out.stderr


def test_readme_custom_layout_example_is_valid():
    """README's custom-layout TOML block, merged into the paper's problem, loads and evaluates;
    its own precharge for circuit A couples bounce and roll, as an asymmetric layout should."""
    import re
    import tomllib

    block = re.search(r"```toml\n(.*?)```", (ROOT / "README.md").read_text(encoding="utf-8"), re.S)
    assert block is not None
    data = tomllib.loads(block.group(1))
    spec = hisopt.load_problem(DEFAULT_PROBLEM).spec.model_dump(by_alias=True)
    spec["his"] |= data["his"]
    spec["variables"] |= data["variables"]
    p = problem_from_dict(spec)
    assert p.variable_names[-1] == "p_front" and p.layout().name == "custom"
    assert p.evaluate(p.baseline)["status"].iloc[0] == "ok"
    assert mode_stiffness(p).iloc[-1]["stiffness_coupling"] > 0.05


def test_refinement_improves_a_design_of_another_layout_with_its_extra_variable():
    """CasADi refinement on the accumulator-valve layout, Rv_acc a design variable: the
    refined design dominates its start, checked by the numpy evaluator."""
    from hisopt.optim.gradient.casadi_model import CasadiModel
    from hisopt.optim.gradient.refine import Part, RefineSettings, refine_point

    p = hisopt.load_problem(ROOT / "problems" / "layout_roll_plane_accumulator_valves.toml")
    x0 = p.baseline
    q0 = p.evaluator()(x0[None])
    f0 = np.array([q0[n][0] for n in p.objective_names])
    result = refine_point(p, [Part(None, p, CasadiModel(p, compile=False))], 0, x0, f0, np.ones(4) * 3.0, RefineSettings())
    q = p.evaluator()(result.x[None])
    f = np.array([q[n][0] for n in p.objective_names])
    assert result.accepted and np.all(f <= f0) and np.any(f < f0)


@pytest.mark.parametrize("name", CATALOGUE_NAMES)
def test_every_catalogue_layout_is_left_right_symmetric(name):
    """Mirroring left and right (FL<->FR, RL<->RR) maps D(s) onto itself (the data are mirror
    images; round-off only), with chamber volumes too."""
    mirror = np.array([[0, 1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 1], [0, 0, 1, 0]], float)
    s = 2j * np.pi * np.geomspace(0.1, 100.0, 30)
    for extra in ({}, {"chamber_volume": 1e-4}):
        d = hisopt.load_problem(DEFAULT_PROBLEM).with_values(layout=name, **extra).hydraulic_system({}).stroke_impedance(s)
        assert np.abs(mirror @ d @ mirror - d).max() <= 1e-14 * np.abs(d).max()
