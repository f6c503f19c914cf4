"""Compiling ahead (hisopt.evaluation.warmup, docs/model.md §10.7): the warm-up compiles every
type the evaluator passes to a kernel, so a run after it compiles nothing. No timing here
(benchmarks/bench_first_run.py prints the seconds)."""

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from numba.core.registry import CPUDispatcher

from hisopt.evaluation import kernels
from hisopt.evaluation.warmup import SIGNATURES
from tests.conftest import DEFAULT_PROBLEM, ROOT

_USED_TYPES = textwrap.dedent(
    """
    import json
    import sys
    import numpy as np
    from numba.core.registry import CPUDispatcher
    import hisopt
    from hisopt.evaluation import kernels
    from hisopt.evaluation.warmup import SIGNATURES
    from hisopt.problem import problem_from_dict
    from tests.conftest import every_quantity, random_designs

    problem = hisopt.load_problem(sys.argv[1])
    data = problem.spec.model_dump(by_alias=True)
    data["objectives"], data["constraints"] = every_quantity()
    data["comfort"]["method"] = "band"
    data["road"]["coherence"] = "isotropic"
    variants = [problem_from_dict(data, "every-quantity-band-isotropic")] + [hisopt.load_problem(p) for p in sys.argv[2:]]
    rng = np.random.default_rng(5)
    for p in variants:
        for n in (1, 5):
            p.evaluate(random_designs(p, n, rng, corners=False))
    used = {name: d.signatures for name, d in vars(kernels).items() if isinstance(d, CPUDispatcher) and name in SIGNATURES}
    print(json.dumps({
        "unused": sorted(name for name in SIGNATURES if not used.get(name)),
        "not warmed up": sorted(f"{name}{sig}" for name, sigs in used.items() for sig in sigs if sig not in SIGNATURES[name]),
    }))
    """
)


def test_warmup_names_only_kernels():
    dispatchers = {name for name, d in vars(kernels).items() if isinstance(d, CPUDispatcher)}
    assert set(SIGNATURES) <= dispatchers, "a SIGNATURES key is not a kernel of hisopt.evaluation.kernels"


@pytest.mark.slow
def test_the_evaluator_uses_only_the_warmed_up_types():
    """In a new process (its kernels hold only what it uses): every (kernel, argument types)
    the evaluator uses on the shipped problems and on a variant that changes its arrays (band
    comfort, isotropic coherence, every quantity), for one design and for a batch, is one the
    warm-up compiles; and every kernel the warm-up compiles is used (the check sees calls)."""
    problems = [str(p) for p in sorted((ROOT / "problems").glob("roll_plane_his*.toml"))]
    out = subprocess.run([sys.executable, "-c", _USED_TYPES, str(DEFAULT_PROBLEM), *problems], cwd=ROOT, check=True, capture_output=True, text=True)
    found = json.loads(out.stdout.splitlines()[-1])
    assert found == {"unused": [], "not warmed up": []}


_COUNT_COMPILES = textwrap.dedent(
    """
    import sys
    import numba
    from numba.core import event
    import numpy as np
    import hisopt
    from tests.conftest import random_designs

    problem = hisopt.load_problem(sys.argv[1])
    with event.install_recorder("numba:compile") as run:
        for n in (1, 5):
            problem.evaluate(random_designs(problem, n, np.random.default_rng(n), corners=False))
        hisopt.optimize(problem, pop_size=12, generations=3)  # the optimiser's kernels too
    with event.install_recorder("numba:compile") as control:  # the count sees a compile
        numba.njit(lambda x: x + 1)(1)
    print(sum(1 for _, e in run.buffer if e.is_start), sum(1 for _, e in control.buffer if e.is_start))
    """
)


@pytest.mark.slow
def test_after_the_warmup_a_run_compiles_nothing(tmp_path):
    """In a fresh numba cache: the warm-up, then an evaluation and a short run in a new process load every
    kernel from the cache (no compile event), while a function not warmed up does compile."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    subprocess.run([sys.executable, "-m", "hisopt.optim.warmup"], env=env, check=True, capture_output=True)
    out = subprocess.run([sys.executable, "-c", _COUNT_COMPILES, str(DEFAULT_PROBLEM)], cwd=ROOT, env=env, check=True, capture_output=True, text=True)
    run, control = (int(v) for v in out.stdout.split())
    assert control > 0
    assert run == 0


def test_warmup_compiles_what_a_call_would(tmp_path):
    """The warm-up's types are the ones a call with the callers' arrays has (a kernel called
    with them after ``compile`` adds no signature)."""
    a = np.ascontiguousarray(np.random.default_rng(1).normal(size=(2, 4, 4)))
    kernels.balance.compile(SIGNATURES["balance"][0])
    count = len(kernels.balance.signatures)
    kernels.balance(a, 3)
    assert len(kernels.balance.signatures) == count
