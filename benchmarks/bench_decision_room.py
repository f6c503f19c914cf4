"""The decision room at scale: file size, build time and the time a brush takes to update
every view in headless Chromium, against a straightforward drawing in the same page.

For each archive: the default run (``hisopt optimize problems/roll_plane_his.toml``, 200
generations of 100: its front and its other evaluations) and a longer one
(``--gens 400``: 40,000 evaluations, the page's cap of 20,000 designs), it

- builds the page (``hisopt.report.decision_room``: re-evaluation, parts, curves, encoding)
  and reports its size;
- loads it in Debian's headless Chromium (selenium and chromium-driver; ``--disable-gpu``,
  software rendering) and brushes the ``sigma_aw`` axis ``--brushes`` times with the mouse
  over ranges of 20 % to 80 % of its height, reading the page's own clock of each update
  (filters, table, count, navigation, every canvas drawn and flushed);
- times, in the same page on the same selections, the straightforward drawing: one path and
  one stroke per design in the parallel coordinates and one arc per design and panel in the
  scatter matrix, instead of one path per colour and a pixel buffer.

Prints one table: designs, file size, build time, the median and largest brush update, the
straightforward drawing's median and the ratio.

Then, per archive (and the parts run, ``problems/roll_plane_his_parts.toml``), the build's
time with the spectra from the evaluator's channels (``method="modal"``, poles and residues:
what ``hisopt report`` does) and with every design's direct solve (``method="direct"``, the
reference, the build before: its spectra by direct solves, its step responses from the full
state space), in CPU seconds (the machine may be shared: CPU time is the steady figure) and
wall seconds, their ratio, the largest relative difference of the two rooms' spectra and of
their step responses (to each design's largest roll angle) and how many of the page's curve
bytes differ. Pin one core for steady
figures: ``taskset -c 0`` with ``OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1``.

    python benchmarks/bench_decision_room.py [--brushes 10] [--run DIR ...]
    python benchmarks/bench_decision_room.py --quick   # a smoke run: a short run, seconds
    python benchmarks/bench_decision_room.py --build-only [--run DIR ...]   # no browser
"""

from __future__ import annotations

import argparse
import base64
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

NAIVE_JS = """
const sel = window.hisoptRoom.selectedRows(), axes = window.hisoptRoom.axes();
const canvas = document.getElementById('pc-fg'), ctx = canvas.getContext('2d');
const data = JSON.parse(document.getElementById('room-data').textContent);
const cols = {};
for (const c of data.columns) {
  const bin = atob(c.data), bytes = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
  cols[c.name] = c.type === 'f64' ? new Float64Array(bytes.buffer) : new Float32Array(bytes.buffer);
}
const t1 = performance.now();  // decoding is not drawing: not counted
ctx.clearRect(0, 0, 1e5, 1e5);
const ranges = {};
for (const a of axes) {
  let lo = Infinity, hi = -Infinity;
  for (const i of sel) { const v = cols[a.name][i]; if (v < lo) lo = v; if (v > hi) hi = v; }
  ranges[a.name] = [lo, hi];
}
for (const i of sel) {
  ctx.beginPath();
  axes.forEach((a, k) => {
    const [lo, hi] = ranges[a.name], y = a.bottom - (cols[a.name][i] - lo) / ((hi - lo) || 1) * (a.bottom - a.top);
    if (k) ctx.lineTo(a.x, y); else ctx.moveTo(a.x, y);
  });
  ctx.strokeStyle = 'rgba(68,1,84,0.35)'; ctx.stroke();
}
const sp = document.getElementById('sp-fg').getContext('2d'), obj = data.objectives, cell = 550 / Math.max(obj.length - 1, 1);
const at = (name, i) => (cols[name][i] - (ranges[name] || [0, 1])[0]) / (((ranges[name] || [0, 1])[1] - (ranges[name] || [0, 1])[0]) || 1);
sp.clearRect(0, 0, 1e5, 1e5);
for (let r = 1; r < obj.length; r++) for (let c = 0; c < r; c++) for (const i of sel) {
  sp.beginPath(); sp.arc(64 + (c + at(obj[c], i)) * cell, (r - at(obj[r], i)) * cell, 1.5, 0, 6.283); sp.fill();
}
canvas.getContext('2d').getImageData(0, 0, 1, 1); sp.getImageData(0, 0, 1, 1);
return performance.now() - t1;
"""


def _run(problem: Path, out: Path, gens: int | None, pop: int | None) -> None:
    args = [sys.executable, "-m", "hisopt", "optimize", str(problem), "--out", str(out)]
    args += [] if gens is None else ["--gens", str(gens)]
    args += [] if pop is None else ["--pop", str(pop)]
    subprocess.run(args, check=True, capture_output=True, timeout=3600)


def _driver():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = shutil.which("chromium") or "chromium"
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--window-size=1400,1200"):
        options.add_argument(arg)
    return webdriver.Chrome(service=Service(shutil.which("chromedriver") or "chromedriver"), options=options)


def _brush(driver, fraction_low: float, fraction_high: float) -> None:
    from selenium.webdriver.common.action_chains import ActionChains

    canvas = driver.find_element("id", "pc-ax")
    a = next(a for a in driver.execute_script("return window.hisoptRoom.axes()") if a["name"] == "sigma_aw")
    width, height = canvas.size["width"], canvas.size["height"]

    def y(t: float) -> float:
        return a["bottom"] - t * (a["bottom"] - a["top"])

    chain = ActionChains(driver)
    chain.move_to_element_with_offset(canvas, int(a["x"] - width / 2), int(y(fraction_low) - height / 2)).click_and_hold()
    chain.move_by_offset(0, int(y(fraction_high) - y(fraction_low))).release().perform()


def measure(run_dir: Path, brushes: int) -> dict[str, float]:
    """Build the page of ``run_dir``, then brush it ``brushes`` times (module docstring)."""
    from hisopt.report import decision_room

    start = time.perf_counter()
    room = decision_room(run_dir)
    build = time.perf_counter() - start
    page = room.save(run_dir / "decision.html")
    driver = _driver()
    try:
        driver.get(page.as_uri())
        hisopt_ms, naive_ms = [], []
        for k in range(brushes):
            low = 0.2 + 0.3 * k / max(brushes - 1, 1)
            _brush(driver, low, low + 0.3)
            hisopt_ms.append(float(driver.execute_script("return window.hisoptRoom.timing().last")))
            naive_ms.append(float(driver.execute_script(NAIVE_JS)))
    finally:
        driver.quit()
    return {
        "designs": len(room.table),
        "front": int(room.table["front"].sum()),
        "mb": page.stat().st_size / 1e6,
        "build_s": build,
        "median_ms": statistics.median(hisopt_ms),
        "max_ms": max(hisopt_ms),
        "naive_ms": statistics.median(naive_ms),
    }


def build_times(run_dir: Path) -> dict[str, float]:
    """CPU and wall seconds of building the room of ``run_dir`` (its data and its page) with
    each curve method, the spectra's largest relative difference and the share of the page's
    curve bytes that differ (module docstring). Imports and compiled kernels are warmed first."""
    import numpy as np

    from hisopt.report.decision_page import curve_payload, decision_room_page
    from hisopt.studies.decision_room import decision_room_data, design_curves, run_sources

    sources = run_sources(run_dir)
    for method in ("direct", "modal"):  # imports and kernels, not timed
        design_curves(sources[0].problem, sources[0].x[:2], method=method)
    out: dict[str, float] = {"designs": float(sum(len(s.x) for s in sources))}
    rooms = {}
    for method in ("direct", "modal"):
        cpu, wall = time.process_time(), time.perf_counter()
        room = decision_room_data(sources, method)
        decision_room_page(room, "bench")
        out[f"{method}_cpu"], out[f"{method}_wall"] = time.process_time() - cpu, time.perf_counter() - wall
        rooms[method] = room
    fast, slow = rooms["modal"].curves, rooms["direct"].curves
    with np.errstate(all="ignore"):
        out["spectra_rel"] = float(np.nanmax(np.abs(fast.spectra / slow.spectra - 1)))
    out["nan_differ"] = float(not (np.array_equal(np.isnan(fast.spectra), np.isnan(slow.spectra)) and np.array_equal(np.isnan(fast.step), np.isnan(slow.step))))
    with np.errstate(all="ignore"):  # relative to each design's largest roll angle
        out["step_rel"] = float(np.nanmax(np.abs(fast.step - slow.step) / np.nanmax(np.abs(slow.step), axis=1, keepdims=True)))
    coded = [np.frombuffer(base64.b64decode(curve_payload(r.curves, r.baseline)["bytes"]), np.uint8) for r in (rooms["modal"], rooms["direct"])]
    out["bytes_differ"] = float(np.mean(coded[0] != coded[1])) if coded[0].shape == coded[1].shape else 1.0
    out["bytes_off_by_more_than_one"] = float(np.sum(np.abs(coded[0].astype(int) - coded[1].astype(int)) > 1))
    return out


def print_build_times(runs: list[Path]) -> None:
    """The table of :func:`build_times` for ``runs``."""
    head = f"{'archive':<12} {'designs':>8} {'direct CPU s':>13} {'modal CPU s':>12} {'ratio':>6} {'direct wall s':>14} {'modal wall s':>13}"
    print(f"{head} {'spectra rel diff':>17} {'step rel diff':>14} {'curve bytes differ':>19} {'by > 1':>7}")
    for run in runs:
        m = build_times(run)
        print(
            f"{run.name:<12} {int(m['designs']):>8} {m['direct_cpu']:>13.1f} {m['modal_cpu']:>12.1f} {m['direct_cpu'] / m['modal_cpu']:>6.1f} "
            f"{m['direct_wall']:>14.1f} {m['modal_wall']:>13.1f} {m['spectra_rel']:>17.1e} {m['step_rel']:>14.1e} {m['bytes_differ']:>18.4%} "
            f"{int(m['bytes_off_by_more_than_one']):>7}" + ("  (their NaN patterns differ)" if m["nan_differ"] else ""),
            flush=True,
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--brushes", type=int, default=10)
    parser.add_argument("--run", type=Path, action="append", help="run directories to measure (default: the two runs of the module docstring)")
    parser.add_argument("--quick", action="store_true", help="one short run, three brushes")
    parser.add_argument("--build-only", action="store_true", help="only the build's times with each curve method (no browser)")
    args = parser.parse_args()
    problem = ROOT / "problems" / "roll_plane_his.toml"
    with tempfile.TemporaryDirectory() as tmp:
        runs = args.run or []
        if not runs:
            plans = [("quick", 10, 40, problem)] if args.quick else [("default", None, None, problem), ("long", 400, None, problem)]
            if not args.quick:
                plans.insert(1, ("parts", None, None, ROOT / "problems" / "roll_plane_his_parts.toml"))
            for name, gens, pop, file in plans:
                out = Path(tmp) / name
                print(f"running {name} ...", flush=True)
                _run(file, out, gens, pop)
                runs.append(out)
        if not args.build_only:
            brushes = 3 if args.quick else args.brushes
            head = f"{'archive':<12} {'designs':>8} {'front':>7} {'file MB':>8} {'build s':>8}"
            print(f"{head} {'brush ms (median, max)':>24} {'one path per design ms':>23} {'ratio':>6}")
            for run in runs:
                m = measure(run, brushes)
                print(
                    f"{run.name:<12} {m['designs']:>8} {m['front']:>7} {m['mb']:>8.2f} {m['build_s']:>8.1f} "
                    f"{m['median_ms']:>15.0f}, {m['max_ms']:>6.0f} {m['naive_ms']:>23.0f} {m['naive_ms'] / m['median_ms']:>6.1f}"
                )
        print("\nbuilding the room: spectra from the evaluator's channels (modal) against every design's direct solve (direct)")
        print_build_times(runs)


if __name__ == "__main__":
    main()
