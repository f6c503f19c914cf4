"""Compile every numba kernel a run uses ahead of the first run: ``python -m hisopt.optim.warmup``.

README's set-up runs this once after ``pip install`` (docs/model.md §10.7): the evaluator's
kernels (:mod:`hisopt.evaluation.warmup`, compiled by signature without evaluating anything)
and the run's own, namely the archive update (:mod:`hisopt.optim.archive`), the progress
hypervolume (:mod:`hisopt.optim.convergence`) and the SMS-EMOA survival
(:mod:`hisopt.optim.hv_survival`). Those three are compiled by one call each on a tiny input
of the array types a run passes; the results are discarded. Later runs load the machine code
from numba's cache; nothing a run computes changes.
"""

from __future__ import annotations

import sys
import time

import numpy as np


def compile_run_kernels() -> float:
    """[s] Compile (or load from numba's cache) the optimiser's kernels; the time taken."""
    from hisopt.optim.archive import Archive
    from hisopt.optim.convergence import ProgressHypervolume
    from hisopt.optim.hv_survival import greedy_least_contributor_removal

    start = time.perf_counter()
    f = np.array([[1.0, 2.0, 3.0, 4.0], [2.0, 1.0, 4.0, 3.0], [3.0, 3.0, 1.0, 1.0]])
    archive = Archive.empty(2, 4, 4)
    for batch in range(2):  # the first offer meets an empty archive, the second a filled one
        g = f - batch
        archive = archive.update(np.zeros((3, 2)), g, g.copy(), np.arange(3, dtype=np.int64) + 3 * batch, np.ones(3, dtype=bool))
    ProgressHypervolume(np.full(4, 5.0)).add(f)
    greedy_least_contributor_removal(f, np.full(4, 5.0), 1)
    return time.perf_counter() - start


def main() -> None:
    """Compile the evaluator's and the optimiser's kernels and say how long it took."""
    from numba.core import config

    from hisopt.evaluation.warmup import compile_kernels

    where = config.CACHE_DIR or "__pycache__ next to the hisopt modules (or numba's user cache)"
    seconds = compile_kernels(lambda line: print(f"  {line}", file=sys.stderr))
    seconds += compile_run_kernels()
    print(f"hisopt: evaluator and optimiser kernels compiled and cached in {seconds:.1f} s ({where})")


if __name__ == "__main__":
    main()
