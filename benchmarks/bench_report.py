"""``hisopt report``'s report.html: its size and the seconds to write it on one core, against
the page as it was before issue 38 in the same run, and what the decision room beside it costs.

For each run: the default one (``hisopt optimize problems/roll_plane_his.toml``, 200
generations of 100) and the parts one (``problems/roll_plane_his_parts.toml``: a catalogue
run with its continuous relaxation), each measured in a fresh process pinned to one core with
one BLAS thread, on a copy of the run (the run itself is not touched):

- ``light``: report.html as ``hisopt report`` writes it (:func:`hisopt.report.html.report_page`:
  plotly.js once, gzip-compressed; the figures' arrays float32, each once per page; a front
  point hovers its row);
- ``before``: the same page the straightforward way, as it was before: plotly.js inline
  (4.8 MB), each figure by plotly's ``to_html`` (full-precision JSON, its own copy of every
  column) and the whole design as hover text on every point of the scatter matrices;
- ``decision``: decision.html (:func:`hisopt.report.decision_page.run_decision_room`), which
  ``hisopt report`` writes next: every design of the run (front and other evaluations), their
  parts and curves re-evaluated.

Prints one table: run, page, file size, the seconds to build and write the page in a warm
process (best of ``--repeats``) and a fresh process's CPU and wall seconds writing it once
(imports included: what ``hisopt report`` spends on it; CPU seconds are what an idle core would
take, wall seconds also count the waits of a shared machine), and the ratio of ``light`` to
``before``.

    python benchmarks/bench_report.py [--default DIR] [--parts DIR] [--repeats 3]
    python benchmarks/bench_report.py --quick   # a smoke run: small runs, seconds
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PROBLEMS = {"default": ROOT / "problems" / "roll_plane_his.toml", "parts": ROOT / "problems" / "roll_plane_his_parts.toml"}
ONE_THREAD = {name: "1" for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")}


def _before() -> None:
    """Make report_page build the page the way it was before issue 38 (this process only)."""
    import plotly.offline

    from hisopt.plotting import figures
    from hisopt.report import html

    class InlineFigures:
        """plotly.js inline, each figure by plotly's to_html."""

        def div(self, fig, div_id: str) -> str:
            return fig.to_html(full_html=False, include_plotlyjs=False, div_id=div_id)

        def head_html(self) -> str:
            return f'<script type="text/javascript">{plotly.offline.get_plotlyjs()}</script>'

        def scripts_html(self) -> str:
            return ""

    scatter_matrix = figures._scatter_matrix

    def whole_design_hover(views, front, refined, highlights, n_axes, title, design_hover=True):  # noqa: ANN001, ANN202
        return scatter_matrix(views, front, refined, highlights, n_axes, title, True)

    html.PageFigures = InlineFigures  # type: ignore[assignment,misc]
    figures._scatter_matrix = whole_design_hover


def child(page: str, run_dir: Path, repeats: int) -> None:
    """Measure one page in this process and print its figures as JSON."""
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    from hisopt.io import atomic_write_text

    if page == "before":
        _before()
    best = float("inf")
    for _ in range(repeats if page != "decision" else 1):
        start = time.perf_counter()
        if page == "decision":
            from hisopt.report.decision_page import run_decision_room

            out = run_decision_room(run_dir)
        else:
            from hisopt.report.html import report_page

            out = run_dir / "report.html"
            atomic_write_text(out, report_page(run_dir))
        best = min(best, time.perf_counter() - start)
    print(json.dumps({"seconds": best, "bytes": out.stat().st_size}))


def measure(page: str, run_dir: Path, repeats: int) -> dict[str, float]:
    """The page's size and best time, and the first process's wall time (imports included)."""
    env = {**os.environ, **ONE_THREAD, "PYTHONPATH": str(ROOT)}

    def run(count: int) -> tuple[dict, float, float]:
        before, start = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
        command = [sys.executable, __file__, "--child", page, str(run_dir), "--repeats", str(count)]
        proc = subprocess.run(command, capture_output=True, text=True, env=env, timeout=3600, check=True)
        wall, after = time.perf_counter() - start, resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
        return json.loads(proc.stdout.strip().splitlines()[-1]), cpu, wall

    found, cpu, wall = run(repeats)
    if page != "decision" and repeats > 1:  # the process of one page: once more alone
        _, cpu, wall = run(1)
    return {"mb": found["bytes"] / 1e6, "seconds": found["seconds"], "cpu": cpu, "process": wall}


def make_run(name: str, out: Path, quick: bool) -> Path:
    args = [sys.executable, "-m", "hisopt", "optimize", str(PROBLEMS[name]), "--out", str(out)]
    args += ["--pop", "16", "--gens", "4"] if quick else []
    print(f"running {name} ...", flush=True)
    subprocess.run(args, check=True, capture_output=True, timeout=3600, env={**os.environ, "PYTHONPATH": str(ROOT)})
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--default", type=Path, help="a finished run of problems/roll_plane_his.toml (default: make one)")
    parser.add_argument("--parts", type=Path, help="a finished run of problems/roll_plane_his_parts.toml (default: make one)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="small runs (16 x 4), one repeat")
    parser.add_argument("--child", nargs=2, metavar=("PAGE", "RUN_DIR"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child[0], Path(args.child[1]), args.repeats)
        return
    repeats = 1 if args.quick else args.repeats
    with tempfile.TemporaryDirectory() as tmp:
        rows = []
        for name in ("default", "parts"):
            given = getattr(args, name)
            source = given if given is not None else make_run(name, Path(tmp) / f"made-{name}", args.quick)
            run_dir = Path(tmp) / name
            shutil.copytree(source, run_dir)  # the pages are written into the copy
            for page in ("light", "before", "decision"):
                print(f"measuring {name} {page} ...", flush=True)
                rows.append((name, page, measure(page, run_dir, repeats)))
        print(f"\n{'run':8} {'page':9} {'size MB':>8} {'write s':>8} {'process CPU s':>14} {'process wall s':>15}")
        for name, page, m in rows:
            print(f"{name:8} {page:9} {m['mb']:8.2f} {m['seconds']:8.2f} {m['cpu']:14.2f} {m['process']:15.2f}")
        print(
            f"one core, one BLAS thread; write: the page built and written in a warm process, best of {repeats}; process: "
            f"a fresh process writing it once, imports included (what `hisopt report` spends on it); load average {os.getloadavg()[0]:.1f}"
        )
        for name in ("default", "parts"):
            light, before = (next(m for n, p, m in rows if n == name and p == page) for page in ("light", "before"))
            print(f"{name}: light / before: size {light['mb'] / before['mb']:.2f}, write {light['seconds'] / before['seconds']:.2f}")


if __name__ == "__main__":
    main()
