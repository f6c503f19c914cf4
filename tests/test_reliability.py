"""Property-based checks: hand-edited problem files and designs anywhere in the box."""

import copy
import os
import tomllib
import warnings

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import hisopt
from hisopt.problem import problem_from_dict
from tests.conftest import DEFAULT_PROBLEM

BASE = tomllib.loads(DEFAULT_PROBLEM.read_text())


def _paths(data, prefix=()):
    for key, value in data.items():
        yield prefix + (key,)
        if isinstance(value, dict):
            yield from _paths(value, prefix + (key,))


PATHS = list(_paths(BASE))
VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(10**6), 10**6),
    st.text(max_size=8),
    st.booleans(),
    st.lists(st.floats(-1e3, 1e3), max_size=3),
    st.dictionaries(st.text(min_size=1, max_size=5), st.floats(-1, 1), max_size=2),
)


@st.composite
def mutated(draw):
    data = copy.deepcopy(BASE)
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(PATHS))
        parent = data
        for key in path[:-1]:
            parent = parent.get(key) if isinstance(parent, dict) else None
            if not isinstance(parent, dict):
                break
        if not isinstance(parent, dict):
            continue
        action = draw(st.sampled_from(["replace", "delete", "add"]))
        if action == "replace":
            parent[path[-1]] = draw(VALUES)
        elif action == "delete":
            parent.pop(path[-1], None)
        else:
            parent[draw(st.text(min_size=1, max_size=6))] = draw(VALUES)
    return data


@settings(max_examples=int(os.environ.get("HISOPT_HYPOTHESIS_EXAMPLES", 300)), deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated())
def test_mutated_problem_files_load_or_fail_with_one_clear_line(data):
    """A mutated file loads (perhaps with plausibility warnings, each one line naming the file
    and key: hisopt.plausibility) or fails with one clear line."""
    from hisopt.errors import PlausibilityWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("error")
        warnings.simplefilter("always", PlausibilityWarning)
        try:
            problem = problem_from_dict(data, "edited.toml")
        except hisopt.ConfigError as exc:
            msg = str(exc)
            assert msg.startswith("edited.toml"), msg
            assert "\n" not in msg and len(msg) < 400, msg
            assert isinstance(exc, ValueError)
        else:
            assert len(problem.variable_names) == len(problem.lower)
            assert np.all(problem.lower < problem.upper)
    for w in caught:
        assert issubclass(w.category, PlausibilityWarning), w
        msg = str(w.message)
        assert msg.startswith("edited.toml: ") and "\n" not in msg and len(msg) < 400, msg


@st.composite
def designs(draw):
    lo = np.array([0.0, 1e-4, 0.1, 0.0])
    hi = np.array([4e6, 25e-4, 0.8, 16e5])
    # Each coordinate: an edge of the box (p0 = 0, Rv = 0, corners) or any interior value.
    u = [draw(st.one_of(st.sampled_from([0.0, 1.0]), st.floats(0.0, 1.0))) for _ in range(4)]
    return lo + (hi - lo) * np.array(u)


@settings(max_examples=60, deadline=None)
@given(st.lists(designs(), min_size=1, max_size=6))
def test_random_designs_give_finite_objectives_without_warnings(problem, rows):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        df = problem.evaluate(np.array(rows))
    values = df[list(problem.objective_names)].to_numpy()
    assert np.all(np.isfinite(values)) and np.all(values > 0)
    assert df["feasible"].all()
