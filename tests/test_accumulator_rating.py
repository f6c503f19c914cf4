"""The accumulators' pressure ratings by catalogue size (docs/model.md §16.8): the part you
would buy for a volume, its ratio and maximum working pressure from the catalogue's pressure
columns, checked against the sources' numbers written out here (HST's ratios, the Bosch
Rexroth HAD data sheet RE 50150's lowest pressures)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

import hisopt
from hisopt.hydraulics.parts_catalogue import BLADDER_RATIO, accumulator_rating, his_accumulator_rating, shipped_accumulator_ratings
from hisopt.problem import problem_from_dict
from hisopt.specification.catalogues import catalogue_accumulator_ratings
from tests.cli_inprocess import assert_one_line, run_cli

ROOT = Path(__file__).resolve().parents[1]
PARTS = ROOT / "problems" / "roll_plane_his_parts.toml"
BAR = 1e5

# size [L]: (ratio, lowest maximum working pressure [bar]) from the sources, by hand
SOURCES = {
    0.075: (8, 250),  # below HST's range: its smallest sizes' 8; Rexroth 250
    0.16: (8, 250),
    0.32: (8, 250),  # Rexroth lacks it: its next size 0.35 L, 250
    0.5: (8, 250),
    0.75: (8, 250),  # Rexroth lacks it: its next size 1.0 L, 250
    1.0: (8, 250),
    1.4: (8, 140),  # sold at 140/250/350
    2.0: (8, 100),  # 100/250/350
    2.8: (4, 70),  # HST <= 4; 70/250/350
    4.0: (4, 250),  # above both ranges: HST's 2.8 L ratio, Rexroth's largest (3.5 L) pressure
}


def test_the_shipped_catalogue_holds_its_sources_numbers():
    ratings = shipped_accumulator_ratings()
    np.testing.assert_allclose(ratings.volumes, np.array(list(SOURCES)) * 1e-3, rtol=1e-15)
    np.testing.assert_array_equal(ratings.ratios, [r for r, _ in SOURCES.values()])
    np.testing.assert_allclose(ratings.pressures, [p * BAR for _, p in SOURCES.values()], rtol=1e-15)


def test_a_volume_gets_the_rating_of_the_smallest_size_that_holds_it():
    volumes = np.array([[0.05, 0.075, 0.16, 0.161], [1.39, 1.4, 2.5, 4.0], [4.01, np.nan, 0.0, -1.0]]) * 1e-3
    ratio, pressure = accumulator_rating(volumes, "diaphragm")
    assert ratio.shape == pressure.shape == volumes.shape  # vectorised: the batch's shape back
    bought = np.array([[0.075, 0.075, 0.16, 0.32], [1.4, 1.4, 2.8, 4.0]])
    np.testing.assert_array_equal(ratio[:2], [[SOURCES[v][0] for v in row] for row in bought])
    np.testing.assert_allclose(pressure[:2], [[SOURCES[v][1] * BAR for v in row] for row in bought], rtol=1e-15)
    assert np.all(np.isnan(ratio[2])) and np.all(np.isnan(pressure[2]))  # no part to buy
    # a size read back from litres moves by an eps: still that size, not the next one
    assert accumulator_rating(1.4 * 1e-3 * (1 + 1e-15))[1] == pytest.approx(140 * BAR)


def test_a_bladder_and_the_problems_own_values_replace_the_catalogues():
    ratio, pressure = accumulator_rating(np.array([0.5e-3, 2.8e-3]), "bladder")
    assert BLADDER_RATIO == 4.0
    np.testing.assert_array_equal(ratio, [4.0, 4.0])
    np.testing.assert_allclose(pressure, [250 * BAR, 70 * BAR], rtol=1e-15)
    ratio, pressure = accumulator_rating(np.array([0.5e-3, 9e-3]), pressure_rating=6.0, max_working_pressure=2.1e7)
    np.testing.assert_array_equal(ratio, [6.0, 6.0])  # the data sheet's, at every volume
    np.testing.assert_array_equal(pressure, [2.1e7, 2.1e7])
    with pytest.raises(ValueError, match="separator"):
        accumulator_rating(1e-3, "piston")


def test_max_working_pressure_is_read_in_its_unit_and_overrides_the_size():
    text = PARTS.read_text(encoding="utf-8").replace('separator = "diaphragm"', 'separator = "bladder"\nmax_working_pressure = "210 bar"')
    his = problem_from_dict(tomllib.loads(text), str(PARTS), warn_implausible=False).spec.his
    assert his.max_working_pressure == pytest.approx(2.1e7, rel=1e-15)
    ratio, pressure = his_accumulator_rating(his, np.array([1.4e-3, 2.8e-3]))
    np.testing.assert_array_equal(ratio, [4.0, 4.0])
    np.testing.assert_allclose(pressure, [2.1e7, 2.1e7], rtol=1e-15)
    ratio, _ = his_accumulator_rating(his.model_copy(update={"pressure_rating": 3.0}), 1.4e-3)
    assert ratio == 3.0


def write_problem(tmp_path: Path, csv: str) -> Path:
    (tmp_path / "accumulators.csv").write_text(csv, encoding="utf-8")
    text = PARTS.read_text(encoding="utf-8").replace('catalogue = "accumulator_volumes"', 'catalogue = "accumulators.csv"')
    path = tmp_path / "problem.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_problems_own_accumulator_catalogue_gives_its_ratings(tmp_path):
    path = write_problem(tmp_path, "# our stock\nvolume [L], max_pressure_ratio [-], max_working_pressure [MPa]\n0.5, 6, 20\n1.0, 6, 18\n2.0, 5, 15\n")
    problem = hisopt.load_problem(path)
    ratings = catalogue_accumulator_ratings(problem.spec.variables["V0"].catalogue, path.parent)
    np.testing.assert_allclose(accumulator_rating(0.7e-3, ratings=ratings), (6.0, 18e6), rtol=1e-15)
    volumes_only = write_problem(tmp_path, "volume [L]\n0.5\n1.0\n2.0\n")  # the sizes alone: the shipped ratings
    ratings = catalogue_accumulator_ratings(hisopt.load_problem(volumes_only).spec.variables["V0"].catalogue, path.parent)
    assert ratings is shipped_accumulator_ratings()


@pytest.mark.parametrize(
    ("csv", "parts"),
    [
        ("volume [L], max_pressure_ratio [-], max_working_pressure [bar]\n0.5, 8, 250\n1.0, 8\n", ("row 3", "expected one in each of the 3 columns")),
        ("volume [L], max_pressure_ratio [-], max_working_pressure [bar]\n0.5, 8, 250\n1.0, 8, \n", ("row 3", "max_working_pressure ''")),
        ("volume [L], max_working_pressure [bar]\n0.5, 250\n1.0, 250\n", ("max_working_pressure column without max_pressure_ratio",)),
        ("volume [L], max_pressure_ratio [-], max_working_pressure [L]\n0.5, 8, 250\n1.0, 8, 250\n", ("max_working_pressure column's unit [L]",)),
        ("volume [L], max_pressure_ratio [-], max_working_pressure [bar]\n0.5, 8, 250\n1.0, 1, 250\n", ("row 3", "at or below 1")),
    ],
)
def test_an_accumulator_size_without_its_rating_is_refused_in_one_line(tmp_path, csv, parts):
    path = write_problem(tmp_path, csv)
    assert_one_line(run_cli("evaluate", str(path)), "accumulators.csv", "variables.V0.catalogue", *parts)
