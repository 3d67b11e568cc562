"""The batch job: every frame of a saved recording reconstructed (mirrorcore.batch)."""

from __future__ import annotations

import threading
from pathlib import Path

from mirrorcore.batch import BatchJob as LibraryBatch
from mirrorcore.batch import BatchReport, BatchRun, Where, exports_folder
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.dense import DenseOptions
from mirrorcore.io.session import SESSION_FILE, Session

from ..results import BatchStarting
from .runner import BATCH, Runner

POLL_S = 0.2  # seconds between two looks at a cancel request


class BatchJob(Runner):
    """Batch reconstruction (Jobs mixes it in).

    Attributes
    ----------
    batch_settings : tuple or None
        The last batch's method, temporal and workers.
    """

    batch_settings: tuple[str, int, int] | None = None

    def start_batch(
        self, session: Session, method: str, options: DenseOptions, temporal: int, workers: int
    ) -> Path:
        """Reconstruct every frame of a saved recording, as a job of its own.

        Into SESSION/exports/frames-METHOD[-temporalN], one PLY per frame and a manifest; a second
        start of the same job goes on where it stopped.

        Parameters
        ----------
        session : Session
            A saved session with frames.
        method : str
            The dense method.
        options : DenseOptions
        temporal : int
            Neighbours each frame is smoothed with.
        workers : int
            Local processes (1: in this process).

        Returns
        -------
        Path
            The output folder.

        Raises
        ------
        MirrorscanError
            When the session is not saved or has no frames, or a batch is running.
        """
        if not session.frames or not (Path(session.root) / SESSION_FILE).is_file():
            raise MirrorscanError(
                "a batch reads a saved session with frames: record one (or Save as) first"
            )
        out = exports_folder(session.root, method, temporal)
        job = LibraryBatch(Path(session.root), out, method, options, temporal)
        self._start(
            BATCH,
            lambda cancel: self._batch(job, Where(workers=workers), cancel),
            "a batch is already running; cancel it first",
        )
        # a tab opening while it runs shows them
        self.batch_settings = (method, temporal, workers)
        return out

    def _batch(self, job: LibraryBatch, where: Where, cancel: threading.Event) -> BatchReport:
        """Run the batch, publishing its progress, until it ends or `cancel` is set."""
        self.progress(BATCH, 0.0, BatchStarting(job.method))
        run = BatchRun(job, where, on_progress=lambda p: self.progress(BATCH, p.fraction, p))
        run.start()
        while run.wait(POLL_S) is None:
            if cancel.is_set():
                run.cancel()
        return run.wait()
