"""A layout study on a Dask cluster that loses a worker mid-study (issue 42, docs/model.md §15).

Dask reschedules the tasks of a dead worker (``Backend.map`` submits with retries and sends
every input in the task specs, so the scheduler can compute anything a lost worker held
again); hisopt's part is that a task run twice gives the same result: a run whose process was killed is continued from its run directory's checkpoint, and
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

import numpy as np
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


def _slow_pick(item: int, shared: np.ndarray) -> float:
    time.sleep(0.05)  # long enough that tasks are running when a worker dies
    return float(shared[item * 1000])


def _workers_without(client, gone: set[str], count: int, timeout_s: float = 120.0) -> dict[str, int]:
    """The process ids of ``count`` running workers once none of ``gone`` is among them (the
    nanny of a killed worker starts a new one at a new address)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        workers = set(client.scheduler_info(n_workers=-1)["workers"])
        if len(workers) == count and not workers & gone:
            return client.run(os.getpid)
        time.sleep(0.05)
    raise AssertionError(f"the cluster did not get back to {count} workers within {timeout_s} s")


@pytest.mark.slow  # twelve kills on a 3-worker cluster: about 30 s
def test_map_returns_every_result_whenever_a_worker_dies():
    """A worker SIGKILLed at any moment of ``Backend.map``, from its start (while it sends a
    160 MB shared input) to mid-way through the tasks: every item's result, in order. The
    ``Client.scatter(broadcast=True)`` that ``map`` used before never returned, or raised
    KeyError, when a worker died while Dask replicated the input (a CI run hung for an hour);
    on this cluster it did within the first three instants."""
    import sys

    import cloudpickle
    from dask.distributed import Client, LocalCluster

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers need not import tests/
    shared = np.arange(20_000_000, dtype=float)
    items = list(range(30))
    expected = [float(i * 1000) for i in items]
    cluster = LocalCluster(n_workers=3, threads_per_worker=1, processes=True, dashboard_address=":0")
    client = Client(cluster)
    killed: set[str] = set()
    try:
        for delay in np.arange(0.0, 1.2, 0.1):
            pids = _workers_without(client, killed, 3)
            victim = sorted(pids)[-1]
            outcome: list = []
            mapper = threading.Thread(target=lambda out=outcome: out.append(Backend(client).map(_slow_pick, items, shared)), daemon=True)
            killer = threading.Timer(delay, os.kill, (pids[victim], signal.SIGKILL))
            killer.start()
            mapper.start()
            mapper.join(timeout=120)  # about a second when it works; a daemon thread, so a hang fails here
            killer.join()
            killed.add(victim)
            assert outcome, f"Backend.map did not return (or raised) when worker {victim} died {delay:.1f} s into it"
            assert outcome[0] == expected, delay
    finally:
        cloudpickle.unregister_pickle_by_value(sys.modules[__name__])
        client.close()
        cluster.close()


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
