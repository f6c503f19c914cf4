"""Cost and accuracy of the ISO 2631-1 weightings in the time domain.

``hisopt.standards.weighting_filters.weighted_signal`` (the exact integration of the Annex A
filter on the records' cubic splines, batched over records; docs/model.md §22.1) against the
straightforward baseline, ``scipy.signal.lsim`` with its first-order hold (``interp=True``)
on the same zero-pole-gain filter, record by record. Both run in one process with one BLAS
thread on the same random records (35 s at 2.5 ms, what the verification simulates); the
baseline on the first ``--loop`` records, extrapolated per record. It prints records per CPU
second of each and their ratio, and each one's amplitude error against the analytic weighting
(``weighting_response``) on sinusoids at 12 Hz and 80 Hz (5 samples per period at 2.5 ms),
beside the closed-form errors (``|G| / |W| - 1``, ``G`` the sum over the images ``f + k/dt`` of
``W`` times the interpolation's gain: ``sinc^4 3 / (2 + cos)`` for the spline,
``sampled_response``; ``sinc^2`` for the hold). The records are white, so the largest
difference printed between the two is where they differ most, near the Nyquist frequency.

    python benchmarks/bench_weighting_filters.py [--records 256] [--loop 8] [--weighting Wk] [--repeats 3]
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.signal import lsim  # noqa: E402

from hisopt.standards import iso_2631_1_1997 as iso  # noqa: E402
from hisopt.standards import weighting_filters as wf  # noqa: E402

DT_S = 2.5e-3
RECORD_S = 35.0


def least_cpu(run, repeats: int) -> tuple[float, np.ndarray]:
    best, out = np.inf, np.empty(0)
    for _ in range(repeats):
        start = time.process_time()
        out = run()
        best = min(best, time.process_time() - start)
    return best, out


def baseline(records: np.ndarray, name: str) -> np.ndarray:
    """``scipy.signal.lsim`` (first-order hold), one record at a time."""
    zpk = wf.weighting_zpk(name)
    t = np.arange(records.shape[-1]) * DT_S
    system = (zpk.zeros_rad_s, zpk.poles_rad_s, zpk.gain)
    return np.array([lsim(system, record, t, interp=True)[1] for record in records])


def amplitude_error(filtered: np.ndarray, f_hz: float, name: str) -> float:
    """``|gain| / |W(f)| - 1`` of a filtered unit cosine, by least squares on cos and sin
    over the settled part (the last 0.1 s left out: the spline's end)."""
    t = np.arange(filtered.size) * DT_S
    keep = (t >= wf.settling_time_s(name, 1e-9)) & (t < t[-1] - 0.1)
    basis = np.stack([np.cos(2 * np.pi * f_hz * t[keep]), np.sin(2 * np.pi * f_hz * t[keep])], axis=-1)
    coef = np.linalg.lstsq(basis, filtered[keep], rcond=None)[0]
    return float(np.hypot(*coef) / abs(iso.weighting_response(f_hz, name)) - 1.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--records", type=int, default=256)
    parser.add_argument("--loop", type=int, default=8)
    parser.add_argument("--weighting", default="Wk")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    name = args.weighting
    rng = np.random.default_rng(41)
    records = rng.standard_normal((args.records, round(RECORD_S / DT_S)))

    ours_s, ours = least_cpu(lambda: wf.weighted_signal(records, DT_S, name), args.repeats)
    loop_s, theirs = least_cpu(lambda: baseline(records[: args.loop], name), args.repeats)
    ours_rate, loop_rate = args.records / ours_s, args.loop / loop_s
    print(f"{name}, {args.records} records of {RECORD_S:g} s at {DT_S * 1e3:g} ms ({records.shape[-1]} samples), one core:")
    print(f"  weighted_signal (spline, exact, batched): {ours_rate:10.1f} records/s")
    print(f"  scipy.signal.lsim (first-order hold):     {loop_rate:10.1f} records/s  ({args.loop} records)")
    print(f"  ratio: {ours_rate / loop_rate:.1f}")
    scale = np.abs(ours[: args.loop]).max()
    print(f"  largest difference on the white records: {np.abs(ours[: args.loop] - theirs).max() / scale:.2e} of the largest output")

    t = np.arange(round(RECORD_S / DT_S)) * DT_S
    print("amplitude error against the analytic weighting (measured; closed form):")
    for f_hz in (12.0, 80.0):
        cosine = np.cos(2 * np.pi * f_hz * t)
        ours_error = amplitude_error(wf.weighted_signal(cosine, DT_S, name), f_hz, name)
        hold_error = amplitude_error(baseline(cosine[None], name)[0], f_hz, name)
        w = abs(iso.weighting_response(f_hz, name))
        spline = abs(wf.sampled_response(f_hz, DT_S, name)) / w - 1.0
        images = f_hz + np.arange(-64, 65) / DT_S
        hold = abs(np.sum(iso.weighting_response(images, name) * np.sinc(images * DT_S) ** 2)) / w - 1.0
        print(f"  {f_hz:4g} Hz: spline {ours_error:+.2e} ({spline:+.2e}); first-order hold {hold_error:+.2e} ({hold:+.2e})")


if __name__ == "__main__":
    main()
