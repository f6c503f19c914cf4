from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import hisopt

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_PROBLEM = ROOT / "problems" / "roll_plane_his.toml"


@pytest.fixture(scope="session")
def problem() -> hisopt.Problem:
    return hisopt.load_problem(DEFAULT_PROBLEM)


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261121)


def random_designs(problem: hisopt.Problem, n: int, rng: np.random.Generator, corners: bool = True) -> np.ndarray:
    """Uniform designs in the box, plus every corner of it when ``corners``."""
    lo, hi = problem.lower, problem.upper
    x = lo + (hi - lo) * rng.random((n, lo.size))
    if corners:
        grid = np.array(np.meshgrid(*[[0, 1]] * lo.size, indexing="ij")).reshape(lo.size, -1).T
        x = np.vstack([x, lo + (hi - lo) * grid])
    return x


RATING_QUANTITIES = ("static_pressure_ratio", "pressure_rating_usage")
"""The accumulator rating quantities: +inf (beyond any rating) at a zero gauge precharge, a
corner of the paper's box (docs/model.md §16.8)."""


def every_quantity(steps: bool = True, swing: bool = False, rating: bool = False, build: bool = False) -> tuple[list[str], list[dict[str, object]]]:
    """Objectives and constraints of a problem that evaluates every registered quantity: those
    that may be minimised as objectives, the others as constraints with a limit never met
    (``steps=False``: without the step-response quantities, docs/model.md §6.6; ``swing``:
    with ``accumulator_swing``, which only a charged HIS has, §16.9; ``rating``: with
    :data:`RATING_QUANTITIES`, +inf for a design without precharge, §16.8; ``build``: with the
    buildability rules' usages, §21, tested in tests/test_buildability.py)."""
    from hisopt.evaluation.transient import STEP_NAMES
    from hisopt.metrics import METRICS

    kinds = {"swing": swing, "build": build}
    objectives = [name for name, m in METRICS.items() if m.objective and (steps or name not in STEP_NAMES) and kinds.get(m.kind, True)]
    return objectives, [{"name": name, "limit": 1e-12} for name, m in METRICS.items() if not m.objective and (rating or name not in RATING_QUANTITIES)]


def _summary_lines() -> list[str]:
    """The outcome counts of the mutation corpus (tests/test_mutations.py) and the decision
    room's brush times (tests/test_decision_room.py), if they ran in this process."""
    import sys

    lines = []
    module = sys.modules.get("tests.test_mutations")
    for corpus, counts in (module.COUNTS if module is not None else {}).items():
        if counts:
            parts = ", ".join(f"{outcome}: {n}" for outcome, n in sorted(counts.items()))
            lines.append(f"mutation corpus, {corpus}: {sum(counts.values())} ({parts})")
    room = sys.modules.get("tests.test_decision_room")
    for archive, ms in (room.TIMINGS if room is not None else {}).items():
        lines.append(f"decision room in headless Chromium: {archive}: every view updated in {ms:.0f} ms")
    return lines


_WORKER_LINES: list[str] = []
"""Under pytest-xdist: the summary lines each worker sent back (the tests ran there)."""


def pytest_sessionfinish(session) -> None:
    """An xdist worker hands its summary lines to the controller, which prints them."""
    workeroutput = getattr(session.config, "workeroutput", None)
    if workeroutput is not None:
        workeroutput["hisopt_summary"] = _summary_lines()


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error) -> None:
    """An xdist hook, called on the controller as each worker ends: keep its summary lines."""
    _WORKER_LINES.extend(getattr(node, "workeroutput", {}).get("hisopt_summary", []))


def pytest_terminal_summary(terminalreporter) -> None:
    """Print the summary lines of :func:`_summary_lines`, from this process or the xdist workers."""
    for line in _summary_lines() + _WORKER_LINES:
        terminalreporter.write_line(line)
