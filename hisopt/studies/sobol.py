"""Sobol indices of any model that converge by themselves (docs/model.md §18.3).

:func:`sobol_indices` draws SALib's Saltelli sample over standard uniform factors, evaluates
the model and estimates first- and total-order indices with SALib's bootstrap intervals. By
default it doubles the base sample count until every interval's half-width is at most a
target, or a cap on evaluations or time stops it.

Doubling costs only the new rows. SALib's ``sobol.sample`` lays the sample out by base row
(``D + 2`` rows per base row of a scrambled Sobol sequence of dimension ``2 D``), and scipy's
``qmc.Sobol`` from one seed gives the same first ``N`` points whatever it is asked for, so the
sample at ``2 N`` starts with the sample at ``N``; SALib's ``skip_values = N`` fast-forwards
the same sequence past its first ``N`` points, so ``sample(N, skip_values=N)`` is exactly the
second half of ``sample(2 N)`` (tested). A converged run at ``N`` therefore equals a direct
run at ``N``, number for number.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hisopt.errors import ConfigError

CONFIDENCE = 0.95
TARGET_HALF_WIDTH = 0.05  # [-] every S1 and ST interval's half-width, by default
FIRST_N_BASE = 1024  # the first base sample count of a converging run (the fixed default before)
MAX_EVALUATIONS = 500_000  # model evaluations a converging run does not double past
DECADE = 10.0  # a positive quantity whose largest value is this many times its smallest is log-transformed

INDEX_COLUMNS = ("S1", "S1_conf", "ST", "ST_conf")


def check_n_base(n_base: int, key: str = "n_base") -> None:
    """Refuse a base sample count that is not a power of 2 of at least 2 (the Sobol
    sequence is balanced only at powers of 2), naming ``key``."""
    if isinstance(n_base, bool) or not isinstance(n_base, (int, np.integer)) or n_base < 2 or n_base & (n_base - 1):
        raise ConfigError(f"expected a power of 2 of at least 2 (Sobol sequences balance at powers of 2); got {n_base!r}", key=key)


def check_convergence_settings(
    target: float, max_evaluations: int, max_seconds: float | None, keys: tuple[str, str, str] = ("target", "max_evaluations", "max_seconds")
) -> None:
    """Refuse a target half-width or a cap that cannot stop a run, naming the argument by its
    ``keys`` (the CLI's option names, or the library's argument names)."""
    if isinstance(target, bool) or not isinstance(target, (int, float, np.number)) or not (np.isfinite(target) and target > 0):
        raise ConfigError(f"expected a half-width above 0; got {target!r}", key=keys[0])
    if isinstance(max_evaluations, bool) or not isinstance(max_evaluations, (int, np.integer)) or max_evaluations < 1:
        raise ConfigError(f"expected a positive number of evaluations; got {max_evaluations!r}", key=keys[1])
    if max_seconds is not None and (
        isinstance(max_seconds, bool) or not isinstance(max_seconds, (int, float, np.number)) or not (np.isfinite(max_seconds) and max_seconds > 0)
    ):
        raise ConfigError(f"expected a time above 0 s; got {max_seconds!r}", key=keys[2])


def decade_span(values: np.ndarray) -> tuple[float, float] | None:
    """The smallest and largest finite value of a quantity that spans more than a decade and is
    positive everywhere (so its ``log10`` exists); None otherwise."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0 or np.min(v) <= 0:
        return None
    low, high = float(np.min(v)), float(np.max(v))
    return (low, high) if high > DECADE * low else None


@dataclass(frozen=True)
class SobolIndices:
    """First- and total-order Sobol indices of a model's outputs and how they were reached.

    Attributes
    ----------
    indices : pd.DataFrame
        [-] one row per (output, factor): ``quantity``, ``input``, ``S1``, ``S1_conf``, ``ST``,
        ``ST_conf`` (half-widths at :data:`CONFIDENCE`)
    n_base : int
        [-] base samples used (``N``; the model saw ``N (D + 2)`` rows)
    evaluations : int
        [-] model evaluations
    dropped : int
        [-] blocks of ``D + 2`` rows dropped for the output that lost most (a failed model)
    stop : str
        [-] why the run stopped: ``"fixed"`` (a count was given), ``"converged"``,
        ``"evaluations"`` (the next doubling would pass the evaluation cap) or ``"time"``
    target : float
        [-] the half-width every interval was to reach
    unconverged : pd.DataFrame
        [-] the intervals wider than ``target``: ``quantity``, ``input``, ``index`` (S1 or
        ST), ``half_width``, widest first
    logged : dict[str, tuple[float, float]]
        [output units] the outputs whose indices are of ``log10``, with their smallest and
        largest value over the samples
    seconds : float
        [s] wall time of the run
    """

    indices: pd.DataFrame
    n_base: int
    evaluations: int
    dropped: int
    stop: str
    target: float
    unconverged: pd.DataFrame
    logged: dict[str, tuple[float, float]]
    seconds: float


def sobol_indices(
    names: Sequence[str],
    model: Callable[[np.ndarray], Mapping[str, np.ndarray]],
    n_base: int | None = None,
    seed: int = 0,
    resamples: int = 250,
    log: bool | None = None,
    target: float = TARGET_HALF_WIDTH,
    start: int = FIRST_N_BASE,
    max_evaluations: int = MAX_EVALUATIONS,
    max_seconds: float | None = None,
) -> SobolIndices:
    """First- and total-order Sobol indices of every output of ``model`` with respect to
    factors ``names``, each standard uniform on (0, 1) (``model`` maps them to its inputs).

    SALib's Saltelli sample (Sobol sequence, ``N (D + 2)`` rows, no second order) and its
    estimators (Saltelli 2010, Jansen) with bootstrap intervals at :data:`CONFIDENCE` from
    ``resamples`` resamples (250: a half-width to a few per cent). A block of ``D + 2`` rows
    with a NaN output is dropped for that output (SALib would read NaN as zero variance).

    With ``n_base``, exactly that many base samples. Without, ``start`` base samples, doubled
    (reusing every evaluated row) until every ``S1`` and ``ST`` half-width is at most
    ``target``, or the next doubling would pass ``max_evaluations`` evaluations, or (with
    ``max_seconds``) take the run past that time: it costs about as long as the run so far.
    The evaluation cap keeps the run deterministic; a time cap makes where it stops depend on
    the machine (the numbers at a given ``N`` do not). An index whose interval is NaN (an
    output constant over the samples, or failed in every block) has nothing to wait for.

    ``log``: None (default) takes ``log10`` of each output that is positive and spans more than
    a decade over the samples (:func:`decade_span`), decided again at each doubling over all
    the samples; True of every output (a value <= 0 then fails its block); False of none.
    """
    if n_base is not None:
        check_n_base(n_base)
    check_n_base(start, key="start")
    check_convergence_settings(target, max_evaluations, max_seconds)
    from SALib.sample import sobol as sobol_sample

    started = time.perf_counter()
    d = len(names)
    problem = {"num_vars": d, "names": list(names), "bounds": [[0.0, 1.0]] * d}
    n = start if n_base is None else n_base
    outputs = {
        k: np.asarray(v, dtype=float) for k, v in model(np.asarray(sobol_sample.sample(problem, n, calc_second_order=False, scramble=True, seed=seed))).items()
    }
    while True:
        indices, dropped, logged = _analyse(problem, outputs, seed, resamples, log)
        unconverged = _wider_than(indices, target)
        if n_base is not None:
            stop = "fixed"
        elif unconverged.empty:
            stop = "converged"
        elif 2 * n * (d + 2) > max_evaluations:
            stop = "evaluations"
        elif max_seconds is not None and 2 * (time.perf_counter() - started) > max_seconds:
            stop = "time"
        else:
            # the sample at 2n is the sample at n followed by these rows (module docstring)
            extra = np.asarray(sobol_sample.sample(problem, n, calc_second_order=False, scramble=True, skip_values=n, seed=seed))
            more = model(extra)
            outputs = {k: np.concatenate([v, np.asarray(more[k], dtype=float)]) for k, v in outputs.items()}
            n *= 2
            continue
        return SobolIndices(indices, n, n * (d + 2), dropped, stop, target, unconverged, logged, time.perf_counter() - started)


def _analyse(
    problem: dict, outputs: Mapping[str, np.ndarray], seed: int, resamples: int, log: bool | None
) -> tuple[pd.DataFrame, int, dict[str, tuple[float, float]]]:
    """SALib's estimators on every output (transformed as ``log`` says), failed blocks dropped."""
    from SALib.analyze import sobol as sobol_analyze

    names, d = problem["names"], problem["num_vars"]
    rows, dropped, logged = [], 0, {}
    for out_name, y in outputs.items():
        span = decade_span(y) if log is None else (float(np.nanmin(y)), float(np.nanmax(y))) if log else None
        if span is not None:
            logged[out_name] = span
            with np.errstate(divide="ignore", invalid="ignore"):
                y = np.where(y > 0, np.log10(np.where(y > 0, y, 1.0)), np.nan)
        blocks = y.reshape(-1, d + 2)
        keep = np.all(np.isfinite(blocks), axis=1)
        dropped = max(dropped, int(np.sum(~keep)))
        kept = blocks[keep].ravel()
        if keep.sum() < 2 or np.ptp(kept) == 0:  # no variance to share out: no indices
            rows += [{"quantity": out_name, "input": n} | dict.fromkeys(INDEX_COLUMNS, np.nan) for n in names]
            continue
        # SALib seeds its bootstrap only for a truthy seed (SALib 1.6, analyze/sobol.py): seed 0
        # would draw fresh resamples each call, so the intervals get seed + 1, never 0
        si = sobol_analyze.analyze(problem, kept, calc_second_order=False, num_resamples=resamples, conf_level=CONFIDENCE, seed=seed + 1)
        rows += [{"quantity": out_name, "input": n} | {c: float(si[c][j]) for c in INDEX_COLUMNS} for j, n in enumerate(names)]
    return pd.DataFrame(rows, columns=["quantity", "input", *INDEX_COLUMNS]), dropped, logged


def _wider_than(indices: pd.DataFrame, target: float) -> pd.DataFrame:
    """The finite intervals wider than ``target`` (NaN ones have nothing to wait for), widest first."""
    parts = [
        pd.DataFrame({"quantity": indices["quantity"], "input": indices["input"], "index": index, "half_width": indices[f"{index}_conf"]})
        for index in ("S1", "ST")
    ]
    table = pd.concat(parts, ignore_index=True)
    wide = table[table["half_width"] > target]  # NaN never compares above
    return wide.sort_values("half_width", ascending=False, kind="stable").reset_index(drop=True)
