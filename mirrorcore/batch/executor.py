"""Where a batch runs (this process, local Dask workers or an existing cluster) and the executor
that runs its tasks there."""
from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.batch.frames import FrameContext, reconstruct_frames, task_error
from mirrorcore.batch.scheduler import scheduler_address
from mirrorcore.dense.volume import cancel_requested

# local worker processes a core may have: more only wait for the cores and take memory
WORKERS_PER_CORE = 2


@dataclass(frozen=True)
class Where:
    """Where a batch runs.

    Attributes
    ----------
    workers : int or None
        Local worker processes (default: one per core; 1 runs in this process, without Dask; at
        most `max_workers()`).
    scheduler : str or None
        The address of an existing Dask cluster ('tcp://HOST:8786' or 'HOST:8786') instead.
    dashboard : bool
        Serve the Dask dashboard of a local cluster.
    """

    workers: int | None = None
    scheduler: str | None = None
    dashboard: bool = True

    def __post_init__(self) -> None:
        if self.scheduler is not None:
            scheduler_address(self.scheduler)
        if self.workers is not None and self.workers < 1:
            raise MirrorscanError(f"--workers: at least 1, got {self.workers}")
        if self.workers is not None and self.workers > max_workers():
            raise MirrorscanError(f"--workers: at most {max_workers()} on this machine "
                                  f"({WORKERS_PER_CORE} per core), got {self.workers}")
        if self.workers is not None and self.scheduler is not None:
            raise MirrorscanError(f"--workers: the cluster at {self.scheduler} has its own "
                                  "workers; give one or "
                                  "the other")

    @property
    def in_process(self) -> bool:
        """True when the batch runs in this process (one local worker, no scheduler)."""
        return self.scheduler is None and self.local_workers == 1

    @property
    def local_workers(self) -> int:
        """The local worker processes: `workers`, or the cores this process may use."""
        return self.workers or cores()


def cores() -> int:
    """The cores this process may use."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def max_workers() -> int:
    """The most local worker processes: WORKERS_PER_CORE per core this process may use."""
    return WORKERS_PER_CORE * cores()


@contextmanager
def task_executor(where: Where, context: FrameContext, cancel) -> Iterator:
    """Yield the executor of `where`: in this process, or on a Dask cluster closed after.

    Raises
    ------
    MirrorscanError
        An existing cluster without workers.
    Cancelled
        A cancel request while waiting for them.
    """
    if where.in_process:
        yield _InProcess(context, cancel)
        return
    # distributed is imported only when used
    from mirrorcore.batch.cluster import DaskExecutor, dask_client
    with dask_client(where.local_workers, where.scheduler, where.dashboard, cancel) as client:
        local = where.scheduler is None
        executor = DaskExecutor(client, context, local, dashboard=where.dashboard or not local)
        try:
            yield executor
        finally:
            executor.close()


class _InProcess:
    """Runs the chunks one by one in this process (same interface as cluster.DaskExecutor)."""

    dashboard = None
    workers = 1

    def __init__(self, context: FrameContext, cancel):
        self.context = context
        self.cancel = cancel
        self.chunks: list[tuple[int, ...]] = []

    @property
    def pending(self) -> int:
        return len(self.chunks)

    def submit(self, chunks: list[tuple[int, ...]]) -> None:
        self.chunks.extend(chunks)

    def wait(self, timeout: float) -> list:
        """Run the next chunk now; an unexpected error fails its frames (others go on)."""
        chunk = self.chunks.pop(0)
        try:
            records, failures = reconstruct_frames(self.context, chunk,
                                                   lambda: cancel_requested(self.cancel))
        # a frame's bug or MemoryError must not end hours of work
        except Exception as exc:  # noqa: BLE001
            records, failures = [], {i: task_error(exc) for i in chunk}
        return [(chunk, records, failures)]

    def deaths(self) -> dict[int, str]:
        return {}

