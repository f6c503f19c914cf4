"""One parallel backend for heavy studies: in-process by default, Dask when asked.

``--workers N`` starts a local Dask cluster of N single-threaded worker processes;
``--scheduler ADDRESS`` connects to an existing cluster (``dask scheduler`` / ``dask worker``
on several machines). Library functions take ``client=`` (a ``dask.distributed.Client``) or
``backend=``. Work is split into chunks large enough for the vectorised evaluator (never one
task per design). Results through Dask equal serial ones within 1e-12 relative (the
determinism contract of docs/model.md: a design's numbers may differ by rounding between
batches, never more).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

T = TypeVar("T")
R = TypeVar("R")

_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")

DEFAULT_CHUNK = 4096
"""Designs per task: big enough to amortise Dask overhead, small enough to spread work."""


@dataclass
class Backend:
    """Runs ``fn`` over items: serially in this process, or as Dask tasks on ``client``."""

    client: Any = None

    @property
    def is_distributed(self) -> bool:
        return self.client is not None

    @property
    def n_workers(self) -> int:
        if self.client is None:
            return 1
        return max(1, len(self.client.scheduler_info().get("workers", {})))

    def map(self, fn: Callable[..., R], items: Sequence[T], *args: Any, on_result: Callable[[int, R], None] | None = None) -> list[R]:
        """``[fn(item, *args) for item in items]``, in order; shared ``args`` are sent once.

        ``on_result(index, result)`` is called as each item finishes (in completion order on
        Dask), e.g. to report progress; the returned list is in item order either way.
        """
        if self.client is None:
            results = []
            for i, item in enumerate(items):
                results.append(fn(item, *args))
                if on_result is not None:
                    on_result(i, results[-1])
            return results
        import dask
        from dask.distributed import as_completed

        # Inputs travel in the task specs, never by scatter: the scheduler keeps every spec, so
        # what a lost worker held (an input, a result) is computed again from it (lineage).
        # A scattered input dies with its holders, and a broadcast scatter never returns when
        # a worker dies while it replicates (distributed 2026.8, Scheduler.replicate's loop).
        # The shared arguments are sent once, as tasks that return them; each item in its own
        # task, boxed so that Dask never reads a tuple item as a task.
        # Dask's warning on a graph over 10 MB is for data it could load itself; these inputs
        # belong in the graph (a 10^6-design sweep's is 32 MB, held by the scheduler).
        n = len(items)
        with dask.config.set({"distributed.admin.large-graph-warning-threshold": "2 GiB"}):
            shared = [self.client.submit(_unbox, _Box(a), pure=False) for a in args]
            futures = self.client.map(_apply, [fn] * n, [_Box(item) for item in items], *[[s] * n for s in shared], pure=False, retries=2)
        position = {f.key: i for i, f in enumerate(futures)}
        done: dict[int, R] = {}
        for future in as_completed(futures):
            i = position[future.key]
            done[i] = future.result()
            if on_result is not None:
                on_result(i, done[i])
        return [done[i] for i in range(n)]


@dataclass(frozen=True)
class _Box:
    """An opaque holder: Dask pickles it whole and never looks inside for tasks or futures."""

    value: Any


def _unbox(box: _Box) -> Any:
    return box.value


def _apply(fn: Callable[..., R], item: _Box, *args: Any) -> R:
    return fn(item.value, *args)


@contextlib.contextmanager
def open_backend(workers: int | None = None, scheduler: str | None = None, client: Any = None) -> Iterator[Backend]:
    """Context manager giving a :class:`Backend`; closes any cluster it started itself."""
    if client is not None:
        yield Backend(client)
        return
    if workers is None and not scheduler:  # --workers 0 is refused below, not taken as local
        yield Backend(None)
        return
    from dask.distributed import Client, LocalCluster

    from hisopt.errors import ConfigError

    if scheduler:
        try:
            own = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError, ValueError) as exc:  # ValueError: a malformed address
            raise ConfigError(f"cannot reach Dask scheduler {scheduler!r} ({exc}); expected an address like tcp://host:8786", key="--scheduler") from None
        try:
            yield Backend(own)
        finally:
            own.close()
        return
    from hisopt.arguments import integer

    workers = integer(workers, "--workers", minimum=1, what="worker")
    # One BLAS thread per worker process: the workers already use every core.
    saved = {k: os.environ.get(k) for k in _THREAD_VARS}
    os.environ.update({k: "1" for k in _THREAD_VARS})
    try:
        # ":0": any free port, so several studies (or test runs) on one machine never collide
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0")
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    own = Client(cluster)
    try:
        yield Backend(own)
    finally:
        own.close()
        cluster.close()


def chunks(n: int, size: int) -> list[slice]:
    """Consecutive slices covering ``range(n)``, each at most ``size`` long."""
    return [slice(i, min(i + size, n)) for i in range(0, n, size)]
