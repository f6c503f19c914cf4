"""The equal-handling NLP of the layout study without a C compilation (docs/model.md §15.4).

The layout study (and synthesis, which runs it) refines each layout's best design at the
handling limit by IPOPT on the CasADi model evaluated on CasADi's virtual machine
(``refine_constrained``, ``compile=False``, the default). The old path compiled the model's
node functions to C first. Compared here, from each catalogue layout's baseline design with
the limit at its own roll gradient (so the constraint is active from the start): the refined
``sigma_aw`` of both paths, which run the same operations in the same order.

Error budget: were rounding to differ between the two (another compiler or libm), it could
alter IPOPT's path, but each path stops once a trust-region round lowers the merit
``(1 + rho) log10 sigma_aw`` by less than ``min_gain`` (1e-5): so the two results may differ
by that last round's gain, ``|log10(sigma_vm / sigma_c)| <= min_gain`` (2.3e-5 relative).
The same build of CasADi and a compiler without fast-math give identical numbers (0 seen).
"""

from __future__ import annotations

import numpy as np
import pytest

from hisopt.evaluation.evaluate import roll_gradient
from hisopt.hydraulics.catalogue import CATALOGUE_NAMES
from hisopt.optim.gradient import casadi_model
from hisopt.optim.gradient.asf_nlp import RefineSettings
from hisopt.optim.gradient.refine import refine_constrained
from hisopt.studies.layout_cases import catalogue_case

SETTINGS = RefineSettings(rounds=8)  # the layout study's (hisopt.studies.layout_tables)
BUDGET = SETTINGS.min_gain  # [decades] of sigma_aw between the two paths (module docstring)
FAST = ("roll_plane", "axle_roll")


def _start(problem, name):
    """The layout's problem, its baseline design and that design's own roll gradient [rad/g]."""
    case = catalogue_case(problem, name).problem
    x0 = case.baseline.copy()
    limit = float(roll_gradient(case.model(x0[None, :]), case.spec.handling.gravity_moment)[0])
    return case, x0, limit


def _both_paths_agree(problem, name):
    case, x0, limit = _start(problem, name)
    vm = refine_constrained(case, x0, "sigma_aw", {"roll_gradient": limit}, SETTINGS)
    c = refine_constrained(case, x0, "sigma_aw", {"roll_gradient": limit}, SETTINGS, compile=True)
    assert vm.accepted and c.accepted, name  # both improve on the baseline
    for point in (vm, c):
        again = case.evaluate(point.x[None, :])  # the standard evaluator, not the NLP's model
        assert bool(again["feasible"].iloc[0]), name
        assert float(roll_gradient(case.model(point.x[None, :]), case.spec.handling.gravity_moment)[0]) <= limit, name
        assert again["sigma_aw"].iloc[0] == pytest.approx(point.quantities["sigma_aw"], rel=1e-12), name
    assert abs(np.log10(vm.quantities["sigma_aw"] / c.quantities["sigma_aw"])) <= BUDGET, name


@pytest.mark.parametrize("name", FAST)
def test_virtual_machine_gives_the_compiled_paths_comfort(problem, name):
    _both_paths_agree(problem, name)


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in CATALOGUE_NAMES if n not in FAST])
def test_virtual_machine_gives_the_compiled_paths_comfort_on_the_rest_of_the_catalogue(problem, name):
    """The twin-accumulator layout alone compiles for minutes (its Jacobian's C code)."""
    _both_paths_agree(problem, name)


def test_the_study_path_compiles_nothing(problem, monkeypatch):
    def refuse(fn):
        raise AssertionError(f"{fn.name()} compiled")

    monkeypatch.setattr(casadi_model, "compiled", refuse)
    case, x0, limit = _start(problem, "roll_plane")
    point = refine_constrained(case, x0, "sigma_aw", {"roll_gradient": limit}, SETTINGS)
    assert point.accepted and point.quantities["roll_gradient"] <= limit
