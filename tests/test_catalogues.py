"""Choice variables and catalogues of standard parts (docs/model.md §17).

Independent references: the catalogue files' own rows (ISO 3320's bores and rods, as the
standard lists them); a search coordinate's round trip; the evaluator on the whole batch
against one design at a time; a run's front checked value by value against its lists.
"""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

import hisopt
from hisopt.optim.pymoo_problem import HisoptPymooProblem
from hisopt.problem import problem_from_dict
from hisopt.specification.catalogues import catalogue_names, listed
from hisopt.studies.sweeps import grid_values
from tests.cli_inprocess import run_cli
from tests.conftest import DEFAULT_PROBLEM

PARTS = """
name = "parts"
objectives = ["sigma_aw", "roll_gradient"]
[variables]
p0 = { lower = "0.5 MPa", upper = "4 MPa" }
Rv = { lower = 0.0, upper = 1.6e6 }
bore = { catalogue = "iso3320_bores", lower = "40 mm", upper = "80 mm" }
rod = { choices = ["20 mm", "25 mm", "28 mm", "32 mm"] }
V0 = { catalogue = "accumulator_volumes", lower = "0.32 L", upper = "2 L" }
[his]
p0 = 2.0e6
Rv = 8e5
bore = "50 mm"
rod = "28 mm"
V0 = "1 L"
[his.charge]
gas_fraction = 0.7
[optimizer]
pop_size = 16
generations = 4
"""


@pytest.fixture(scope="module")
def parts() -> hisopt.Problem:
    return problem_from_dict(tomllib.loads(PARTS))


def test_a_catalogue_within_bounds_gives_its_listed_values(parts):
    assert parts.variable_names == ("p0", "Rv", "bore", "rod", "V0")
    choices = parts.choices
    np.testing.assert_array_equal(choices[2], [0.040, 0.050, 0.063, 0.080])  # ISO 3320 bores 40-80 mm
    np.testing.assert_array_equal(choices[3], [0.020, 0.025, 0.028, 0.032])
    np.testing.assert_array_equal(choices[4], [0.32e-3, 0.5e-3, 0.75e-3, 1.0e-3, 1.4e-3, 2.0e-3])
    assert list(parts.lower[2:]) == [0.040, 0.020, 0.32e-3] and list(parts.upper[2:]) == [0.080, 0.032, 2.0e-3]


def test_every_shipped_catalogue_reads_in_order():
    assert set(catalogue_names()) >= {"iso3320_bores", "iso3320_rods", "accumulator_volumes", "hose_bores"}
    bores = problem_from_dict(tomllib.loads(PARTS.replace('lower = "40 mm", upper = "80 mm"', 'lower = "8 mm", upper = "500 mm"')))
    # ISO 3320:2013 Table 1, every preferred bore
    expected = [8, 10, 12, 16, 20, 25, 32, 40, 50, 63, 80, 100, 125, 160, 200, 250, 320, 400, 500]
    np.testing.assert_array_equal(bores.choices[2], np.array(expected) / 1000)


def test_search_coordinates_move_along_each_list_and_round_trip(parts):
    adapter = HisoptPymooProblem(parts)
    assert adapter.xl[2] == -0.5 and adapter.xu[2] == 3.5  # four bores: places 0 to 3
    u = np.array([[1e6, 1e5, -0.5, 3.49, 2.2], [1e6, 1e5, 0.49, 0.51, 5.5]])
    x = adapter.decode(u)
    assert list(x[:, 2]) == [0.040, 0.040] and list(x[:, 3]) == [0.032, 0.025] and list(x[:, 4]) == [0.75e-3, 2.0e-3]
    assert np.array_equal(x[:, :2], u[:, :2])  # the continuous ones as they are
    np.testing.assert_array_equal(adapter.decode(adapter.encode(x)), x)


def test_the_batch_equals_design_by_design(parts):
    rng = np.random.default_rng(4)
    adapter = HisoptPymooProblem(parts)
    x = adapter.decode(adapter.xl + (adapter.xu - adapter.xl) * rng.random((12, 5)))
    batch = parts.evaluator()(x)
    for i in range(len(x)):
        alone = parts.evaluator()(x[i : i + 1])
        for name in parts.spec.objectives:
            # the same arithmetic in another batch shape; the BLAS may block it differently
            np.testing.assert_allclose(alone[name][0], batch[name][i], rtol=1e-12, atol=0)


def test_a_design_off_its_lists_is_flagged(parts):
    df = parts.evaluate(np.array([[2e6, 8e5, 0.050, 0.028, 1e-3], [2e6, 8e5, 0.051, 0.028, 1e-3]]))
    assert list(df["status"]) == ["ok", "out_of_bounds"]
    assert "bore = 0.051 is not one of its listed choices" in df.loc[1, "reason"]
    assert listed(np.array([0.036000000000000004, 0.0361]), np.array([0.032, 0.036, 0.040])).tolist() == [True, False]


def test_a_run_is_made_of_listed_parts_and_its_refinement_keeps_them(parts):
    from hisopt.optim.gradient.refine import refine_front

    result = hisopt.optimize(parts, seed=3)
    front = result.front
    assert len(front) > 0
    for j, values in parts.choices.items():
        assert listed(front[parts.variable_names[j]].to_numpy(dtype=float), values).all()
    refined = refine_front(parts, front, max_points=6)
    for j, values in parts.choices.items():
        assert listed(refined.front[parts.variable_names[j]].to_numpy(dtype=float), values).all()
    assert refined.hypervolume_after >= refined.hypervolume_before
    # each kept design, evaluated again, is no worse than its start in any objective, with its parts
    kept = refined.points[refined.points["accepted"]]
    assert len(kept) > 0
    names = list(parts.objective_names)
    again = parts.evaluate(kept[list(parts.variable_names)].to_numpy(dtype=float), log=False)
    start = front.iloc[kept["source_index"].to_numpy()]
    assert (again[names].to_numpy() <= start[names].to_numpy()).all()
    listed_columns = [parts.variable_names[j] for j in parts.choices]
    np.testing.assert_array_equal(kept[listed_columns].to_numpy(), start[listed_columns].to_numpy())


def test_a_sweep_of_a_choice_takes_its_listed_values(parts):
    np.testing.assert_array_equal(grid_values(parts, 2, 41), [0.040, 0.050, 0.063, 0.080])
    np.testing.assert_array_equal(grid_values(parts, 4, 3), [0.32e-3, 0.75e-3, 2.0e-3])  # places 0, 2 (2.5 rounded to even), 5


@pytest.mark.parametrize(
    "entry, key, message",
    [
        ('{ choices = ["50 mm", "40 mm"] }', "variables.bore.choices", "increasing order"),
        ('{ choices = ["50 mm"] }', "variables.bore.choices", "at least two"),
        ('{ choices = ["40 mm", "50 mm"], lower = "45 mm" }', "variables.bore", "one or the other"),
        ('{ choices = ["40 kg", "50 kg"] }', "variables.bore.choices.0", "length"),
        ('{ catalogue = "iso_bores" }', "variables.bore.catalogue", "unknown catalogue"),
        ('{ catalogue = "accumulator_volumes" }', "variables.bore.catalogue", "length"),
        ('{ catalogue = "iso3320_bores", lower = "41 mm", upper = "49 mm" }', "variables.bore", "at least two"),
        ('{ catalogue = "missing.csv" }', "variables.bore.catalogue", "not found"),
    ],
)
def test_bad_choices_are_one_line_naming_the_key(tmp_path, entry, key, message):
    text = PARTS.replace('bore = { catalogue = "iso3320_bores", lower = "40 mm", upper = "80 mm" }', f"bore = {entry}")
    path = tmp_path / "bad.toml"
    path.write_text(text)
    result = run_cli("evaluate", str(path))
    assert result.code == 2 and len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert key in result.stderr and message in result.stderr, result.stderr


@pytest.mark.parametrize(
    "csv, message",
    [
        ("bore\n40\n50\n", "expected columns named with their units"),
        ("bore [mm],rod\n40,20\n", "expected columns named with their units"),
        ("bore [mm],rod [mm]\n40,20\n50\n", "row 3"),  # a second column needs a value in every row
        ("bore [mm],rod [mm]\n40,20\n50,x\n", "row 3: rod 'x'; expected a positive finite number [mm]"),
        ("bore [mm]\n40\nfifty\n", "row 3"),
        ("bore [mm]\n50\n40\n", "increasing order"),
        ("# only a comment\n", "empty"),
    ],
)
def test_a_users_catalogue_file_is_read_or_refused_in_one_line(tmp_path, csv, message):
    (tmp_path / "mine.csv").write_text(csv)
    text = PARTS.replace('bore = { catalogue = "iso3320_bores", lower = "40 mm", upper = "80 mm" }', 'bore = { catalogue = "mine.csv" }')
    path = tmp_path / "problem.toml"
    path.write_text(text)
    result = run_cli("evaluate", str(path))
    assert result.code == 2 and len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert "mine.csv" in result.stderr and message in result.stderr, result.stderr


def test_a_users_catalogue_file_beside_the_problem(tmp_path):
    (tmp_path / "mine.csv").write_text("# our stock\nbore [in]\n1.5\n2\n2.5\n")
    text = PARTS.replace('bore = { catalogue = "iso3320_bores", lower = "40 mm", upper = "80 mm" }', 'bore = { catalogue = "mine.csv" }')
    (tmp_path / "problem.toml").write_text(text)
    p = hisopt.load_problem(tmp_path / "problem.toml")
    np.testing.assert_allclose(p.choices[2], [0.0381, 0.0508, 0.0635], rtol=1e-15)


def test_the_paper_problem_has_no_choices():
    assert hisopt.load_problem(DEFAULT_PROBLEM).choices == {}


def test_a_run_of_a_users_catalogue_keeps_its_values_in_the_copy(tmp_path):
    """The run directory's copy of the problem cannot find a catalogue file beside the
    original: it is the JSON specification, which holds the listed values."""
    from hisopt.optim.rundir import problem_copy

    (tmp_path / "mine.csv").write_text("bore [mm]\n40\n50\n63\n")
    text = PARTS.replace('bore = { catalogue = "iso3320_bores", lower = "40 mm", upper = "80 mm" }', 'bore = { catalogue = "mine.csv" }')
    (tmp_path / "problem.toml").write_text(text)
    name, raw, _ = problem_copy(hisopt.load_problem(tmp_path / "problem.toml"))
    assert name == "problem.json"
    spec = problem_from_dict(__import__("json").loads(raw)).spec
    assert spec.variables["bore"].choices == [0.040, 0.050, 0.063]
    shipped = tmp_path / "shipped.toml"
    shipped.write_text(PARTS)
    assert problem_copy(hisopt.load_problem(shipped))[0] == "problem.toml"  # a shipped name reads anywhere


def test_a_dump_reads_back(parts):
    assert problem_from_dict(parts.spec.model_dump(by_alias=True)).spec == parts.spec
    without_none = {k: v for k, v in parts.spec.model_dump(by_alias=True)["variables"]["rod"].items() if v is not None}
    data = parts.spec.model_dump(by_alias=True) | {"variables": parts.spec.model_dump(by_alias=True)["variables"] | {"rod": without_none}}
    assert problem_from_dict(data).spec == parts.spec  # as TOML writes it: no null, the bounds repeated
