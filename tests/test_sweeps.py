"""Sweeps (paper Section IV, Figs. 5-8) and feasible regions (Section V, Figs. 9-10).

Each paper statement of Section IV that the model supports has a test below (41-point sweeps
of the default problem across the paper's Table 2 bounds, other variables at the baseline
design; mode frequencies from the modal analysis, response peaks = band maxima of the Fig. 4
responses: roll and pitch angular accelerations, CG vertical acceleration, FL tyre load).

Supported (tested):

- roll: frequency rises with p0, dA and lam; the peak roll acceleration rises with p0, dA and
  lam; R_v lowers the peak and raises the frequency slightly; the roll frequency is most
  sensitive to dA (``test_roll_*``);
- pitch: frequency and peak independent of lam (``test_pitch_independent_of_lam``); over dA
  the frequency of the pitch-dominated mode first falls, then rises
  (``test_pitch_character_dips_over_dA``; see the caveat below);
- bounce: frequency and peak vertical acceleration rise with p0; frequency rises with dA and is
  most sensitive to it; frequency and peak independent of lam; R_v raises the frequency
  slightly and barely changes the peak (``test_bounce_*``);
- tyre force: R_v has no great influence on its peak frequency or value; over dA its peak
  value passes through a minimum inside the range (``test_tire_*``).

Not supported by the model (docs/model.md §2 and §3 fix the physics; the reasons):

- "Pitch frequency and amplitude remain constant as p0 increases": the HIS stiffens the sum
  of the four strokes, and body pitch about the CG changes that sum by ``2 (l_r - l_f) theta``
  (l_f = 1.13 m, l_r = 1.47 m), so p0 stiffens pitch too and the bounce and pitch modes veer
  near p0 = 0.65 MPa: the two frequency curves do not cross, but the bounce and pitch
  characters move from one to the other. A sweep follows each curve continuously and names it
  as at the baseline design (``test_sweep_follows_each_mode_continuously``); the peak pitch
  acceleration falls about 17 % over p0.
- "Pitch amplitude increases with dA" (the model's peak falls, then rises) and "pitch
  frequency and amplitude increase with R_v; pitch is most sensitive to dA and R_v": the valve
  adds only ``R_v A_b^2`` (tens to a few hundred N s/m) beside 1500 N s/m dampers (docs/model.md
  §3.3, valve note), so R_v changes every frequency and peak by well under 1 %.
- "Pitch frequency minimum at dA = 15e-4 m^2" and "tyre force minimum at dA = 15e-4 m^2":
  the shapes are there but the model's minima lie near 6e-4 m^2 (pitch frequency: there the
  pitch character passes from the upper to the lower of the two veering curves, both of which
  rise with dA) and 9e-4 m^2 (tyre force); the paper's vehicle data (Tables 4-5) did not
  survive, and the defaults of docs/model.md §2.5 move them.
- "Bounce amplitude increases with dA" over the whole range: the peak vertical acceleration
  rises up to dA of about 15e-4 m^2, then falls as the bounce mode stiffens away from the road
  input's low-frequency energy.
- "The tyre force frequency increases and its amplitude decreases with p0 and lam": at low
  p0 or lam the FL tyre load peaks at wheel hop (about 11 Hz); beyond, the stiffened roll mode
  (2-4 Hz) dominates, and because the HIS adds roll stiffness without matching damping its
  damping ratio falls (0.34 to 0.07 over p0, to 0.01 at lam = 0.8), so the tyre force peak
  grows by orders of magnitude instead of falling. The same makes lam, not dA, the variable
  with the largest effect on the tyre force amplitude ("dA affects the response amplitude a
  lot" holds, but lam more).

The roll *angle* (rather than acceleration) peaks at the band's lower edge, where the road
input is largest, and falls with every stiffening; the paper's "amplitude increases" refers to
the Fig. 4 acceleration responses, which is why :data:`hisopt.studies.sweeps.SWEEP_RESPONSES` uses them.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

import hisopt
from hisopt.io import read_csv
from hisopt.studies.sweeps import INDICATORS, regions, response_peaks, sweep
from tests.conftest import DEFAULT_PROBLEM, ROOT

HANDLING = ROOT / "problems" / "roll_plane_his_handling.toml"


@pytest.fixture(scope="module")
def sweeps(problem) -> dict[str, pd.DataFrame]:
    return {name: sweep(problem, name).to_frame() for name in problem.variable_names}


def freq_of(problem, mode: str, **design: float) -> float:
    """[Hz] Frequency of ``mode`` as :func:`hisopt.modal_analysis` names it at one design."""
    return float(hisopt.modal_analysis(problem, design).set_index("mode").loc[mode, "frequency_hz"])


def rising(y: pd.Series) -> bool:
    return bool(np.all(np.diff(y.to_numpy()) > 0))


def falling(y: pd.Series) -> bool:
    return bool(np.all(np.diff(y.to_numpy()) < 0))


def spread(y: pd.Series) -> float:
    """[-] max / min - 1 over the sweep."""
    return float(y.max() / y.min() - 1)


# --- roll mode (paper Fig. 5) ------------------------------------------------------------------
@pytest.mark.parametrize("name", ["p0", "dA", "lam"])
def test_roll_frequency_and_peak_rise_with_stiffening_variables(sweeps, name):
    # Fig. 5 (a)-(c): "the frequency of the roll mode goes higher"; "both frequency and maximum
    # response amplitude increase with an increase of either dA or lam"; "higher response amplitude"
    s = sweeps[name]
    assert rising(s["roll_frequency_hz"])
    assert rising(s["roll_peak_psd"])


def test_roll_rv_lowers_the_peak_and_raises_the_frequency_slightly(sweeps):
    # Fig. 5 (d): "an increase in R_v produces a decrease in the response amplitude and a slight
    # increase in the frequency"
    s = sweeps["Rv"]
    assert falling(s["roll_peak_psd"])
    assert rising(s["roll_frequency_hz"])
    assert spread(s["roll_frequency_hz"]) < 1e-3


def test_roll_frequency_is_most_sensitive_to_dA(sweeps):
    # "Among the four parameters, the roll mode is most sensitive to the area difference"
    effects = {name: spread(s["roll_frequency_hz"]) for name, s in sweeps.items()}
    assert max(effects, key=effects.get) == "dA"


# --- pitch mode (paper Fig. 6) -----------------------------------------------------------------
def test_pitch_independent_of_lam(sweeps):
    # Fig. 6 (c): "as lam increases, both frequency and maximum response amplitude remain constant"
    s = sweeps["lam"]
    assert spread(s["pitch_frequency_hz"]) < 1e-3
    assert spread(s["pitch_peak_psd"]) < 5e-3


def test_pitch_character_dips_over_dA(problem, sweeps):
    # Fig. 6 (b): "the frequency has a decrease until dA = 15e-4 m^2 and increases after that"
    # (the model's minimum lies elsewhere: see the module docstring). Both followed curves rise;
    # the frequency of the mode with the larger pitch share (modal_analysis per design) dips
    # where the pitch character passes to the lower curve, the sweep's "pitch".
    s = sweeps["dA"]
    assert rising(s["pitch_frequency_hz"]) and rising(s["bounce_frequency_hz"])
    f = np.array([freq_of(problem, "pitch", dA=v) for v in s["dA"]])
    k = int(np.argmin(f))
    assert 0 < k < f.size - 1
    assert np.all(np.diff(f[k:]) > 0)
    share = s["pitch_motion_share"].to_numpy()
    assert share[k - 1] < 0.5 <= share[k]


# --- bounce mode (paper Fig. 7) ----------------------------------------------------------------
def test_bounce_frequency_and_peak_rise_with_p0(sweeps):
    # Fig. 7 (a): "as p0 increases, both frequency and maximum response amplitude have an increase"
    s = sweeps["p0"]
    assert rising(s["bounce_frequency_hz"])
    assert rising(s["bounce_peak_psd"])


def test_bounce_frequency_rises_with_dA_and_is_most_sensitive_to_it(sweeps):
    # Fig. 7 (b): "the vertical frequency increases"; "dA is the most sensitive factor"
    assert rising(sweeps["dA"]["bounce_frequency_hz"])
    effects = {name: spread(s["bounce_frequency_hz"]) for name, s in sweeps.items()}
    assert max(effects, key=effects.get) == "dA"


def test_bounce_independent_of_lam(sweeps):
    # Fig. 7 (c): "both frequency and maximum response amplitude remain unchanged"
    s = sweeps["lam"]
    assert spread(s["bounce_frequency_hz"]) < 1e-3
    assert spread(s["bounce_peak_psd"]) < 0.05


def test_bounce_rv_raises_frequency_without_changing_the_peak_much(sweeps):
    # Fig. 7 (d): "the frequency increases with R_v, whereas R_v doesn't have a great influence
    # on the response amplitude"
    s = sweeps["Rv"]
    assert rising(s["bounce_frequency_hz"])
    assert spread(s["bounce_peak_psd"]) < 0.01


# --- tyre force (paper Fig. 8) -----------------------------------------------------------------
def test_tire_force_barely_depends_on_rv(sweeps):
    # Fig. 8 (d): "R_v doesn't have great influence on both frequencies of the tire ground force
    # and its response amplitude"
    s = sweeps["Rv"]
    assert spread(s["tire_peak_hz"]) < 1e-3
    assert spread(s["tire_peak_psd"]) < 0.01


def test_tire_force_peak_has_a_minimum_inside_the_dA_range(sweeps):
    # Fig. 8 (b): "the maximum response amplitude reaches its minimum" inside the range
    y = sweeps["dA"]["tire_peak_psd"].to_numpy()
    k = int(np.argmin(y))
    assert 0 < k < y.size - 1


# --- the sweep itself --------------------------------------------------------------------------
def test_sweep_frame_and_modal_frequencies(problem, sweeps):
    s = sweeps["p0"]
    assert len(s) == 41
    np.testing.assert_allclose(s["p0"], np.linspace(0.0, 4e6, 41))
    modes = hisopt.modal_analysis(problem, {"p0": s["p0"][20]}).set_index("mode")
    for mode in ("roll", "pitch", "bounce"):
        assert s[f"{mode}_frequency_hz"][20] == pytest.approx(modes.loc[mode, "frequency_hz"], rel=1e-12)


# --- each mode followed continuously (issue 12) ------------------------------------------------
def test_sweep_follows_each_mode_continuously(problem, sweeps):
    s = sweeps["p0"]
    # The two symmetric body modes veer without crossing: the followed "pitch" (named at the
    # baseline, p0 = 2 MPa) is the lower of the two at every point, "bounce" the upper, while
    # the per-design names exchange between 0.6 and 0.7 MPa with the modes' character.
    per_design = np.array([[freq_of(problem, m, p0=v) for m in ("pitch", "bounce")] for v in s["p0"]])
    np.testing.assert_allclose(s["pitch_frequency_hz"], per_design.min(axis=1), rtol=1e-12)
    np.testing.assert_allclose(s["bounce_frequency_hz"], per_design.max(axis=1), rtol=1e-12)
    assert s["p0"][6] == pytest.approx(0.6e6) and s["p0"][7] == pytest.approx(0.7e6)
    assert per_design[6, 0] > per_design[6, 1] and per_design[7, 0] < per_design[7, 1]
    assert s["pitch_motion_share"][6] < 0.5 < s["pitch_motion_share"][7]
    for mode in ("pitch", "bounce"):  # formerly a 0.17 Hz jump (1.33 <-> 1.16 Hz)
        assert abs(s[f"{mode}_frequency_hz"][7] - s[f"{mode}_frequency_hz"][6]) < 0.01


@pytest.mark.parametrize("name", ["p0", "dA", "lam", "Rv"])
def test_sweep_curves_have_no_jumps(sweeps, name):
    # a swap of names shows as one step far larger than both neighbouring steps
    for mode in ("roll", "pitch", "bounce"):
        f = sweeps[name][f"{mode}_frequency_hz"].to_numpy()
        step = np.abs(np.diff(f))
        neighbours = np.maximum(np.r_[step[1:], 0.0], np.r_[0.0, step[:-1]])
        assert np.all(step <= 3 * neighbours + 1e-9 * f[1:]), (mode, step.max())


def test_tracking_does_not_depend_on_the_grid(problem, sweeps):
    # three points over the box (big steps, halved until the shapes match) give the 41-point
    # curves; wheel modes too: the warp stays rear_axle_tramp all along, at its closed form
    from hisopt.coupled.modal import MODE_NAMES, track_modes

    fine = track_modes(problem, problem.design_matrix({"p0": np.linspace(0.0, 4e6, 41)}), anchor=20)
    coarse = track_modes(problem, problem.design_matrix({"p0": [0.0, 2e6, 4e6]}), anchor=1)
    f_fine = fine.pivot(index="design", columns="mode", values="frequency_hz").loc[[0, 20, 40], list(MODE_NAMES)]
    f_coarse = coarse.pivot(index="design", columns="mode", values="frequency_hz")[list(MODE_NAMES)]
    np.testing.assert_allclose(f_coarse.to_numpy(), f_fine.to_numpy(), rtol=1e-12)
    for mode in ("roll", "pitch", "bounce"):
        np.testing.assert_allclose(fine[fine["mode"] == mode]["frequency_hz"], sweeps["p0"][f"{mode}_frequency_hz"], rtol=1e-12)
    v = problem.spec.vehicle
    warp = fine[fine["mode"] == "rear_axle_tramp"]["frequency_hz"]
    np.testing.assert_allclose(warp, np.sqrt((v.k_sf + v.k_tf) / v.m_uf) / (2 * np.pi), rtol=1e-9)


def test_response_peaks_are_continuous_maxima(problem):
    # the refined peak is at least the largest value on a fine grid and within 1e-6 of it
    x = problem.design_matrix({"p0": [0.0, 4e6], "lam": [0.1, 0.8]})
    peaks = response_peaks(problem, x, ("acc_roll", "tire_load_fl"))
    from hisopt.evaluation.channels import DirectOutputs
    from hisopt.evaluation.evaluate import Evaluator

    ev = Evaluator(problem)
    f = np.geomspace(0.5, 80.0, 40001)[None, :].repeat(2, axis=0)
    outs = {n: ev.all_outputs[n] for n in ("acc_roll", "tire_load_fl")}
    psd = ev.spectra(f, DirectOutputs(problem.model(x), outs)(2 * np.pi * f))
    for j, name in enumerate(outs):
        grid_max = psd[..., j].max(axis=1)
        assert np.all(peaks[name][1] >= grid_max * (1 - 1e-9))
        assert np.all(peaks[name][1] <= grid_max * (1 + 1e-4))


def test_sweep_plot_and_errors(problem):
    result = sweep(problem, "Rv", points=3)
    fig = result.plot()
    assert len(fig.data) == 3 * 3 + 2  # three traces per mode, two for the tyre force
    with pytest.raises(hisopt.ConfigError, match="--vary"):
        sweep(problem, "V0")
    with pytest.raises(hisopt.ConfigError, match="--points"):
        sweep(problem, "p0", points=1)


# --- feasible regions (paper Figs. 9-10) -------------------------------------------------------
def test_regions_with_the_problem_constraints():
    problem = hisopt.load_problem(HANDLING)
    result = regions(problem, ("p0", "Rv"), points=9)
    assert result.threshold_source == "constraints"
    assert result.thresholds == {c.name: c.limit for c in problem.spec.constraints}
    frame = result.to_frame()
    assert len(frame) == 81 and set(INDICATORS) <= set(frame.columns)
    # the grid points are designs: their values are the evaluator's, feasibility the problem's
    x = problem.design_matrix(frame[["p0", "Rv"]].assign(dA=problem.baseline[1], lam=problem.baseline[2]))
    df = problem.evaluate(x)
    np.testing.assert_array_equal(frame["feasible"], df["feasible"])
    for name in problem.constraint_names:
        np.testing.assert_allclose(frame[name], df[name], rtol=1e-12)
    assert 0 < frame["feasible"].mean() < 1  # the limits cut through this plane
    fig = result.plot()
    assert sum(t.name == "infeasible" for t in fig.data) == 4


def test_regions_without_constraints_use_the_baseline(problem):
    result = regions(problem, ("dA", "lam"), points=5)
    assert result.threshold_source == "baseline"
    base = problem.evaluator()(problem.baseline[None])
    assert result.thresholds == pytest.approx({n: base[n][0] for n in INDICATORS}, rel=1e-12)
    f = result.to_frame()
    expected = np.all([f[n] <= base[n][0] for n in INDICATORS], axis=0)
    np.testing.assert_array_equal(f["feasible"], expected)
    assert "baseline design's values" in result.plot().layout.title.text
    for pair in (("dA", "dA"), ("dA", "V0")):
        with pytest.raises(hisopt.ConfigError, match="--pair"):
            regions(problem, pair)


def test_cli_sweep_and_regions_write_csv_and_html(tmp_path):
    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "hisopt", *args], capture_output=True, text=True, timeout=300)

    out = run("sweep", str(DEFAULT_PROBLEM), "--vary", "lam", "--points", "5", "--out", str(tmp_path / "sweeps"))
    assert out.returncode == 0, out.stderr
    frame = read_csv(tmp_path / "sweeps" / "sweep_lam.csv")
    assert len(frame) == 5 and "roll_frequency_hz" in frame and "tire_peak_psd" in frame
    units = frame.attrs["units"]
    assert set(units) == set(frame.columns) and units["lam"] == "-" and units["roll_frequency_hz"] == "Hz"
    assert units["roll_peak_psd"] == "(rad/s^2)^2/Hz" and units["tire_peak_psd"] == "N^2/Hz" and units["roll_damping_ratio"] == "-"
    assert "plotly" in (tmp_path / "sweeps" / "sweep_lam.html").read_text()[:20000].lower()
    out = run("regions", str(DEFAULT_PROBLEM), "--pair", "p0,Rv", "--points", "4", "--out", str(tmp_path / "regions"))  # a folder of its own
    assert out.returncode == 0, out.stderr
    grid = read_csv(tmp_path / "regions" / "regions_p0_Rv.csv")
    assert len(grid) == 16 and set(grid.attrs["units"]) == set(grid.columns)
    assert grid.attrs["units"]["p0"] == "Pa" and grid.attrs["units"]["Rv"] == "Pa s m^-3" and grid.attrs["units"]["sigma_aw"] == "m/s^2"
    assert (tmp_path / "regions" / "regions_p0_Rv.html").stat().st_size > 1_000_000  # plotly.js embedded: offline
    bad = run("regions", str(DEFAULT_PROBLEM), "--pair", "p0")
    assert bad.returncode == 2 and "--pair" in bad.stderr and "Traceback" not in bad.stderr
