"""Problem files: the shipped problem loads; mistakes name the file and the key."""

import tomllib

import pytest

import hisopt
from hisopt.problem import problem_from_dict
from tests.conftest import DEFAULT_PROBLEM


def test_shipped_problem_matches_paper_table_2(problem):
    assert problem.variable_names == ("p0", "dA", "lam", "Rv")
    assert list(problem.lower) == [0.0, 1e-4, 0.1, 0.0]
    assert list(problem.upper) == [4e6, 25e-4, 0.8, 16e5]
    assert list(problem.baseline) == [2e6, 10e-4, 0.5, 8e5]
    assert problem.objective_names == ("sigma_aw", "max_roll_psd", "max_stroke_psd", "max_tire_load_psd")
    assert problem.sha256 and len(problem.sha256) == 64


def _data():
    return tomllib.loads(DEFAULT_PROBLEM.read_text())


@pytest.mark.parametrize(
    "mutate,key,expect",
    [
        (lambda d: d["vehicle"].update(m_s=-5.0), "vehicle.m_s", "greater than 0"),
        (lambda d: d["vehicle"].update(mass=5.0), "vehicle.mass", "unknown key"),
        (lambda d: d["his"].update(lam=1.2), "his.lam", "less than 1"),
        (lambda d: d["his"].update(V0=0.0), "his.V0", "greater than 0"),
        (lambda d: d["variables"]["p0"].update(lower=5e6), "variables.p0", "lower < upper"),
        (lambda d: d.update(objectives=["comfort"]), "objectives", "unknown objective 'comfort'"),
        (lambda d: d["road"].update({"class": "Z"}), "road.class", "'A'"),
        (lambda d: d["vehicle"].update(k_sf="stiff"), "vehicle.k_sf", "valid number"),
    ],
)
def test_mistakes_name_file_and_key(mutate, key, expect):
    data = _data()
    mutate(data)
    with pytest.raises(hisopt.ConfigError) as info:
        problem_from_dict(data, "my.toml")
    msg = str(info.value)
    assert msg.startswith(f"my.toml: {key}"), msg
    assert expect in msg
    assert "\n" not in msg


def test_missing_file_and_bad_toml(tmp_path):
    with pytest.raises(hisopt.ProblemFileNotFoundError, match="nope.toml"):
        hisopt.load_problem(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[vehicle\nm_s = 1")
    with pytest.raises(hisopt.ConfigError, match="bad.toml: invalid TOML"):
        hisopt.load_problem(bad)


def test_set_overrides_and_unknown_key(problem):
    assert problem.with_values(p0=3e6).baseline[0] == 3e6
    with pytest.raises(hisopt.ConfigError, match="unknown HIS parameter 'foo'"):
        problem.with_values(foo=1.0)
