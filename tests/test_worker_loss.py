"""A layout study on a Dask cluster that loses a worker mid-study (issue 42, docs/model.md §15).

Dask reschedules the tasks of a dead worker (``Backend.map`` submits with retries and
scatters every input to every worker); hisopt's part is that a task run twice gives the same
result: a run whose process was killed is continued from its run directory's checkpoint, and
a continued run is identical to an uninterrupted one (the determinism contract). So the
study's files written on a cluster whose worker was SIGKILLed while running a task equal,
byte for byte, those of the same study run serially in one process.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import pytest

from hisopt.evaluation.parallel import Backend
from hisopt.problem import load_problem
from hisopt.studies.layout_study import run_layout_study
from tests.conftest import DEFAULT_PROBLEM

LAYOUTS = "axle_roll,roll_plane_twin_accumulator"
SEEDS = (1, 2)
POP, GENS = 12, 30
COMPARED = ("layouts.csv", "runs.csv", "fronts.csv", "handling_curve.csv")


def _kill_a_busy_worker(client, done: threading.Event, killed: list[str], timeout_s: float = 120.0) -> None:
    """SIGKILL the process of the first worker seen running a task (its nanny starts a new one)."""
    pids = client.run(os.getpid)
    start = time.monotonic()
    while not done.is_set() and time.monotonic() - start < timeout_s:
        busy = [w for w, tasks in client.processing().items() if tasks]
        if busy:
            time.sleep(1.0)  # well into the task: its run directory holds a checkpoint or more
            os.kill(pids[busy[0]], signal.SIGKILL)
            killed.append(busy[0])
            return
        time.sleep(0.05)


@pytest.mark.slow  # two studies of 3 layouts x 2 seeds and a cluster: about a minute
def test_a_study_that_loses_a_worker_writes_what_a_serial_study_writes(tmp_path: Path) -> None:
    from dask.distributed import Client, LocalCluster

    problem = load_problem(DEFAULT_PROBLEM)
    run_layout_study(problem, LAYOUTS, SEEDS, out=tmp_path / "serial", pop_size=POP, generations=GENS)

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
    client = Client(cluster)
    done, killed = threading.Event(), []
    killer = threading.Thread(target=_kill_a_busy_worker, args=(client, done, killed))
    try:
        killer.start()
        run_layout_study(problem, LAYOUTS, SEEDS, out=tmp_path / "cluster", pop_size=POP, generations=GENS, backend=Backend(client))
    finally:
        done.set()
        killer.join()
        client.close()
        cluster.close()
    assert killed, "no worker was busy long enough to be killed: the test proved nothing"
    for name in COMPARED:
        assert (tmp_path / "cluster" / name).read_bytes() == (tmp_path / "serial" / name).read_bytes(), name
