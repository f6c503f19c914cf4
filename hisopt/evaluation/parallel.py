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
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    pass

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
        done: dict[int, R] = {}
        pending = list(range(len(items)))
        for _ in range(LOST_INPUT_ATTEMPTS):
            pending = self._run_pending(fn, items, args, pending, done, on_result)
            if not pending:
                return [done[i] for i in range(len(items))]
        raise RuntimeError(f"Dask lost the inputs of {len(pending)} task(s) {LOST_INPUT_ATTEMPTS} times (workers dying); their results are missing")

    def _run_pending(
        self,
        fn: Callable[..., R],
        items: Sequence[T],
        args: tuple[Any, ...],
        pending: list[int],
        done: dict[int, R],
        on_result: Callable[[int, R], None] | None,
    ) -> list[int]:
        """Submit the ``pending`` items, store each result in ``done`` once (by item index), and
        return the items whose tasks were cancelled because their scattered inputs were lost
        with every worker holding them (a retry cannot run: they are submitted again, with the
        inputs scattered anew)."""
        from concurrent.futures import CancelledError

        from dask.distributed import as_completed

        # Unique keys (hash=False): a repeated scatter of the same object must not share a
        # key whose release by an earlier call would drop it from under the new tasks.
        shared = [self.client.scatter(a, broadcast=True, hash=False) for a in args]
        # Items are scattered too, so the task graph stays small whatever the data size; to
        # every worker, like the shared arguments, so that losing a worker (a missed
        # heartbeat on a loaded machine) loses no input and a retry can run elsewhere.
        item_futures = self.client.scatter([items[i] for i in pending], hash=False, broadcast=True)
        futures = self.client.map(fn, item_futures, *[[s] * len(pending) for s in shared], pure=False, retries=2)
        position = {f.key: i for f, i in zip(futures, pending, strict=True)}
        lost = []
        for future in as_completed(futures):
            i = position[future.key]
            try:
                result = future.result()
            except CancelledError:
                lost.append(i)
                continue
            if i not in done:  # one result per item, whatever ran twice
                done[i] = result
                if on_result is not None:
                    on_result(i, result)
        return sorted(lost)


LOST_INPUT_ATTEMPTS = 3
"""[-] Times :meth:`Backend.map` submits tasks whose scattered inputs Dask lost (every worker
holding them died) before it gives up."""


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
