"""How the evaluator plans its integrals: which outputs it evaluates and which it derives
from them, which ``(output, weighting)`` integrals the metrics ask for, and the comfort
weightings' polynomials (docs/model.md §10)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from hisopt.coupled.response import Output
from hisopt.evaluation.psd import reduce_metrics
from hisopt.standards import iso_2631_1_1997 as iso2631

if TYPE_CHECKING:
    from hisopt.metrics import Metric
    from hisopt.specification.config import Comfort


def integral_keys(metrics: list[Metric], comfort: Comfort, outputs: dict[str, Output], n_accumulators: int) -> list[tuple[str, str | None]]:
    """The ``(output, weighting)`` integrals :func:`hisopt.evaluation.psd.reduce_metrics` asks for (found
    by running it once on placeholders, so the dispatch stays in one place)."""
    keys: list[tuple[str, str | None]] = []

    def record(output: str, weighting: str | None) -> float:
        keys.append((output, weighting))
        return 0.0

    reduce_metrics(
        metrics,
        comfort,
        lambda name: outputs[name].weighting,  # type: ignore[arg-type,return-value]
        record,
        lambda o: 0.0,
        lambda n: 0.0,
        lambda n: 0.0,
        lambda: [1.0] * n_accumulators,
        lambda n: 0.0,  # the rules' integrals: the evaluator's build_outputs
    )
    return list(dict.fromkeys(keys))


def padded_polynomials(weightings: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """The weightings' ``|W|^2`` numerators and denominators in ``f^2``, zero-padded to common
    lengths, ``(W, D)`` each (``(0, 1)`` for none)."""
    pairs = [iso2631.weighting_gain_polynomials(wt) for wt in weightings]  # type: ignore[arg-type]
    out = []
    for part in (0, 1):
        width = max([len(p[part]) for p in pairs], default=1)
        out.append(np.array([np.pad(p[part], (0, width - len(p[part]))) for p in pairs]).reshape(len(pairs), width))
    return out[0], out[1]


def total(terms: np.ndarray) -> np.ndarray:
    """Row sums in sequential order (zero-weight padding nodes add exact zeros)."""
    return np.cumsum(terms, axis=1)[:, -1]


def derived_psd(rule: tuple[str, float, int], f_hz: np.ndarray, base_psd: np.ndarray) -> np.ndarray:
    """PSD of an output from its base's by its ``rule`` ``(base, scale, p)`` of
    :func:`_share_outputs`: ``scale^2 omega^(2p) S_base``."""
    _, scale, power = rule
    if power == 0 and scale == 1.0:
        return base_psd
    factor = np.full(f_hz.shape, scale**2)
    omega2 = np.square(2 * np.pi * f_hz)
    for _ in range(power):
        factor *= omega2
    return factor * base_psd


def share_outputs(outputs: dict[str, Output]) -> tuple[dict[str, Output], dict[str, tuple[str, float, int]]]:
    """Evaluate fewer FRFs: an output ``s^p (c . X)`` is a multiple of a displacement output.

    Returns the base outputs to evaluate and, per output, ``(base, scale, p)`` with
    ``S_y = scale^2 omega^(2p) S_base`` (e.g. ``acc_y = -h_0s phi''`` from ``roll``).
    """
    bases: dict[str, Output] = {}
    derived: dict[str, tuple[str, float, int]] = {}
    pure: dict[str, np.ndarray] = {}  # base name -> displacement vector of a pure (p = 0, no road term) base
    for name, out in outputs.items():
        rows = np.flatnonzero(np.any(out.c != 0, axis=1))
        if len(rows) != 1 or np.any(out.d):
            bases[name], derived[name] = out, (name, 1.0, 0)
            continue
        p, vec = int(rows[0]), out.c[rows[0]]
        k = int(np.flatnonzero(vec)[0])
        for bname, bvec in pure.items():
            if bvec.shape == vec.shape and np.allclose(vec * bvec[k], bvec * vec[k], rtol=0, atol=0):
                derived[name] = (bname, float(vec[k] / bvec[k]), p)
                break
        else:
            bases[name] = Output(name, out.unit, vec[None, :], np.zeros((1, 4)), out.weighting)
            pure[name] = vec
            derived[name] = (name, 1.0, p)
    return bases, derived
