"""Running a batch: the frames still to do, split into tasks of a few frames, run in this process or
on Dask (a local cluster, or an existing one: executor), the manifest kept up to date, progress
reported, stopped cleanly on cancel. `run_batch` blocks; `BatchRun` runs it in a thread for a UI."""
from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

from mirrorcore.dense.volume import cancel_requested
from mirrorcore.base.errors import Cancelled, MirrorscanError
from mirrorcore.io.sessionfile import load_session
from mirrorcore.depth.temporal import check_window_memory
from mirrorcore.batch.executor import Where, task_executor
from mirrorcore.batch.frames import FrameContext
from mirrorcore.batch.job import BatchJob, session_inputs
from mirrorcore.batch.manifest import MANIFEST_FILE, OutputFolder
from mirrorcore.batch.scheduler import probe_scheduler

# how often a Dask run looks at the cancel request and the cluster's events
POLL_SECONDS = 0.25


@dataclass(frozen=True)
class BatchProgress:
    """Where a batch stands.

    Attributes
    ----------
    total : int
        The session's frames.
    done : int
        Frames done (kept + written).
    kept : int
        Frames found done in the output folder when this run started.
    failed : int
        Frames that failed in this run.
    fps : float
        Frames written per second by this run.
    seconds_left : float or None
        At that rate (None before the first frame).
    retried : tuple of int
        Frames run again after their worker died.
    dashboard : str or None
        The Dask dashboard's address (None in process or without one).
    """

    total: int
    done: int
    kept: int
    failed: int
    fps: float
    seconds_left: float | None
    retried: tuple[int, ...] = ()
    dashboard: str | None = None

    @property
    def fraction(self) -> float:
        """(done + failed) / total; 1 for a session without frames."""
        return (self.done + self.failed) / self.total if self.total else 1.0


@dataclass(frozen=True)
class BatchReport:
    """How a batch ended.

    Attributes
    ----------
    out : Path
        The output folder.
    total : int
        The session's frames.
    kept, written : int
        Frames found done in the output folder when this run started, and frames this run wrote.
    failed : dict of int to str
        {frame: one-line error}.
    retried : dict of int to str
        {frame: address of the worker that died with it}.
    seconds : float
        This run's wall time from the first task to the last result (cluster start-up excluded).
    startup_seconds : float
        The cluster's start-up.
    cancelled : bool
        Stopped by a cancel request.
    dashboard : str or None
        The Dask dashboard's address.
    """

    out: Path
    total: int
    kept: int
    written: int
    failed: dict[int, str] = field(default_factory=dict)
    retried: dict[int, str] = field(default_factory=dict)
    seconds: float = 0.0
    startup_seconds: float = 0.0
    cancelled: bool = False
    dashboard: str | None = None

    @property
    def complete(self) -> bool:
        """Every frame of the session is done."""
        return self.kept + self.written == self.total

    @property
    def fps(self) -> float:
        """Frames written per second (0 without time)."""
        return self.written / self.seconds if self.seconds > 0 else 0.0

    @property
    def manifest(self) -> Path:
        """The output folder's manifest file."""
        return self.out / MANIFEST_FILE


def default_frames_per_task(method: str) -> int:
    """Return the frames per task of a method.

    Enough raw frames that a task lasts a few tenths of a second; one dense frame.

    Parameters
    ----------
    method : str

    Returns
    -------
    int
    """
    return 8 if method == "raw" else 1


def task_chunks(todo: list[int], per_task: int, workers: int) -> list[tuple[int, ...]]:
    """Split frames into tasks that shrink towards the end (guided self-scheduling).

    Tasks of `per_task` frames, but for the last ones: a task takes at most a 2 * `workers`-th of
    the frames left (and at least one), so that the workers finish together instead of one running
    a whole last task alone. One worker: tasks of `per_task`.

    Parameters
    ----------
    todo : list of int
        The frames.
    per_task : int
    workers : int

    Returns
    -------
    list of tuple of int
    """
    chunks, start = [], 0
    while start < len(todo):
        left = len(todo) - start
        size = per_task if workers <= 1 else min(per_task, max(1, -(-left // (2 * workers))))
        chunks.append(tuple(todo[start:start + size]))
        start += size
    return chunks


def run_batch(job: BatchJob, where: Where = Where(), frames_per_task: int | None = None,
              overwrite: bool = False,
              progress: Callable[[BatchProgress], None] | None = None, cancel=None) -> BatchReport:
    """Reconstruct every frame of job.session not yet done in job.out.

    What is done is listed in the manifest (see mirrorcore.batch.manifest). Frames that cannot be
    read or reconstructed are reported in the report and the manifest, the others go on; a rerun
    does only the frames still missing.

    Parameters
    ----------
    job : BatchJob
    where : Where
    frames_per_task : int, optional
        Default `default_frames_per_task`.
    overwrite : bool
        Do every frame again when the manifest was made with other settings or inputs.
    progress : callable, optional
        progress(BatchProgress) is called after each task and when a worker dies.
    cancel : threading.Event or callable, optional
        Stops the run (a callable returning True): frames finished are kept and the manifest is
        written.

    Returns
    -------
    BatchReport

    Raises
    ------
    MirrorscanError
        One line, for a bad session, output folder or cluster (a scheduler that does not answer
        as Dask within scheduler.PROBE_SECONDS: nothing is written then).
    """
    session = load_session(Path(job.session).resolve())
    job = replace(job, session=Path(session.root),
                  out=Path(job.out).resolve()).for_session(session)
    per_task = default_frames_per_task(job.method) if frames_per_task is None else frames_per_task
    if per_task < 1:
        raise MirrorscanError(f"--frames-per-task: at least 1, got {per_task}")
    if job.temporal:
        check_window_memory(min(2 * job.temporal + 1, len(session.frames)), session.camera.shape,
                            f"--temporal {job.temporal}")
    context = FrameContext.build(session, job, threads=None if where.in_process else 1)
    # a peer that is not a Dask scheduler is refused before the folder is made or distributed
    # imported (a second)
    try:
        if where.scheduler is not None:
            probe_scheduler(where.scheduler, cancel)
    except Cancelled:
        return BatchReport(job.out, len(context.names), 0, 0, cancelled=True)
    folder = OutputFolder(job.out, str(session.root), job.settings(),
                          session_inputs(session, job.scene_colour),
                          context.names, [Path(session.root) / f for f in session.frames],
                          overwrite)
    try:
        todo = [i for i in range(len(context.names)) if i not in folder.kept]
        run = _Run(folder, len(context.names), progress)
        if todo and not cancel_requested(cancel):
            try:
                with task_executor(where, context, cancel) as executor:
                    run.drive(executor, task_chunks(todo, per_task, executor.workers), cancel)
            # a cancel request while waiting for the cluster's workers: the report says cancelled
            except Cancelled:
                if not cancel_requested(cancel):
                    raise
        return run.report(job.out, cancelled=cancel_requested(cancel))
    finally:
        folder.flush()
        folder.close()


class _Run:
    """The client's side of one run: results into the manifest, progress, the figures of the
    report."""

    def __init__(self, folder: OutputFolder, total: int,
                 progress: Callable[[BatchProgress], None] | None):
        self.folder, self.total, self.progress = folder, total, progress
        self.kept = len(folder.kept)
        self.written = 0
        self.failed: dict[int, str] = {}
        self.retried: dict[int, str] = {}
        self.dashboard: str | None = None
        self.created = time.perf_counter()
        self.started = self.finished = None

    def drive(self, executor, chunks: list[tuple[int, ...]], cancel) -> None:
        """Submit every chunk, then take results until none is pending or a cancel request comes."""
        self.dashboard = executor.dashboard
        self.started = time.perf_counter()
        executor.submit(chunks)
        self._report()
        while executor.pending and not cancel_requested(cancel):
            results = executor.wait(POLL_SECONDS)
            deaths = executor.deaths()
            self.retried.update(deaths)
            for chunk, records, failures in results:
                self.folder.add(records, failures)
                self.written += len(records)
                self.failed.update(failures)
                self.finished = time.perf_counter()
            if results or deaths:
                self._report()

    def _report(self) -> None:
        """Pass the figures so far to `progress` as a BatchProgress."""
        if self.progress is None:
            return
        fps = self._fps()
        left = self.total - self.kept - self.written - len(self.failed)
        self.progress(BatchProgress(self.total, self.kept + self.written, self.kept,
                                    len(self.failed), fps,
                                    left / fps if fps > 0 else None, tuple(sorted(self.retried)),
                                    self.dashboard))

    def _fps(self) -> float:
        """Frames written per second between the first task and the last result (0 before)."""
        seconds = (self.finished or 0.0) - (self.started or 0.0)
        return self.written / seconds if self.started and seconds > 0 else 0.0

    def report(self, out: Path, cancelled: bool) -> BatchReport:
        seconds = (self.finished - self.started) if self.started and self.finished else 0.0
        startup = (self.started - self.created) if self.started else 0.0
        return BatchReport(out, self.total, self.kept, self.written,
                           dict(sorted(self.failed.items())),
                           dict(sorted(self.retried.items())), seconds, startup, cancelled,
                           self.dashboard)


class BatchRun:
    """A batch in a background thread, for a UI.

    start() it, read `progress` or pass `on_progress`, cancel() it, wait() for its BatchReport.

    Parameters
    ----------
    job, where, frames_per_task, overwrite
        As for `run_batch`.
    on_progress : callable, optional
        Called with each BatchProgress.

    Attributes
    ----------
    progress : BatchProgress or None
        The latest, None before the first.
    error : Exception or None
        The exception that ended it (a MirrorscanError: show its one line); wait() re-raises it.
    """

    def __init__(self, job: BatchJob, where: Where = Where(), frames_per_task: int | None = None,
                 overwrite: bool = False,
                 on_progress: Callable[[BatchProgress], None] | None = None):
        self.job, self.where = job, where
        self.frames_per_task, self.overwrite = frames_per_task, overwrite
        self.on_progress = on_progress
        self.progress: BatchProgress | None = None
        self.report: BatchReport | None = None
        self.error: BaseException | None = None
        self._cancel = threading.Event()
        self._thread = threading.Thread(target=self._run, name="mirrorscan-batch", daemon=True)

    def start(self) -> BatchRun:
        """Start the run's thread; returns self."""
        self._thread.start()
        return self

    def cancel(self) -> None:
        """Ask the run to stop: the frames finished are kept, the manifest is written.

        Then wait() returns.
        """
        self._cancel.set()

    @property
    def running(self) -> bool:
        """True while the run's thread is alive."""
        return self._thread.is_alive()

    def wait(self, timeout: float | None = None) -> BatchReport | None:
        """Wait for the report once the run has ended.

        Parameters
        ----------
        timeout : float, optional
            Seconds.

        Returns
        -------
        BatchReport or None
            None if it is still running after `timeout`.

        Raises
        ------
        Exception
            The error that ended the run.
        """
        self._thread.join(timeout)
        if self._thread.is_alive():
            return None
        if self.error is not None:
            raise self.error
        return self.report

    def _progress(self, progress: BatchProgress) -> None:
        """Keep the latest BatchProgress and pass it to `on_progress`."""
        self.progress = progress
        if self.on_progress is not None:
            self.on_progress(progress)

    def _run(self) -> None:
        """Run the batch; keep its report, or the exception that ended it."""
        try:
            self.report = run_batch(self.job, self.where, self.frames_per_task, self.overwrite,
                                    self._progress,
                                    self._cancel)
        except BaseException as exc:       # noqa: BLE001 (kept for wait() and the UI)
            self.error = exc

