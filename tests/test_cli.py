"""CLI smoke tests through the real entry point (exit codes, output)."""

import subprocess
import sys

from tests.conftest import DEFAULT_PROBLEM


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "hisopt", *args], capture_output=True, text=True, timeout=300)


def test_modes_prints_table_with_and_without_his():
    out = run("modes", str(DEFAULT_PROBLEM))
    assert out.returncode == 0, out.stderr
    for word in ("bounce", "roll", "pitch", "wheel_hop_fl", "f ref [Hz]", "f HIS [Hz]"):
        assert word in out.stdout
    assert "2.744" in out.stdout  # baseline roll frequency with HIS


def test_modes_set_override_changes_result():
    out = run("modes", str(DEFAULT_PROBLEM), "--set", "p0=4e6")
    assert out.returncode == 0, out.stderr
    assert "p0=4e+06" in out.stdout


def test_user_errors_exit_2_without_traceback(tmp_path):
    out = run("modes", str(tmp_path / "missing.toml"))
    assert out.returncode == 2
    assert "missing.toml" in out.stderr and "Traceback" not in out.stderr
    out = run("modes", str(DEFAULT_PROBLEM), "--set", "nonsense")
    assert out.returncode == 2 and "KEY=VALUE" in out.stderr
