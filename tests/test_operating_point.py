"""The operating envelope's physics: oil, gas and a charged HIS at any temperature (docs/model.md §16).

Independent references: the oil's data sheet (two points the Walther equation must return
to rounding, a third it must predict within the equation's accuracy); the ideal gas law by
hand; a charged circuit's static pressure from the strut forces by hand (a quadratic in
closed form: the static gas law is isothermal); the ideal model as the limit of the charged
one; monotonic physics. numpy against CasADi, the state space against the direct solve and
the time domain against the FRF run on three charged variants in tests/test_core.py.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

import hisopt
from hisopt.constants import G_MPS2, P_ATM_PA
from hisopt.coupled.operating_point import accumulator_quantities
from hisopt.errors import ConfigError
from hisopt.hydraulics import laws
from hisopt.hydraulics.fluid import Oil, expanded_density, thermal_ratios
from hisopt.problem import problem_from_dict
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT, random_designs

T20, T_COLD, T_HOT = 293.15, 253.15, 333.15


def problem_at(temperature: float | None = None, charge: dict | None = None, payload: dict | None = None, **his) -> hisopt.Problem:
    data = tomllib.loads(DEFAULT_PROBLEM.read_text())
    data["his"] |= his
    if charge is not None:
        data["his"]["charge"] = charge
    if temperature is not None:
        data["temperature"] = temperature
    if payload is not None:
        data["payload"] = payload
    return problem_from_dict(data, warn_implausible=False)  # -20 C extrapolates the oil's viscosity (a warning)


def his_of(problem: hisopt.Problem, design: tuple[float, ...] | None = None):
    x = np.atleast_2d(problem.baseline if design is None else design)
    return problem.model(x).his


# --- the oil ------------------------------------------------------------------------------------
def test_the_walther_equation_returns_its_two_points_and_predicts_a_third():
    oil = Oil()
    assert oil.kinematic_viscosity(313.15) == pytest.approx(32.0e-6, rel=1e-12)
    assert oil.kinematic_viscosity(373.15) == pytest.approx(5.4e-6, rel=1e-12)
    # the data sheet's 338 mm^2/s at 0 C, given to 3 digits; ASTM D341's two-constant
    # equation predicts mineral oils within about 2 % over 0-100 C: it gives 336.0
    assert oil.kinematic_viscosity(273.15) == pytest.approx(338e-6, rel=0.02)


def test_density_follows_the_expansion_coefficient_and_every_ratio_is_one_at_the_reference():
    oil = Oil()
    assert oil.density_at(288.15) == 875.0
    assert oil.density_at(338.15) == pytest.approx(875.0 / (1 + 7e-4 * 50.0), rel=1e-15)
    assert expanded_density(300.0, 1000.0, 300.0, 1e-3) == 1000.0
    r = thermal_ratios(oil, T20, T20)
    assert (r.density, r.viscosity, r.volume) == (1.0, 1.0, 1.0)
    cold = thermal_ratios(oil, T_COLD, T20)
    assert cold.volume == pytest.approx((1 + 7e-4 * (T_COLD - 288.15)) / (1 + 7e-4 * (T20 - 288.15)), rel=1e-14)
    nu = oil.kinematic_viscosity(T_COLD) / oil.kinematic_viscosity(T20)
    assert cold.viscosity == pytest.approx(nu * cold.density, rel=1e-14)


# --- the paper's idealisation -------------------------------------------------------------------
def test_the_paper_problem_is_unchanged_at_its_reference_temperature():
    plain, stated = problem_at(), problem_at(T20)
    x = np.vstack([plain.baseline, plain.upper, plain.lower + 0.3 * (plain.upper - plain.lower)])
    a, b = plain.evaluator()(x), stated.evaluator()(x)
    for name in plain.objective_names:
        np.testing.assert_array_equal(a[name], b[name])


@pytest.mark.parametrize("temperature", [T_COLD, T_HOT])
def test_an_ideal_precharge_at_another_temperature_is_p0_t_over_t0(temperature):
    """The gas fills the accumulator (no oil in it): constant volume, ``p_abs T / T0``."""
    p = problem_at(temperature)
    values = his_of(p).values
    for v, p_abs, _ in values.gas.values():
        assert np.asarray(v) == 1.0e-3
        assert p_abs[0] == pytest.approx((2.0e6 + P_ATM_PA) * temperature / T20, rel=1e-15)


# --- the charged circuit -----------------------------------------------------------------------
@pytest.mark.parametrize("temperature", [T_COLD, T20, T_HOT])
@pytest.mark.parametrize("design", [(2.0e6, 10e-4, 0.5), (1.0e6, 25e-4, 0.8), (4.0e6, 3e-4, 0.2)])
def test_a_charged_circuit_under_a_payload_by_hand(temperature, design):
    """A payload ``W`` at the CG of the symmetric car, roll-plane layout, charged to gas
    fraction ``phi``, at temperature ``T``.

    By symmetry both circuits sit at one absolute pressure ``q``. The strut forces by hand
    (tests/test_payload.py): circuit A takes in ``alpha - beta_s (q - p_c)`` of oil with
    ``alpha = dA W / (2 k_s)``, ``beta_s = 2 dA^2 / k_s``. It holds gas ``tau G / q``
    (``G = p0_abs V0``, ``tau = T / T_c``) and oil ``V_oil e (1 - (q - p_c) / beta)``, having
    held ``G / p_c`` and ``V_oil`` at charge (``p_c = p0_abs / phi``). So
    ``m q + c0 - tau G / q = 0``: a quadratic in ``q``.
    """
    p0, d_a, lam = design
    phi, chamber, w_kg = 0.7, 2.5e-4, 350.0
    p = problem_at(temperature, {"gas_fraction": phi}, {"mass": w_kg}, p0=p0, dA=d_a, lam=lam, chamber_volume=chamber)
    q_model = his_of(p, design + (8e5,)).static_pressure[0]
    oil = Oil()
    e = thermal_ratios(oil, temperature, T20).volume
    tau, beta, v0, k_s, w = temperature / T20, 1.5e9, 1.0e-3, 18_000.0, w_kg * G_MPS2
    g_content = (p0 + P_ATM_PA) * v0
    p_c = (p0 + P_ATM_PA) / phi
    v_oil = 4 * chamber + v0 * (1 - phi)  # four chambers per circuit, and the accumulator's oil
    alpha, beta_s = d_a * w / (2 * k_s), 2 * d_a**2 / k_s
    m = v_oil * e / beta + beta_s
    c0 = g_content / p_c + v_oil * (1 - e) - m * p_c - alpha
    disc = math.sqrt(c0 * c0 + 4 * m * tau * g_content)
    q = 2 * tau * g_content / (c0 + disc) if c0 > 0 else (disc - c0) / (2 * m)
    np.testing.assert_allclose(q_model, [q, q], rtol=1e-9)
    # the accumulators are linearised there: gas tau G / q at q
    for v, p_abs, _ in his_of(p, design + (8e5,)).values.gas.values():
        assert p_abs[0] == pytest.approx(q, rel=1e-9)
        assert v[0] == pytest.approx(tau * g_content / q, rel=1e-9)


def test_the_charged_model_tends_to_the_idealisation_as_the_gas_fills_the_accumulator():
    """``phi -> 1``: the accumulator holds no oil at charge; with an isothermal gas the laden
    point is the payload model's (§13). The gap closes as ``1 - phi``."""
    payload = {"mass": 300.0, "x": -0.3, "y": 0.2}
    ideal = problem_at(None, None, payload, gamma=1.0)
    x = np.vstack([ideal.baseline, ideal.lower + 0.6 * (ideal.upper - ideal.lower)])
    ref_his = ideal.model(x).his
    ref_p = (x[:, :1] + P_ATM_PA) + ref_his.static_rise
    gaps = []
    for phi in (1 - 1e-4, 1 - 1e-6):
        charged = problem_at(None, {"gas_fraction": phi}, payload, gamma=1.0)
        his = charged.model(x).his
        gaps.append(np.max(np.abs(his.static_pressure / ref_p - 1)))
        ev_c, ev_i = charged.evaluator()(x), ideal.evaluator()(x)
        for name in ideal.objective_names:
            np.testing.assert_allclose(ev_c[name], ev_i[name], rtol=300 * (1 - phi))
    assert gaps[1] < 2e-6 and gaps[1] < gaps[0] / 50


def test_monotonic_physics_of_temperature_and_load():
    """Colder: lower static pressure and a softer gas spring; laden: higher; more viscous oil
    raises a laminar valve's resistance and leaves an orifice's to the density alone."""
    charge = {"gas_fraction": 0.7}
    states = {}
    for name, (t, payload) in {"cold": (T_COLD, None), "ref": (T20, None), "hot": (T_HOT, None), "laden": (T20, {"mass": 400.0})}.items():
        his = his_of(problem_at(t, charge, payload, chamber_volume=2e-4))
        k_gas = 1.0 / np.array([s[0] for k, s in his.values.shunt.items() if k in his.values.gas])
        states[name] = (his.static_pressure[0, 0], k_gas[0], his.values.resistance)
    assert states["cold"][0] < states["ref"][0] < states["hot"][0] < 1.5 * states["ref"][0]
    assert states["cold"][1] < states["ref"][1] < states["hot"][1]
    assert states["laden"][0] > states["ref"][0] and states["laden"][1] > states["ref"][1]
    valve = next(iter(states["ref"][2]))
    assert states["cold"][2][valve] > 5 * states["ref"][2][valve] > 5 * states["hot"][2][valve]
    orifice_cold = his_of(problem_at(T_COLD, charge, valve_laminar_fraction=0.0)).values.resistance[valve]
    density = thermal_ratios(Oil(), T_COLD, T20).density
    assert orifice_cold[0] == pytest.approx(8e5 * density, rel=1e-15)  # rho only: 3 % denser, not 25 times thicker


def test_cooling_empties_a_full_accumulator_and_the_design_is_refused_not_misread():
    """Charged to 90 % gas with 4 L of oil per circuit, the cold shrinks the oil by 110 mL and
    the small struts (dA = 1 cm^2) sink too little to make it up: the accumulator holds no
    oil, the linear model is not the system's, and the design gets NaN (failed). Charged to
    80 %, it keeps some oil."""
    design = (2e6, 1e-4, 0.5, 8e5)
    for phi, empty in ((0.9, True), (0.8, False)):
        p = problem_at(T_COLD, {"gas_fraction": phi}, chamber_volume=1e-3)
        assert np.all(np.isnan(his_of(p, design).static_pressure)) == empty
        row = p.evaluate(np.array([design])).iloc[0]
        assert (row["status"] == "failed") == empty


# --- the problem file ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("extra", "key", "expect"),
    [
        ('temperature = "-300 degC"', "temperature", "-300 degC is below absolute zero (-273.15 degC)"),
        ("temperature = 20.0", "temperature", 'a bare number is kelvin; for Celsius write "20 degC"'),
        ('temperature = "150 degC"', "temperature", "outside the range the oil is used in"),
        ("[his.charge]\ngas_fraction = 1.0", "his.charge.gas_fraction", "less than 1"),
        ("[his.charge]\ngas_fraction = 0.0", "his.charge.gas_fraction", "greater than 0"),
        ('[his.oil]\ntemperature_1 = "40 degC"\nviscosity_1 = "46 cSt"', "his.oil", "needs two data points; temperature_2, viscosity_2 missing"),
    ],
)
def test_bad_operating_input_is_one_line_exit_2(tmp_path, extra, key, expect):
    text = DEFAULT_PROBLEM.read_text()
    head, rest = (extra, "") if extra.startswith("temperature") else ("", extra)
    path = tmp_path / "p.toml"
    path.write_text(head + "\n" + text + "\n" + rest + "\n")
    with pytest.raises(ConfigError) as err:
        hisopt.load_problem(path)
    assert key in str(err.value) and expect in str(err.value)
    out = run_cli("evaluate", str(path))
    assert out.code == 2 and len(out.error_lines) == 1 and expect in out.stderr


def test_an_extrapolated_viscosity_warns_and_a_scenario_temperature_is_its_own_model(tmp_path):
    text = DEFAULT_PROBLEM.read_text() + "\n[his.charge]\ngas_fraction = 0.7\n"
    text += '\n[[scenarios]]\nname = "winter"\ntemperature = "-20 degC"\n\n[[scenarios]]\nname = "summer"\ntemperature = "40 degC"\n'
    path = tmp_path / "p.toml"
    path.write_text(text)
    with pytest.warns(hisopt.PlausibilityWarning, match="extrapolated"):
        p = hisopt.load_problem(path)
    ev = p.evaluator()
    assert len(ev.groups) == 2  # one model per temperature
    out = ev(p.baseline[None, :])
    winter, summer = (problem_at(t, {"gas_fraction": 0.7}) for t in (T_COLD, 313.15))
    for name in p.objective_names:
        assert out[f"{name}@winter"][0] == pytest.approx(winter.evaluator()(p.baseline[None, :])[name][0], rel=1e-12)
        assert out[f"{name}@summer"][0] == pytest.approx(summer.evaluator()(p.baseline[None, :])[name][0], rel=1e-12)
        assert out[f"{name}@winter"][0] != out[f"{name}@summer"][0]


# --- the accumulator quantities -----------------------------------------------------------------
ACCUMULATOR_QUANTITIES = ["sigma_aw", "static_gas_fraction", "static_pressure_ratio"]


def with_quantities(p: hisopt.Problem) -> hisopt.Problem:
    data = p.spec.model_dump(by_alias=True)
    data["objectives"] = ["sigma_aw"]
    data["constraints"] = [{"name": "static_gas_fraction", "limit": 0.9}, {"name": "static_pressure_ratio", "limit": 4.0}]
    return problem_from_dict(data, warn_implausible=False)


def test_the_idealisation_holds_no_oil_and_a_payload_compresses_its_gas_by_hand(rng):
    """Ideal, unladen: ``V = V0`` at ``p0`` exactly. Laden: ``V / V0 = (p0 / (p0 + dp))^(1/gamma)``."""
    ideal = with_quantities(problem_at())
    x = random_designs(ideal, 5, rng)
    out = ideal.evaluate(x)
    charged = x[:, 0] > 0  # the ratio is in gauge: a zero precharge is rated for nothing (+inf: evaluated, infeasible)
    assert np.all(out["static_gas_fraction"][charged] == 1.0) and np.all(out["static_pressure_ratio"][charged] == 1.0)
    assert np.all(out["status"][~charged] == "ok") and np.all(out["static_pressure_ratio"][~charged] == np.inf) and np.any(~charged)
    assert not out["feasible"][~charged].any()
    assert np.all(accumulator_quantities(ideal.model(x).his)["static_pressure_ratio"] == np.where(charged, 1.0, np.inf))
    laden = with_quantities(problem_at(None, None, {"mass": 400.0, "x": -0.5}))
    dp = laden.model(x).his.static_rise  # (n, 2)
    p_abs0 = x[:, :1] + P_ATM_PA
    out = laden.evaluate(x)
    np.testing.assert_allclose(out["static_gas_fraction"][charged], np.max((p_abs0 / (p_abs0 + dp)) ** (1 / 1.4), axis=1)[charged], rtol=1e-14)
    with np.errstate(divide="ignore"):
        by_hand = np.max((x[:, :1] + dp) / x[:, :1], axis=1)  # gauge: p0 + dp over p0
    np.testing.assert_allclose(out["static_pressure_ratio"][charged], by_hand[charged], rtol=1e-14)


def test_a_charged_accumulator_at_its_charge_holds_the_gas_fraction_it_was_charged_to(rng):
    charged = with_quantities(problem_at(None, {"gas_fraction": 0.65}, chamber_volume=2e-4))
    x = random_designs(charged, 6, rng)
    x = x[x[:, 0] > 0]  # p0 = 0 has its own plausibility warning, not this test's subject
    out = charged.evaluate(x)
    np.testing.assert_allclose(out["static_gas_fraction"], 0.65, rtol=1e-14)
    p0_abs = x[:, 0] + P_ATM_PA  # charged to p0_abs / 0.65; the ratio in gauge
    np.testing.assert_allclose(out["static_pressure_ratio"], (p0_abs / 0.65 - P_ATM_PA) / x[:, 0], rtol=1e-13)


def test_the_rating_is_checked_on_gauge_pressures():
    """The makers' ratio p2/p0 is in bar gauge: 9 bar over a 1 bar precharge is 9, not the
    absolute 10/2 = 5; a precharge at or below atmospheric is rated for nothing (+inf, never
    NaN), so the issue's zero precharge at 43 kPa above atmospheric fails where the absolute
    ratio passed it at (101.325 + 43) / 101.325 / 8 = 0.18 of a diaphragm's rating."""
    import casadi as ca

    bar = 1e5
    p = np.array([9.0 * bar, 43e3, 43e3, 2.0 * bar]) + P_ATM_PA
    p0 = np.array([1.0 * bar, 0.0, -0.1 * bar, 2.0 * bar]) + P_ATM_PA
    np.testing.assert_array_equal(laws.gauge_pressure_ratio(p, p0), [9.0, np.inf, np.inf, 1.0])
    assert (143.325e3 / P_ATM_PA) / 8 < 1.0  # the absolute ratio that let it pass
    x = ca.SX.sym("p0_abs")
    fn = ca.Function("r", [x], [laws.gauge_pressure_ratio(9.0 * bar + P_ATM_PA, x), ca.gradient(laws.gauge_pressure_ratio(9.0 * bar + P_ATM_PA, x), x)])
    assert [float(v) for v in fn(P_ATM_PA)] == [math.inf, 0.0]  # the unchosen branch adds nothing, not NaN
    value, slope = (float(v) for v in fn(1.0 * bar + P_ATM_PA))
    assert value == pytest.approx(9.0, rel=1e-15) and slope == pytest.approx(-9.0 / bar, rel=1e-12)  # d(pg / (x - patm))/dx


def test_numpy_and_casadi_give_the_same_accumulator_quantities(rng):
    import casadi as ca

    from hisopt.optim.gradient.casadi_model import CasadiModel

    p = with_quantities(problem_at(T_COLD, {"gas_fraction": 0.7}, {"mass": 300.0, "x": -0.4, "y": 0.2}, chamber_volume=2e-4))
    model = CasadiModel(p, compile=False)
    x_sym = ca.MX.sym("x", len(p.variable_names))
    values = model.accumulators(x_sym)
    fn = ca.Function("acc", [x_sym], [values["static_gas_fraction"], values["static_pressure_ratio"]])
    x = random_designs(p, 4, rng, corners=False)
    numeric = p.evaluator()(x)
    for i, xi in enumerate(x):
        fraction, ratio = (float(v) for v in fn(xi))
        assert fraction == pytest.approx(numeric["static_gas_fraction"][i], rel=1e-12)
        assert ratio == pytest.approx(numeric["static_pressure_ratio"][i], rel=1e-12)
    assert np.all(np.abs(numeric["static_gas_fraction"] - 0.7) > 1e-3)  # away from the charge: a real test


def test_a_gas_fraction_limit_holds_in_every_load_case_of_the_envelope_problem():
    with pytest.warns(hisopt.PlausibilityWarning, match="extrapolated"):
        p = with_quantities(hisopt.load_problem(ROOT / "problems" / "roll_plane_his_envelope.toml"))
    x = np.vstack([p.baseline, [1.0e6, 3e-4, 0.3, 8e5]])
    out = p.evaluate(x)
    columns = [f"static_gas_fraction@{s}" for s in p.scenario_names]
    np.testing.assert_array_equal(out["static_gas_fraction"], out[columns].max(axis=1))
    within = (out["static_gas_fraction"] <= 0.9) & (out["static_pressure_ratio"] <= 4.0)
    assert not np.any(out["feasible"] & ~within)  # feasible only within both limits in every case


@pytest.mark.parametrize("temperature", [T_COLD, T_HOT])
def test_oil_without_an_element_weighs_in_the_static_balance_as_chamber_oil_does(temperature, rng):
    """``[his.charge] oil_volume`` is the circuit's chamber oil for the statics (4 chambers of
    0.25 L = 1 L per circuit), without the chambers' stiff compliances in the dynamics."""
    with_chambers = problem_at(temperature, {"gas_fraction": 0.7}, chamber_volume=2.5e-4)
    with_volume = problem_at(temperature, {"gas_fraction": 0.7, "oil_volume": 1e-3})
    x = random_designs(with_volume, 4, rng, corners=False)
    np.testing.assert_allclose(with_volume.model(x).his.static_pressure, with_chambers.model(x).his.static_pressure, rtol=1e-13)


def test_one_temperature_per_design_gives_each_designs_values_to_the_bit():
    """Temperatures as an array (one per design, for sampled inputs): every parameter and
    every element value of each design is that of its temperature alone, the reference's
    ratios exactly 1 (docs/model.md §16.2)."""
    from hisopt.hydraulics.catalogue import his_parameter_values
    from hisopt.hydraulics.network import element_values

    data = tomllib.loads(DEFAULT_PROBLEM.read_text())
    data["his"]["charge"] = {"gas_fraction": 0.7, "temperature": "20 degC"}
    problem = problem_from_dict(data)
    his, network = problem.spec.his, problem.network()
    temperatures = np.array([253.15, 293.15, 313.15, 353.15, 293.15])
    overrides = {"p0": np.linspace(1e6, 3e6, 5), "Rv": np.linspace(2e5, 1e6, 5)}
    batch = his_parameter_values(his, overrides, temperatures)
    values = element_values(network, batch)
    for i, t in enumerate(temperatures):
        one = his_parameter_values(his, {k: v[i] for k, v in overrides.items()}, float(t))
        for key, value in one.items():
            got = batch[key][i] if np.ndim(batch[key]) else batch[key]
            assert got == value, (key, t)
        single = element_values(network, one)
        for kind in ("shunt", "resistance", "inertance", "compliance", "gas"):
            for element, want in getattr(single, kind).items():
                got = getattr(values, kind)[element]
                for g, w in zip(np.broadcast_arrays(*got) if isinstance(got, tuple) else [got], want if isinstance(want, tuple) else [want], strict=True):
                    assert np.broadcast_to(g, temperatures.shape)[i] == w, (kind, element, t)
    reference = [i for i, t in enumerate(temperatures) if t == 293.15]
    for key in ("gas_temperature_ratio", "viscosity_ratio", "density_ratio", "oil_volume_ratio"):
        assert (batch[key][reference] == 1.0).all()
