"""The equal-handling NLP of the layout study without a C compilation (docs/model.md §15.4).

The layout study (and synthesis, which runs it) refines each layout's best design at the
handling limit by IPOPT on the CasADi model evaluated on CasADi's virtual machine
(``refine_constrained``, ``compile=False``); the old path compiled the model's node functions
to C first (``compile=True``). The points along the trade-off curve, and the equal-handling
NLPs with ``refine_method="slp"``, are solved by the batched SLP on the evaluator (steps
corrected back onto the limit). Compared here, from each catalogue layout's baseline design on
the paper's problem with the limit at the design's own roll gradient (so that the limit binds
from the start, the hard case for a linear programme): the refined ``sigma_aw`` of the paths.

Error budgets:

- SLP against IPOPT, ``log10(sigma_slp / sigma_ipopt) <= 2e-5`` (4.6e-5 relative): IPOPT
  stops once a trust-region round lowers ``(1 + rho) log10 sigma_aw`` by less than its
  ``min_gain`` (1e-5 decades), so it may stop that much short of its local optimum; the SLP
  stops once its radius falls below 1e-4 of the box or its model promises less than 1e-7,
  its last accepted steps gaining less than the same 1e-5 decades (measured: at most
  1.0e-5 decades short of IPOPT on the six). One-sided: the SLP runs four starts per design
  and may find a lower local optimum than IPOPT's one (axle_roll: 0.22 % lower).
- the virtual machine against the compiled code: the same operations in the same order, so
  identical numbers (0 seen on all six); were rounding to differ (another compiler or libm)
  it could alter IPOPT's path, each stopping within its ``min_gain``:
  ``|log10(sigma_vm / sigma_c)| <= 1e-5``.
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

IPOPT = RefineSettings(rounds=8)  # the layout study's (hisopt.studies.layout_tables)
VM_BUDGET = IPOPT.min_gain  # [decades] of sigma_aw, virtual machine against compiled
SLP_BUDGET = 2.0 * IPOPT.min_gain  # [decades] of sigma_aw the SLP may stay above IPOPT (module docstring)
FAST = ("roll_plane", "roll_plane_accumulator_valves")  # the second needs the most SLP steps


def _start(problem, name):
    """The layout's problem, its baseline design and that design's own roll gradient [rad/g]."""
    case = catalogue_case(problem, name).problem
    x0 = case.baseline.copy()
    limit = float(roll_gradient(case.model(x0[None, :]), case.spec.handling.gravity_moment)[0])
    return case, x0, limit


def _checked(case, point, limit, name):
    """[m/s^2] The refined sigma_aw, after checking the design with the standard evaluator."""
    assert point.accepted, name  # it improves on the baseline
    again = case.evaluate(point.x[None, :])
    assert bool(again["feasible"].iloc[0]), name
    assert float(roll_gradient(case.model(point.x[None, :]), case.spec.handling.gravity_moment)[0]) <= limit, name
    assert again["sigma_aw"].iloc[0] == pytest.approx(point.quantities["sigma_aw"], rel=1e-12), name
    return point.quantities["sigma_aw"]


def _slp_meets_ipopt(problem, name):
    case, x0, limit = _start(problem, name)
    slp = _checked(case, refine_constrained(case, x0, "sigma_aw", {"roll_gradient": limit}, method="slp"), limit, name)
    ipopt = _checked(case, refine_constrained(case, x0, "sigma_aw", {"roll_gradient": limit}, IPOPT, method="ipopt"), limit, name)
    assert np.log10(slp / ipopt) <= SLP_BUDGET, (name, slp, ipopt)


@pytest.mark.parametrize("name", FAST)
def test_slp_gives_ipopts_comfort_at_the_limit(problem, name):
    _slp_meets_ipopt(problem, name)


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in CATALOGUE_NAMES if n not in FAST])
def test_slp_gives_ipopts_comfort_at_the_limit_on_the_rest_of_the_catalogue(problem, name):
    _slp_meets_ipopt(problem, name)


def _vm_meets_compiled(problem, name):
    case, x0, limit = _start(problem, name)
    vm = refine_constrained(case, x0, "sigma_aw", {"roll_gradient": limit}, IPOPT, method="ipopt")
    c = refine_constrained(case, x0, "sigma_aw", {"roll_gradient": limit}, IPOPT, method="ipopt", compile=True)
    assert abs(np.log10(_checked(case, vm, limit, name) / _checked(case, c, limit, name))) <= VM_BUDGET, name


def test_ipopt_on_the_virtual_machine_gives_the_compiled_paths_comfort(problem):
    _vm_meets_compiled(problem, "roll_plane")


@pytest.mark.slow
@pytest.mark.parametrize("name", CATALOGUE_NAMES[1:])
def test_ipopt_on_the_virtual_machine_gives_the_compiled_paths_comfort_on_the_catalogue(problem, name):
    """The twin-accumulator layout alone compiles for minutes (its Jacobian's C code)."""
    _vm_meets_compiled(problem, name)


@pytest.mark.parametrize("method", ["slp", "ipopt"])
def test_the_study_paths_compile_nothing(problem, monkeypatch, method):
    def refuse(fn):
        raise AssertionError(f"{fn.name()} compiled")

    monkeypatch.setattr(casadi_model, "compiled", refuse)
    case, x0, limit = _start(problem, "roll_plane")
    point = refine_constrained(case, x0, "sigma_aw", {"roll_gradient": limit}, IPOPT if method == "ipopt" else None, method=method)
    assert point.accepted and point.quantities["roll_gradient"] <= limit
