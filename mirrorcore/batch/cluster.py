"""Running a batch on Dask (distributed): a local cluster of worker processes on this machine, or an
existing cluster by its scheduler's address. The frame context is built once and shipped once to
each worker as a WorkerPlugin, which a restarted or late-joining worker receives too; each task
reconstructs a few frames; a worker that dies is noticed from the scheduler's 'remove-worker' event,
and the frames it was running are reported (Dask runs them again on another worker, up to its
`allowed-failures`, then the task fails with KilledWorker).

Imported only when a batch runs on Dask: importing distributed takes a second.
"""
from __future__ import annotations

import contextlib
import logging
import os
import queue
import shutil
import signal
import tempfile
import threading
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import cv2
import dask
from distributed import Client, LocalCluster, WorkerPlugin, get_worker, wait

from mirrorcore.base.errors import Cancelled, MirrorscanError
from mirrorcore.base.progress import cancel_requested
from mirrorcore.batch.frames import FrameContext, reconstruct_frames, task_error
from mirrorcore.batch.records import FrameRecord
from mirrorcore.batch.scheduler import POLL_SECONDS

CONNECT_SECONDS = 20.0     # to reach a scheduler and see a first worker
DASHBOARD = ":8787"        # Dask's usual dashboard port (another free one if it is taken)
_SPAWN_ENVIRON = "distributed.nanny.pre-spawn-environ"
# A local cluster's housekeeping, measured on 2 cores with 2 idle workers: 180 CPU ms a second with
# Dask's defaults, 60 with these (most of it the 20 ms tick that only watches for a blocked event
# loop, and the sampling profiler that costs a worker ~2 ms a frame). Work stealing has nothing to
# do with one queue of equal tasks.
LEAN_LOCAL_CLUSTER = {"distributed.worker.profile.enabled": False,
                      "distributed.admin.tick.interval": "1s",
                      "distributed.scheduler.work-stealing": False}

ChunkResult = tuple[tuple[int, ...], list[FrameRecord], dict[int, str]]


class ContextPlugin(WorkerPlugin):
    """Hold a batch's FrameContext on a worker, and keep OpenCV to one thread per task there.

    As Dask does with OpenMP and BLAS (each worker thread runs a task; the cores are shared out by
    the workers). On a local cluster it also makes the worker ignore Ctrl-C: the terminal sends
    SIGINT to every process of the command, and the command stops its workers itself.

    Parameters
    ----------
    context : FrameContext
    ignore_ctrl_c : bool
        Ignore SIGINT on the worker (a local cluster).
    """

    def __init__(self, context: FrameContext, ignore_ctrl_c: bool):
        self.context = context
        self.ignore_ctrl_c = ignore_ctrl_c

    def setup(self, worker) -> None:
        """Set the worker up.

        Parameters
        ----------
        worker : distributed.Worker

        Raises
        ------
        MirrorscanError
            The session or the output folder is not there on the worker.
        """
        for folder in (Path(self.context.session.root), Path(self.context.job.out)):
            if not folder.is_dir():
                raise MirrorscanError(
                    f"worker {worker.address}: {folder} is not there; the session and the output "
                                      "folder must be on a file system that every worker sees at "
                                      "the same path")
        cv2.setNumThreads(1)
        if self.ignore_ctrl_c and threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)


def run_task(plugin: str, indices: tuple[int, ...]) -> tuple[list[FrameRecord], dict[int, str]]:
    """Run a Dask task: reconstruct frames with the context a plugin holds on this worker.

    Parameters
    ----------
    plugin : str
        The plugin's name.
    indices : tuple of int
        The frames.

    Returns
    -------
    records : list of FrameRecord
    failures : dict of int to str
        {frame: one-line error}.
    """
    return reconstruct_frames(get_worker().plugins[plugin].context, indices)


@contextmanager
def dask_client(workers: int, scheduler: str | None, dashboard: bool, cancel=None
                ) -> Iterator[Client]:
    """Connect to a Dask cluster, or start a local one, closed on the way out.

    Parameters
    ----------
    workers : int
        Processes of a new local cluster, one thread each, listening on 127.0.0.1 only.
    scheduler : str or None
        The address of an existing cluster ('tcp://HOST:8786'), answering as Dask
        (scheduler.probe_scheduler).
    dashboard : bool
        Serve the dashboard of a local cluster.
    cancel : threading.Event or callable, optional
        Stops the wait for an existing cluster's first worker.

    Yields
    ------
    distributed.Client
        Closed (processes, ports, scratch folder) on the way out.

    Raises
    ------
    MirrorscanError
        One line: no Dask client could connect to `scheduler`, or it has no workers.
    Cancelled
        A cancel request while waiting for an existing cluster's first worker.
    """
    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=CONNECT_SECONDS)
        except (OSError, ValueError) as exc:
            raise MirrorscanError(
                f"--scheduler {scheduler}: no Dask scheduler answered ({exc})") from None
        with client:
            _wait_for_a_worker(client, scheduler, cancel)
            yield client
        return
    scratch = tempfile.mkdtemp(prefix="mirrorscan-dask-")
    config = {**LEAN_LOCAL_CLUSTER, _SPAWN_ENVIRON: worker_environment(),
              "temporary-directory": scratch}
    try:
        # the scheduler's HTTP server runs even without the dashboard: on a free port then
        with dask.config.set(config), LocalCluster(
                n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                local_directory=scratch,
                dashboard_address=DASHBOARD if dashboard else ":0",
                scheduler_kwargs={"dashboard": dashboard},
                silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
            try:
                yield client
            finally:
                if cancel_requested(cancel):
                    _kill_workers(cluster)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _kill_workers(cluster: LocalCluster) -> None:
    """Kill a local cluster's worker processes, so that closing it waits for no running task.

    Their nannies are told first not to start them again. A frame a worker was writing is left as
    a temporary file, which the batch folder removes when it is next opened (manifest.OutputFolder).
    """
    for nanny in list(cluster.workers.values()):
        nanny.close_gracefully(reason="mirrorscan-cancelled")
        if nanny.pid:
            with contextlib.suppress(ProcessLookupError):
                os.kill(nanny.pid, signal.SIGKILL)


def _wait_for_a_worker(client: Client, scheduler: str, cancel) -> None:
    """Wait up to CONNECT_SECONDS for the cluster's first worker, looking at `cancel` meanwhile."""
    deadline = time.monotonic() + CONNECT_SECONDS
    while not client.nthreads():
        if cancel_requested(cancel):
            raise Cancelled("cancelled while waiting for the Dask cluster's workers")
        if time.monotonic() > deadline:
            raise MirrorscanError(f"--scheduler {scheduler}: the cluster has no workers")
        time.sleep(POLL_SECONDS)


def worker_environment() -> dict:
    """Return Dask's environment for new worker processes without MALLOC_TRIM_THRESHOLD_.

    Dask sets it to 64 kB so that workers give memory back sooner, which makes every large numpy
    array a fresh mmap and a frame 3 to 4 times slower.
    """
    return {k: v for k,
            v in dask.config.get(_SPAWN_ENVIRON).items() if k != "MALLOC_TRIM_THRESHOLD_"}


class DaskExecutor:
    """Run chunks of frames on a Dask cluster.

    submit() them all, then wait() for those that finish; deaths() gives the frames whose worker
    died with them (they are run again elsewhere).

    Parameters
    ----------
    client : distributed.Client
    context : FrameContext
        Handed to the workers.
    local : bool
        The cluster is this command's own.
    dashboard : bool
        Give the dashboard's address.
    """

    def __init__(self, client: Client, context: FrameContext, local: bool, dashboard: bool):
        self.client = client
        self.dashboard = client.dashboard_link if dashboard else None
        self.plugin = f"mirrorscan-batch-{uuid.uuid4().hex[:12]}"
        self._chunks: dict[str, tuple[int, ...]] = {}
        self._pending: set = set()
        self._events: queue.SimpleQueue = queue.SimpleQueue()
        try:
            client.register_plugin(ContextPlugin(context, ignore_ctrl_c=local), name=self.plugin)
        except MirrorscanError:
            raise
        # whatever a worker raised loading the context: one line for the user
        except Exception as exc:  # noqa: BLE001
            raise MirrorscanError(
                f"the Dask workers could not load the batch ({type(exc).__name__}: {exc}); is "
                                  "mirrorscan installed on every worker?") from None
        client.subscribe_topic("all", self._events.put)

    @property
    def pending(self) -> int:
        """The tasks submitted and not yet finished."""
        return len(self._pending)

    @property
    def workers(self) -> int:
        """The tasks the cluster runs at once (its worker threads)."""
        return max(1, sum(self.client.nthreads().values()))

    def submit(self, chunks: list[tuple[int, ...]]) -> None:
        """Submit a task per chunk.

        Parameters
        ----------
        chunks : list of tuple of int
            The frames of each task.
        """
        for chunk in chunks:
            key = f"mirrorscan-frames-{chunk[0]:06d}-{self.plugin[-12:]}"
            self._chunks[key] = chunk
            self._pending.add(self.client.submit(run_task, self.plugin, chunk, key=key, pure=False))

    def wait(self, timeout: float) -> list[ChunkResult]:
        """Return the chunks that finished within a time (possibly none).

        A task that raised (KilledWorker after its workers died, a bug) gives every frame of its
        chunk as failed with that one-line error.

        Parameters
        ----------
        timeout : float
            Seconds.

        Returns
        -------
        list of ChunkResult
        """
        if not self._pending:
            return []
        try:
            finished = wait(list(self._pending), timeout=timeout,
                            return_when="FIRST_COMPLETED").done
        except TimeoutError:
            return []
        results = []
        for future in finished:
            # a result lost with its worker since wait() saw it is computed again: still pending
            if future.status not in ("finished", "error"):
                continue
            self._pending.discard(future)
            chunk = self._chunks[future.key]
            if future.status == "finished":
                results.append((chunk, *future.result()))
            else:
                message = task_error(future.exception())
                results.append((chunk, [], {i: message for i in chunk}))
            future.release()
        return results

    def deaths(self) -> dict[int, str]:
        """Return the frames a worker was running when it left the cluster, since the last call.

        Returns
        -------
        dict of int to str
            {frame: worker address}.
        """
        found: dict[int, str] = {}
        while True:
            try:
                _, event = self._events.get_nowait()
            except queue.Empty:
                return found
            if isinstance(event, dict) and event.get("action") == "remove-worker":
                for key in event.get("processing-tasks", ()):
                    for frame in self._chunks.get(key, ()):
                        found[frame] = event.get("worker", "?")

    def close(self) -> None:
        """Cancel what is still pending, stop listening and drop the context from the workers."""
        # the cluster is gone already: nothing is left to drop
        if self.client.status != "running":
            return
        if self._pending:
            self.client.cancel(list(self._pending))
            self._pending.clear()
        self.client.unsubscribe_topic("all")
        self.client.unregister_worker_plugin(self.plugin)
