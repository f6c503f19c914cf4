"""CLI smoke tests through the real entry point (exit codes, output)."""

from hisopt.io import read_csv
import subprocess
import sys

from tests.conftest import DEFAULT_PROBLEM


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "hisopt", *args], capture_output=True, text=True, timeout=300)


def test_modes_prints_table_with_and_without_his():
    out = run("modes", str(DEFAULT_PROBLEM))
    assert out.returncode == 0, out.stderr
    for word in ("bounce", "roll", "pitch", "front_axle_hop", "rear_axle_tramp", "f ref [Hz]", "f HIS [Hz]", "zeta HIS [-]", "change [%]"):
        assert word in out.stdout
    assert "wheel_hop_fl/fr/rl/rr = front_axle_hop, front_axle_tramp, rear_axle_hop, rear_axle_tramp" in out.stdout
    assert "2.744" in out.stdout  # baseline roll frequency with HIS


def test_modes_compares_the_same_mode_without_and_with_his():
    # issue 12: at p0 = 3 MPa the unchanged 11.08 Hz wheel warp had a different name with HIS
    # than without, so the change column compared different modes
    out = run("modes", str(DEFAULT_PROBLEM), "--set", "p0=3e6")
    assert out.returncode == 0, out.stderr
    row = next(line for line in out.stdout.splitlines() if "rear_axle_tramp" in line)
    cells = [c.strip() for c in row.strip("│ ").split("│")]
    assert cells[2] == cells[4] == "11.08" and cells[6] == "+0.0", row


def test_modes_set_override_changes_result():
    out = run("modes", str(DEFAULT_PROBLEM), "--set", "p0=4e6")
    assert out.returncode == 0, out.stderr
    assert "p0 = 4 MPa" in out.stdout and "dA = 10 cm^2" in out.stdout  # the design, in engineering units


def test_user_errors_exit_2_without_traceback(tmp_path):
    out = run("modes", str(tmp_path / "missing.toml"))
    assert out.returncode == 2
    assert "missing.toml" in out.stderr and "Traceback" not in out.stderr
    out = run("modes", str(DEFAULT_PROBLEM), "--set", "nonsense")
    assert out.returncode == 2 and "KEY=VALUE" in out.stderr


def test_evaluate_baseline_and_designs_file(tmp_path):
    out = run("evaluate", str(DEFAULT_PROBLEM))
    assert out.returncode == 0, out.stderr
    assert "0.5532" in out.stdout or "0.5533" in out.stdout  # docs/model.md §7.1: 0.5534 within 0.1 %
    for shown in ("sigma_aw [m/s^2]", "p0 [MPa]", "dA [cm^2]", "Rv [MPa s/m^3]", "max_roll_psd [rad^2/Hz]", "8.467e-5"):
        assert shown in out.stdout  # units on every row, engineering values
    designs = tmp_path / "designs.csv"
    designs.write_text("p0,dA,lam,Rv\n2e6,1e-3,0.5,8e5\n0,1e-4,0.1,0\n")
    results = tmp_path / "results.csv"
    out = run("evaluate", str(DEFAULT_PROBLEM), "--designs", str(designs), "--out", str(results))
    assert out.returncode == 0, out.stderr

    df = read_csv(results)
    assert list(df.columns) == ["p0", "dA", "lam", "Rv", "sigma_aw", "max_roll_psd", "max_stroke_psd", "max_tire_load_psd", "feasible"]
    assert abs(df.loc[1, "sigma_aw"] / 0.4599 - 1) < 5e-3
    assert df.attrs["units"] == {
        "p0": "Pa", "dA": "m^2", "lam": "-", "Rv": "Pa s m^-3", "sigma_aw": "m/s^2", "max_roll_psd": "rad^2/Hz",
        "max_stroke_psd": "m^2/Hz", "max_tire_load_psd": "N^2/Hz", "feasible": "-",
    }  # fmt: skip
    assert results.read_text().splitlines()[1].startswith("[Pa],[m^2],[-],[Pa s m^-3],[m/s^2]")
    # The results file is a designs file again (its units row is skipped), with the same results.
    again = tmp_path / "again.csv"
    out = run("evaluate", str(DEFAULT_PROBLEM), "--designs", str(results), "--out", str(again))
    assert out.returncode == 0, out.stderr
    assert read_csv(again).equals(df)


def test_evaluate_bad_designs_file_is_a_user_error(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("p0,dA\n1,2\n")
    out = run("evaluate", str(DEFAULT_PROBLEM), "--designs", str(bad))
    assert out.returncode == 2
    assert "bad.csv" in out.stderr and "'lam'" in out.stderr and "Traceback" not in out.stderr


def test_response_writes_csv_and_offline_html(tmp_path):
    out = run("response", str(DEFAULT_PROBLEM), "--out", str(tmp_path / "resp"))
    assert out.returncode == 0, out.stderr

    df = read_csv(tmp_path / "resp" / "response.csv")
    for col in ("f_hz", "acc_z_his", "acc_z_ref", "acc_roll_his", "acc_pitch_ref", "tire_load_fl_his"):
        assert col in df
    units = df.attrs["units"]
    assert units["f_hz"] == "Hz" and units["acc_z_his"] == "(m/s^2)^2/Hz" and units["tire_load_fl_ref"] == "N^2/Hz"
    assert units["acc_roll_ref"] == "(rad/s^2)^2/Hz" and set(units) == set(df.columns)
    # The HIS stiffens bounce: the body's vertical-acceleration peak moves up in frequency;
    # at the lowest frequency the body follows the road with or without HIS.
    body = df[df["f_hz"] < 5]
    assert body.loc[body["acc_z_his"].idxmax(), "f_hz"] > body.loc[body["acc_z_ref"].idxmax(), "f_hz"]
    assert abs(df.loc[0, "acc_z_his"] / df.loc[0, "acc_z_ref"] - 1) < 0.25
    html = (tmp_path / "resp" / "response.html").read_text()
    assert "plotly" in html and 'src="https://cdn.plot.ly' not in html and len(html) > 2_000_000  # JS embedded
