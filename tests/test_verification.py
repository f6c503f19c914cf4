"""The time-domain verification (docs/model.md §22): the pipeline against the frequency domain,
its statistics and verdicts, and ``hisopt verify``'s refusals.

The pipeline's proof: the linear model simulated on seeded road pairs gives, for three designs
of the paper's problem, ``sigma_aw`` (the ISO 2631-1 filters in the time domain), the RMS
stroke and the RMS tyre load equal to the frequency domain's exact values within three
standard errors of the realisations' spread. The remaining differences of a finite record (its
band edges, the periodogram's leakage) are part of that spread: the frequency domain is the
expectation the realisations scatter about.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from hisopt.simulation.verification import load_cases, verify_case
from hisopt.simulation.verification_rows import (
    AGREES,
    CAUSE_LABELS,
    GAP,
    SMALL_GAP,
    VerifySettings,
    attribute,
    davenport_peak,
    ratio_gap,
    rms_and_error,
)
from hisopt.standards.weighting_filters import spline_gain
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM

FAST = VerifySettings(realisations=3, duration_s=20.0)
"""Three road pairs of 20 s: sigma_aw's standard error about 0.5 % on the paper's city road."""

DESIGNS = {
    "baseline": None,
    "soft": {"p0": 1.0e6, "dA": 4e-4, "lam": 0.3, "Rv": 4e5},
    "stiff": {"p0": 3.0e6, "dA": 12e-4, "lam": 0.6, "Rv": 1.2e6},
}
"""Three designs of the paper's problem spread over its box."""


@pytest.fixture(scope="module")
def paper_cases(problem):
    """Each design's verification on the paper's road (its only load case)."""
    ((name, case),) = load_cases(problem)
    out = {}
    for label, design in DESIGNS.items():
        x = case.design_matrix(case.baseline if design is None else design)
        out[label] = verify_case(case, x, name, 0, FAST)
    return out


@pytest.mark.parametrize("label", list(DESIGNS))
@pytest.mark.parametrize(("figure", "splines"), [("sigma_aw", 2), ("rms_stroke", 1), ("rms_tire_load", 1)])
def test_linear_simulation_equals_the_frequency_domain_within_three_standard_errors(problem, paper_cases, label, figure, splines):
    """The pipeline's proof (module docstring). Besides the spread, the budget holds the cubic
    spline's attenuation at five samples per period of the band's top (the road is read
    between samples by its spline; sigma_aw's weighting filters read the acceleration the
    same way): at most ``1 - S(f_max)`` per spline, 0.49 % at 80 Hz, for a response with all its
    power there (a design whose wheels lock shows part of it)."""
    (row,) = [r for r in paper_cases[label].rows if r["figure"].startswith(figure)]
    dt = 1.0 / (5.0 * problem.spec.band.f_max_hz)
    spline = splines * float(1.0 - spline_gain(problem.spec.band.f_max_hz, dt))
    assert row["linear_se"] > 0.0
    assert abs(row["linear"] - row["frequency_domain"]) <= 3.0 * row["linear_se"] + spline * row["frequency_domain"], row


def test_the_gas_law_is_the_only_nonlinearity_at_work_on_the_paper_car(paper_cases):
    """Linear valves and tyres that never leave the road: any gap of the paper's car is the gas
    law's (named without a rerun); every extreme is read against its limit."""
    for verification in paper_cases.values():
        for row in verification.rows:
            if row["verdict"] in (GAP, SMALL_GAP):
                assert row["cause"] == CAUSE_LABELS["gas_law"], row
        floors = [r for r in verification.rows if r["figure"].startswith("accumulator_pressure_min")]
        assert floors and all(math.isfinite(r["limit"]) for r in floors)


def test_rms_and_its_error_by_the_delta_method():
    """The RMS of mean squares and half their relative spread."""
    ms = np.array([1.0, 1.2, 0.8, 1.0])
    rms, error = rms_and_error(ms)
    assert rms == pytest.approx(1.0)
    assert error == pytest.approx(0.5 * np.std(ms, ddof=1) / 2.0)


def test_ratio_gap_is_exact_for_proportional_runs():
    """Nonlinear mean squares 4 % above the linear ones on every road: a gap of sqrt(1.04) - 1
    with no spread."""
    lin = np.array([1.0, 2.0, 3.0])
    gap, error = ratio_gap(1.04 * lin, lin)
    assert gap == pytest.approx(math.sqrt(1.04) - 1.0, rel=1e-12)
    assert error == pytest.approx(0.0, abs=1e-15)


def test_davenport_peak_against_its_closed_form():
    """sigma (sqrt(2 ln N) + gamma / sqrt(2 ln N)) with N = 2 nu0 T crossings."""
    sigma, rate, t = 2.0, 2.0 * math.pi * 2.0 * 1.5, 100.0  # nu0 = 1.5 Hz
    root = math.sqrt(2.0 * math.log(2.0 * 1.5 * 100.0))
    assert davenport_peak(sigma, rate, t) == pytest.approx(sigma * (root + 0.5772156649015329 / root), rel=1e-12)
    assert math.isnan(davenport_peak(1.0, 1e-6, 1.0))  # fewer crossings than the formula needs


def test_attribution_names_the_nonlinearity_that_takes_the_gap_away():
    """A 5 % gap that the gas law's removal halves or more is the gas law's; one no single
    switch removes is several together; an agreeing row is left alone."""
    rows = [{"verdict": GAP, "gap": 0.05, "cause": ""}, {"verdict": GAP, "gap": 0.05, "cause": ""}, {"verdict": AGREES, "gap": 0.0, "cause": ""}]
    without = {
        "gas_law": [{"gap": 0.01}, {"gap": 0.04}, {"gap": 0.0}],
        "tyre_liftoff": [{"gap": 0.05}, {"gap": 0.03}, {"gap": 0.0}],
    }
    attribute(rows, without)
    assert [r["cause"] for r in rows] == [CAUSE_LABELS["gas_law"], CAUSE_LABELS["combined"], ""]


# --- the command's refusals -------------------------------------------------------------------
def refused(out, *parts):
    assert out.code == 2, out
    assert len(out.error_lines) == 1 and out.error_lines[0].startswith("error: "), out.stderr
    for part in parts:
        assert part in out.error_lines[0], out.error_lines[0]


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory) -> Path:
    run = tmp_path_factory.mktemp("verify") / "run"
    assert run_cli("optimize", DEFAULT_PROBLEM, "--out", run, "--pop", "8", "--gens", "2").code == 0
    return run


def test_a_design_not_in_the_run_is_refused(tiny_run):
    refused(run_cli("verify", tiny_run, "--design", "999"), "--design 999", "not in the run")
    assert not list(tiny_run.glob("verify-*"))


def test_a_folder_of_another_kind_is_refused(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    refused(run_cli("verify", tmp_path, "--design", "0"), "expected a run directory")


@pytest.mark.parametrize(
    ("option", "value", "expected"),
    [("--realisations", "1", "at least 2 realisations"), ("--duration", "5s", "at least 20 s"), ("--design", "a,b", "front.csv rows")],
)
def test_too_few_realisations_or_too_short_a_record_is_refused(tiny_run, option, value, expected):
    """R below two gives no standard error; a record shorter than ten periods of the band's
    lowest frequency cannot resolve it (the standard error check after the run refuses what
    passes these and still misses 10 %)."""
    refused(run_cli("verify", tiny_run, option, value), option, expected)


def test_a_road_class_outside_iso_8608s_table_is_refused(tmp_path):
    """The problem's own check (its [road] and every load case's road) refuses it on loading."""
    bad = tmp_path / "bad.toml"
    bad.write_text(DEFAULT_PROBLEM.read_text().replace('class = "C"', 'class = "Z"', 1))
    refused(run_cli("verify", bad, "--out", tmp_path / "v"), "road.class", "'Z'")
    assert not (tmp_path / "v").exists()


def test_a_problems_baseline_needs_an_out_folder():
    refused(run_cli("verify", DEFAULT_PROBLEM), "--out")


def test_several_designs_on_a_local_dask_cluster(tiny_run, tmp_path):
    """Two front designs, one task each on two worker processes: each gets its own folder and
    summary, in the order asked, as a serial run would write them."""
    import json

    out = tmp_path / "verified"
    result = run_cli("verify", tiny_run, "--design", "1,0", "--out", out, "--realisations", "2", "--no-manoeuvres", "--workers", "2")
    assert result.code == 0, result.stderr
    for row in (0, 1):
        summary = json.loads((out / f"verify-{row}" / "verify.json").read_text())
        assert summary["row"] == row and summary["design"] == f"front.csv row {row}"
        assert summary["realisations"] == {"road": 2}
    assert result.stdout.index("verify-1") < result.stdout.index("verify-0")
