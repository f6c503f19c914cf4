"""Uncertain inputs (docs/model.md §18): the distributions, the evaluator's routes against a
problem per sample, Sobol indices against the Ishigami function's closed form, Monte Carlo
statistics against closed forms, determinism and Dask."""

from __future__ import annotations

import tomllib

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from hisopt.errors import ConfigError
from hisopt.evaluation.parallel import open_backend
from hisopt.evaluation.uncertain import UncertainEvaluator, monte_carlo_variates, with_inputs
from hisopt.problem import Problem, problem_from_dict
from hisopt.report.uncertainty import sensitivity_notes
from hisopt.specification.uncertain import resolve_uncertain
from hisopt.standards.iso_8608_2016 import class_gd_n0
from hisopt.studies.sobol import decade_span
from hisopt.studies.uncertainty import SensitivityResult, sensitivity, sobol_indices, tolerance
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM, ROOT

UNCERTAIN_PROBLEM = ROOT / "problems" / "roll_plane_his_uncertain.toml"


def with_uncertain(entries: list[dict], **extra) -> Problem:
    data = tomllib.loads(DEFAULT_PROBLEM.read_text())
    data["uncertain"] = entries
    data |= extra
    return problem_from_dict(data, "test.toml")


# --- distributions ------------------------------------------------------------------------------
def test_distributions_map_variates_to_their_quantiles():
    p = with_uncertain(
        [
            {"input": "vehicle.m_s", "distribution": "normal", "sd": "5 %"},
            {"input": "V0", "tolerance": "±10 %"},
            {"input": "temperature", "distribution": "triangular", "lower": "-10 degC", "mode": "20 degC", "upper": "50 degC"},
            {"input": "vehicle.I_x", "distribution": "normal", "sd": "50 kg m^2", "truncate": ["350 kg m^2", "400 kg m^2"]},
            {"input": "road.class", "band": ["B", "C"]},
            {"input": "vehicle.k_sf", "distribution": "normal", "tolerance": "±9 %"},
        ]
    )
    m_s, v0, temp, i_x, road, k_sf = resolve_uncertain(p.spec)
    u = np.array([0.025, 0.5, 0.975])
    np.testing.assert_allclose(m_s.values(u, 1210.0), 1210.0 * (1 + 0.05 * stats.norm.ppf(u)), rtol=1e-15)
    np.testing.assert_allclose(v0.values(u, 1e-3), [0.905e-3, 1e-3, 1.095e-3], rtol=1e-14)
    # a triangle's median splits it where the areas are equal: the mode is its middle here
    np.testing.assert_allclose(temp.values(np.array([0.0, 0.5, 1.0]), 293.15), [263.15, 293.15, 323.15], rtol=1e-14)
    cut = i_x.values(np.linspace(1e-9, 1 - 1e-9, 101), 390.0)
    assert cut.min() >= 350.0 - 1e-9 and cut.max() <= 400.0 + 1e-9
    np.testing.assert_allclose(k_sf.spread, 0.03, rtol=1e-15)  # a tolerance read as 3 sd
    assert road.kind == "loguniform"
    np.testing.assert_allclose(road.values(np.array([0.0, 1.0]), 0.0), [32e-6, 512e-6], rtol=1e-12)  # ISO 8608 B lower, C upper


@pytest.mark.parametrize(
    ("entry", "key", "words"),
    [
        ({"input": "vehicle.mass", "sd": "5 %"}, "uncertain.0.input", "names nothing in the model"),
        ({"input": "p00", "sd": "5 %"}, "uncertain.0.input", "names nothing"),
        ({"input": "vehicle.m_s", "sd": "-5 %"}, "uncertain.0.sd", "above 0"),
        ({"input": "vehicle.m_s", "sd": 0}, "uncertain.0.sd", "above 0"),
        ({"input": "vehicle.m_s", "sd": "40 %"}, "uncertain.0", "outside m_s > 0 (kg)"),
        ({"input": "p0", "distribution": "normal", "sd": "50 %"}, "uncertain.0", "outside p0 >= 0 (Pa)"),
        ({"input": "temperature", "distribution": "normal", "sd": "40 K"}, "uncertain.0", "temperature"),
        ({"input": "temperature", "lower": "-300 degC", "upper": "20 degC"}, "uncertain.0", "absolute zero"),
        ({"input": "vehicle.m_s", "lower": 1300, "upper": 1100}, "uncertain.0.upper", "not below upper"),
        ({"input": "p0", "lower": 1e6, "upper": 2e6}, "uncertain.0.lower", "design variable"),
        ({"input": "vehicle.m_s", "sd": "5 kPa"}, "uncertain.0.sd", "pressure"),
        ({"input": "vehicle.y_cg", "sd": "5 %"}, "uncertain.0", "give the spread in m"),
        ({"input": "road.class", "band": ["D", "B"]}, "uncertain.0.band", "in order"),
        ({"input": "payload.mass", "sd": "10 kg"}, "uncertain.0.input", "[payload]"),
    ],
)
def test_bad_uncertain_entries_are_one_line_naming_the_key(entry, key, words):
    with pytest.raises(ConfigError) as err:
        with_uncertain([entry])
    message = str(err.value)
    assert "\n" not in message and message.startswith(f"test.toml: {key}") and words in message, message


def test_impossible_temperature_range_is_refused_as_outside_the_oil():
    with pytest.raises(ConfigError, match="uncertain.0: triangular .* reaches -60 degC is outside the range the oil is used in"):
        with_uncertain([{"input": "temperature", "distribution": "triangular", "lower": "-60 degC", "upper": "20 degC"}])


def test_cli_refuses_a_bad_entry_with_exit_2(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(DEFAULT_PROBLEM.read_text() + '\n[[uncertain]]\ninput = "vehicle.m_s"\nsd = "-1 kg"\n')
    out = run_cli("tolerance", str(path), "--samples", "16", "--out", str(tmp_path))
    assert out.code == 2 and len(out.error_lines) == 1 and "uncertain.0.sd" in out.stderr, out.stderr


# --- the evaluator's routes against a problem per sample ---------------------------------------
def one_problem(p: Problem, values: dict[str, float]) -> Problem:
    """``p`` with every input set in its problem file: the independent route."""
    spec = p.spec
    car = {k.removeprefix("vehicle."): v for k, v in values.items() if k.startswith("vehicle.")}
    his = {k: v for k, v in values.items() if not k.startswith(("vehicle.", "road.", "temperature")) and k not in p.variable_names}
    update = {"vehicle": spec.vehicle.model_copy(update=car), "his": spec.his.model_copy(update=his)}
    if "temperature" in values:
        update["temperature"] = values["temperature"]
    if "road.speed" in values:
        update["road"] = spec.road.model_copy(update={"speed": values["road.speed"]})
    return Problem(spec.model_copy(update=update), None)


def test_every_route_equals_a_problem_per_sample():
    entries = [
        {"input": "vehicle.m_s", "sd": "5 %"},  # a batch of cars
        {"input": "vehicle.k_tf", "sd": "5 %"},  # an output reads it: a problem per value
        {"input": "p0", "tolerance": "±5 %"},  # a design variable
        {"input": "V0", "tolerance": "±5 %"},  # a fixed [his] value, batched
        {"input": "temperature", "lower": "0 degC", "upper": "40 degC"},
        {"input": "road.speed", "lower": "8 m/s", "upper": "14 m/s"},
    ]
    p = with_uncertain(entries, constraints=[{"name": "roll_gradient", "limit": "5 deg/g"}])
    ev = UncertainEvaluator(p)
    assert ev.routes == ("batched", "problem", "design", "batched", "batched", "problem")
    x = np.tile(p.baseline, (2, 1))
    x[1, 1] *= 1.3
    u = monte_carlo_variates(3, len(entries), seed=5)
    got = ev(x, u)
    for i in range(2):
        for j in range(3):
            values = {k: float(v[0]) for k, v in ev.values(x[i : i + 1], u[j : j + 1]).items()}
            row = x[i].copy()
            row[p.variable_names.index("p0")] = values["p0"]
            expected = one_problem(p, values).evaluator()(row[None, :])
            for name in ev.names:
                # the same operations on the same numbers: equal to the last bit
                assert got[name][i, j] == expected[name][0], (name, i, j)


def test_road_roughness_scales_each_quantity_as_a_class_change_does():
    """ISO 8608 class B is class C's roughness over 4, exactly: the scaled quantities equal a
    class-B problem's to rounding (2 roundings of a product)."""
    p = with_uncertain([{"input": "road.gd_n0", "lower": 1e-6, "upper": 1e-3}], constraints=[{"name": "roll_gradient", "limit": "5 deg/g"}])
    ev = UncertainEvaluator(p)
    u = (class_gd_n0("B") - 1e-6) / (1e-3 - 1e-6)
    got = ev(p.baseline[None, :], np.array([[u]]))
    data = tomllib.loads(DEFAULT_PROBLEM.read_text())
    data["road"]["class"] = "B"
    data["constraints"] = [{"name": "roll_gradient", "limit": "5 deg/g"}]
    b = problem_from_dict(data).evaluate(p.baseline[None, :])
    for name in ev.names:
        np.testing.assert_allclose(got[name][0, 0], b[name].iloc[0], rtol=4e-16 * 8, err_msg=name)


def test_an_impossible_draw_is_flagged_not_evaluated():
    """Rv = 8e5 Pa s/m^3, sd 1.2e5: 1.3e-11 of the mass is below 0, allowed; a draw 7 sd down is negative."""
    data = tomllib.loads(DEFAULT_PROBLEM.read_text())
    p = with_uncertain([{"input": "Rv", "distribution": "normal", "sd": "1.2e5 Pa s m^-3"}], variables={"p0": data["variables"]["p0"]})
    ev = UncertainEvaluator(p)
    got = ev(p.baseline[None, :], np.array([[1e-300], [0.5]]))
    assert not got["valid"][0, 0] and np.isnan(got["sigma_aw"][0, 0])
    assert got["valid"][0, 1]


# --- Sobol indices -----------------------------------------------------------------------------
A_ISHIGAMI, B_ISHIGAMI = 7.0, 0.1


def ishigami(u):
    """Ishigami's function (a = 7, b = 0.1) of three factors uniform on (-pi, pi)."""
    x = -np.pi + 2 * np.pi * u
    return {"f": np.sin(x[:, 0]) + A_ISHIGAMI * np.sin(x[:, 1]) ** 2 + B_ISHIGAMI * x[:, 2] ** 4 * np.sin(x[:, 0])}


def test_sobol_indices_of_the_ishigami_function_match_the_closed_form():
    """Ishigami (a = 7, b = 0.1) through the same SALib path as the model: every index within its
    bootstrap 95 % interval of the closed form (Saltelli et al. 2008, section 4.5)."""
    a, b = A_ISHIGAMI, B_ISHIGAMI
    variance = a**2 / 8 + b * np.pi**4 / 5 + b**2 * np.pi**8 / 18 + 0.5
    v1, v2, v13 = 0.5 * (1 + b * np.pi**4 / 5) ** 2, a**2 / 8, b**2 * np.pi**8 * (1 / 18 - 1 / 50)
    first = np.array([v1, v2, 0.0]) / variance
    total = np.array([v1 + v13, v2, v13]) / variance
    run = sobol_indices(["x1", "x2", "x3"], ishigami, n_base=4096, seed=3)
    indices = run.indices
    assert run.dropped == 0 and run.stop == "fixed" and not run.logged  # Ishigami takes both signs: never log10
    assert np.all(np.abs(indices["S1"] - first) <= indices["S1_conf"]), indices
    assert np.all(np.abs(indices["ST"] - total) <= indices["ST_conf"]), indices


def widest(indices) -> float:
    return float(np.max(indices[["S1_conf", "ST_conf"]].to_numpy()))


def test_the_doubling_stops_at_the_target_and_equals_a_direct_run():
    """Ishigami from 256 base samples, the target the widest half-width of a direct run at 1024
    (wider at 256 and 512): two doublings, every half-width within the target, every number
    equal to the direct run's, and each row evaluated once (the doubling reuses the rows)."""
    names = ["x1", "x2", "x3"]
    direct = {n: sobol_indices(names, ishigami, n_base=n, seed=2).indices for n in (256, 512, 1024)}
    target = widest(direct[1024])
    assert widest(direct[256]) > target and widest(direct[512]) > target  # so it takes two doublings
    rows = []

    def counted(u):
        rows.append(len(u))
        return ishigami(u)

    run = sobol_indices(names, counted, seed=2, target=target, start=256)
    assert (run.stop, run.n_base, run.evaluations) == ("converged", 1024, 1024 * 5)
    assert rows == [256 * 5, 256 * 5, 512 * 5]  # the first sample, then only the new rows
    assert widest(run.indices) <= target and run.unconverged.empty
    pd.testing.assert_frame_equal(run.indices, direct[1024])  # the same numbers, not close ones


def test_a_cap_names_every_interval_still_too_wide():
    """Stopped by the evaluation cap (or a time cap): the result and its printed notes name
    each interval wider than the target, with its quantity, input and half-width."""
    names = ["x1", "x2", "x3"]
    run = sobol_indices(names, ishigami, seed=2, target=1e-3, start=256, max_evaluations=512 * 5)
    assert (run.stop, run.n_base) == ("evaluations", 512)
    ix = run.indices
    expected = {(q, i, k, w) for k in ("S1", "ST") for q, i, w in zip(ix["quantity"], ix["input"], ix[f"{k}_conf"], strict=True) if w > 1e-3}
    assert set(run.unconverged.itertuples(index=False, name=None)) == expected and len(expected) == 6
    result = SensitivityResult(ix, None, run.evaluations, 0, run.n_base, run.stop, run.target, run.unconverged, {}, None, run.seconds)
    notes = sensitivity_notes(result)
    assert "NOT converged" in notes[0] and "--max-evaluations" in notes[0]
    for q, i, k, w in expected:
        assert f"  {k} of {i} on {q}: ± {w:.3f}" in notes
    timed = sobol_indices(names, ishigami, seed=2, target=1e-3, start=256, max_seconds=1e-9)
    assert (timed.stop, timed.n_base) == ("time", 256) and len(timed.unconverged) == 6


def test_a_quantity_spanning_more_than_a_decade_is_taken_as_log10_by_default():
    """exp(5 u) spans 2.2 decades and is taken as log10 (its indices are those of 5 u log10(e),
    a model given as such); 2 + u spans less than one and is not; log=True/False force it."""

    def model(u):
        return {"wide": np.exp(5 * u[:, 0]) * (1 + u[:, 1]), "narrow": 2 + u[:, 0] + u[:, 1]}

    def already_logged(u):
        return {"wide": np.log10(model(u)["wide"])}

    run = sobol_indices(["a", "b"], model, n_base=64)
    assert list(run.logged) == ["wide"]
    wide = run.indices[run.indices["quantity"] == "wide"].reset_index(drop=True)
    pd.testing.assert_frame_equal(wide, sobol_indices(["a", "b"], already_logged, n_base=64, log=False).indices)
    assert not sobol_indices(["a", "b"], model, n_base=64, log=False).logged
    assert set(sobol_indices(["a", "b"], model, n_base=64, log=True).logged) == {"wide", "narrow"}
    assert decade_span(np.array([1.0, 10.0])) is None and decade_span(np.array([1.0, 10.5])) == (1.0, 10.5)
    assert decade_span(np.array([-1.0, 100.0])) is None  # no log10 of a value <= 0


@pytest.mark.parametrize("n_base", [30, 0, 1, 3.0])
def test_a_base_count_not_a_power_of_two_is_refused_naming_n_base(n_base):
    p = with_uncertain([{"input": "V0", "tolerance": "±5 %"}])
    with pytest.raises(ConfigError) as err:
        sensitivity(p, p.baseline[None, :], n_base=n_base)
    assert err.value.key == "n_base" and "power of 2" in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(ConfigError, match="n_base: expected a power of 2"):
        sobol_indices(["a"], lambda u: {"y": u[:, 0]}, n_base=n_base)


def test_an_input_the_model_does_not_read_has_no_total_index():
    """The accumulators' pressure rating enters only the rating constraint: no objective sees it."""
    p = with_uncertain([{"input": "p0", "tolerance": "±5 %"}, {"input": "pressure_rating", "lower": 6.0, "upper": 10.0}])
    result = sensitivity(p, p.baseline[None, :], n_base=256, resamples=200)
    rating = result.indices[result.indices["input"] == "pressure_rating"]
    assert np.all(np.abs(rating["ST"]) <= rating["ST_conf"]), rating
    precharge = result.indices[(result.indices["input"] == "p0") & (result.indices["quantity"] == "max_tire_load_psd")]
    assert float(precharge["ST"].iloc[0]) > 0.5  # the one input that varies drives what it reaches


def test_sensitivity_over_the_box_names_the_design_variables():
    p = with_uncertain([{"input": "V0", "tolerance": "±5 %"}])
    result = sensitivity(p, None, n_base=64, resamples=50)
    assert list(dict.fromkeys(result.indices["input"])) == ["p0", "dA", "lam", "Rv", "V0"]
    assert result.evaluations == 64 * 7


# --- Monte Carlo -------------------------------------------------------------------------------
def test_monte_carlo_of_a_linear_quantity_matches_the_closed_form():
    """A PSD maximum is linear in the road's roughness: with the roughness normal, its mean and
    variance are closed forms; the estimates lie within 4 standard errors of them, and the
    probability of exceeding mean + 1 sd within its Wilson interval of 1 - Phi(1)."""
    gd = class_gd_n0("C")
    sd = 0.1 * gd
    nominal = with_uncertain([]).evaluate(with_uncertain([]).baseline[None, :])["max_roll_psd"].iloc[0]
    slope = nominal / gd
    limit = slope * (gd + sd)
    p = with_uncertain([{"input": "road.gd_n0", "distribution": "normal", "sd": "10 %"}], constraints=[{"name": "max_roll_psd", "limit": limit}])
    n = 40_000
    result = tolerance(p, p.baseline[None, :], n_samples=n, seed=11)
    row = result.summary.set_index("quantity").loc["max_roll_psd"]
    mean, sigma = slope * gd, slope * sd
    assert abs(row["mean"] - mean) <= 4 * sigma / np.sqrt(n)
    assert abs(row["sd"] ** 2 - sigma**2) <= 4 * sigma**2 * np.sqrt(2 / (n - 1))
    chance = result.violations.iloc[0]
    assert chance["low"] <= 1 - stats.norm.cdf(1.0) <= chance["high"], chance


def test_same_seed_same_numbers_and_dask_equals_one_process():
    p = Problem.__new__(Problem)
    p = problem_from_dict(tomllib.loads(UNCERTAIN_PROBLEM.read_text()))
    first = tolerance(p, p.baseline[None, :], n_samples=20_000, seed=4)
    again = tolerance(p, p.baseline[None, :], n_samples=20_000, seed=4)
    assert first.values.equals(again.values)
    with open_backend(workers=1) as backend:
        dist = tolerance(p, p.baseline[None, :], n_samples=20_000, seed=4, backend=backend)
    for name in UncertainEvaluator(p).names:
        np.testing.assert_allclose(dist.values[name], first.values[name], rtol=1e-12, atol=0, err_msg=name)


def test_with_inputs_leaves_the_problem_as_it_was():
    p = with_uncertain([])
    q = with_inputs(p, {"vehicle.k_tf": 1.5e5, "road.speed": 20.0})
    assert q.spec.vehicle.k_tf == 1.5e5 and q.spec.road.speed == 20.0
    assert p.spec.vehicle.k_tf == 2e5 and p.spec.road.speed == 10.0


def test_cli_tolerance_and_sensitivity_write_their_files(tmp_path):
    out = run_cli("tolerance", str(UNCERTAIN_PROBLEM), "--samples", "200", "--out", str(tmp_path / "t"))
    assert out.code == 0, out.stderr
    assert all((tmp_path / "t" / f).exists() for f in ("tolerance.csv", "violations.csv", "samples.parquet", "tolerance.html"))
    assert "roll_gradient" in out.stdout and "deg/g" in out.stdout
    out = run_cli("sensitivity", str(UNCERTAIN_PROBLEM), "--design", "baseline", "--max-evaluations", "100", "--out", str(tmp_path / "s"))
    assert out.code == 0, out.stderr
    assert "1,024 base samples, 10,240 model evaluations" in out.stdout and "NOT converged" in out.stdout and "  S1 of " in out.stdout
    assert (tmp_path / "s" / "sensitivity.csv").exists() and (tmp_path / "s" / "sensitivity.html").exists()
    for page in (tmp_path / "t" / "tolerance.html", tmp_path / "s" / "sensitivity.html"):  # light pages (hisopt.report.embed)
        text = page.read_text()
        drawn_inline = "Plotly.newPlot(" in text.replace("return Plotly.newPlot(", "")  # plotly's own to_html draws each figure so
        assert text.count('id="hisopt-plotly"') == 1 and "window.hisoptFigures.push" in text and not drawn_inline
    out = run_cli("sensitivity", str(UNCERTAIN_PROBLEM), "--samples", "32", "--log", "--out", str(tmp_path / "b"))
    assert out.code == 0 and "log10 of each quantity" in out.stdout, out.stderr
    assert "decades" in (tmp_path / "b" / "sensitivity.csv").read_text()
    for bad in (["--samples", "30"], ["--samples", "32", "--target", "0.1"], ["--max-time", "0 s"]):
        out = run_cli("sensitivity", str(UNCERTAIN_PROBLEM), *bad, "--out", str(tmp_path / "refused"))
        assert out.code == 2 and len(out.error_lines) == 1 and bad[0] in out.stderr and not (tmp_path / "refused").exists(), out.stderr
    assert "power of 2" in run_cli("sensitivity", str(UNCERTAIN_PROBLEM), "--samples", "30").stderr


def test_payload_cg_height_and_a_laden_car_route_through_a_problem_per_sample():
    """A laden problem's car fields, its payload and the CG height change what the batched
    evaluator freezes: each sample is its own problem, equal to the file with its values."""
    entries = [
        {"input": "payload.mass", "lower": "100 kg", "upper": "300 kg"},
        {"input": "vehicle.h_0s", "sd": "5 %"},
        {"input": "vehicle.m_s", "sd": "5 %"},
    ]
    p = with_uncertain(entries, payload={"mass": 200.0, "x": -0.5, "z": 0.1})
    ev = UncertainEvaluator(p)
    assert ev.routes == ("problem", "problem", "problem")
    u = monte_carlo_variates(2, 3, seed=8)
    got = ev(p.baseline[None, :], u)
    for j in range(2):
        values = {k: float(v[0]) for k, v in ev.values(p.baseline[None, :], u[j : j + 1]).items()}
        spec = p.spec
        car = spec.vehicle.model_copy(update={"h_0s": values["vehicle.h_0s"], "m_s": values["vehicle.m_s"]})
        laden = spec.payload.model_copy(update={"mass": values["payload.mass"]})
        expected = Problem(spec.model_copy(update={"vehicle": car, "payload": laden}), None).evaluator()(p.baseline[None, :])
        for name in ev.names:
            assert got[name][0, j] == expected[name][0], (name, j)


def test_uncertain_inputs_combine_with_load_cases():
    """A scenario problem at every sample: each sample's load cases, then their aggregate;
    the road stays each load case's own."""
    data = tomllib.loads((ROOT / "problems" / "roll_plane_his_robust.toml").read_text())
    data["uncertain"] = [{"input": "V0", "tolerance": "±5 %"}, {"input": "vehicle.I_x", "sd": "5 %"}]
    p = problem_from_dict(data)
    ev = UncertainEvaluator(p)
    u = monte_carlo_variates(3, 2, seed=1)
    got = ev(p.baseline[None, :], u)
    assert set(p.scenario_columns) <= set(got)
    for j in range(3):
        values = {k: float(v[0]) for k, v in ev.values(p.baseline[None, :], u[j : j + 1]).items()}
        spec = p.spec
        update = {"his": spec.his.model_copy(update={"V0": values["V0"]}), "vehicle": spec.vehicle.model_copy(update={"I_x": values["vehicle.I_x"]})}
        expected = Problem(spec.model_copy(update=update), None).evaluator()(p.baseline[None, :])
        for name in ev.names:
            assert got[name][0, j] == expected[name][0], (name, j)
    data["uncertain"] = [{"input": "road.speed", "lower": 8.0, "upper": 12.0}]
    with pytest.raises(ConfigError, match="uncertain.0.input: road.speed: a problem with .* road per load case"):
        problem_from_dict(data)


def test_sensitivity_intervals_are_reproducible_at_seed_0():
    """SALib seeds its bootstrap only for a truthy seed: hisopt never hands it 0."""
    p = with_uncertain([{"input": "V0", "tolerance": "±5 %"}, {"input": "vehicle.I_x", "sd": "5 %"}])
    first = sensitivity(p, p.baseline[None, :], n_base=64, seed=0, resamples=50)
    again = sensitivity(p, p.baseline[None, :], n_base=64, seed=0, resamples=50)
    assert first.indices.equals(again.indices)


def test_a_sample_the_file_would_refuse_is_flagged_not_evaluated():
    """A payload drawn off the back of the body is no car: that sample is NaN and not valid."""
    p = with_uncertain([{"input": "payload.x", "lower": "-3 m", "upper": "0 m"}], payload={"mass": 200.0})
    got = UncertainEvaluator(p)(p.baseline[None, :], np.array([[0.01], [0.9]]))  # x = -2.97 m, then -0.3 m
    assert not got["valid"][0, 0] and np.isnan(got["sigma_aw"][0, 0])
    assert got["valid"][0, 1] and np.isfinite(got["sigma_aw"][0, 1])
