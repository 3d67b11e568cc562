"""The recording job: the live frames into a new session folder, saved with the mirrors."""

from __future__ import annotations

import threading
from dataclasses import replace
from pathlib import Path

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.session import Session
from mirrorcore.io.sessionfile import save_session
from mirrorcore.io.sessionlock import SessionLock
from mirrorcore.sources.record import Recorder, new_recording_folder

from ..events import FrameReady
from ..liveframe import frame_number
from ..recording import LiveTap
from ..sessionfile import EDITOR
from ..results import Recorded, RecordingState, Replay
from .runner import RECORD, Runner

COUNT_EVERY = 10  # live frames between two counts of the frames recorded


class RecordingJob(Runner):
    """Recording (Jobs mixes it in); `recorder` while one runs."""

    recorder: Recorder | None = None
    _tap: LiveTap | None = None

    def start_recording(self, sessions_dir: Path) -> Path:
        """Record the live frames into a new session folder in `sessions_dir`.

        The folder gets a name of its own even when two recordings start in the same second;
        stop_recording() saves it with the session's mirrors and selection as they are then.

        Parameters
        ----------
        sessions_dir : Path

        Returns
        -------
        Path
            The folder.

        Raises
        ------
        MirrorscanError
            While a recording runs.
        """
        with self._lock:
            if RECORD in self._running:
                raise MirrorscanError("already recording; stop first")
            self._running[RECORD] = threading.Event()
        try:
            folder = new_recording_folder(sessions_dir)
            self._tap = LiveTap(
                self.loop.source,
                lambda take: self.bus.subscribe(FrameReady, lambda e: take(e.frame)),
            )
        except (MirrorscanError, OSError):
            with self._lock:
                self._running.pop(RECORD, None)
            raise
        self.recorder = Recorder(self._tap, folder).start()
        self.progress(RECORD, 0.0, self.recording_state())
        self._unsubscribe_count = self.bus.subscribe(
            FrameReady, lambda e: self._count(e.frame.index)
        )
        return folder

    def _replay_at(self) -> Replay | None:
        """Where the recording that plays is, or None for a live source."""
        count = self.loop.source.frame_count
        return Replay(frame_number(max(self.loop.index - 1, 0), count), count) if count else None

    def _count(self, index: int) -> None:
        """Say how many frames the recording holds, every COUNT_EVERY live frames."""
        state = self.recording_state()
        if state is not None and index % COUNT_EVERY == 0:
            self.progress(RECORD, 0.0, state)

    def recording_state(self) -> RecordingState | None:
        """How the recording stands, or None when none runs."""
        recorder, tap = self.recorder, self._tap
        if recorder is None or tap is None:
            return None
        error = str(recorder.error) if recorder.done and recorder.error is not None else None
        ended = tap.replay_ended or (recorder.done and error is None)
        return RecordingState(
            Path(recorder.folder), tap.taken, recorder.frames, self._replay_at(), ended, error
        )

    def stop_recording(self, current: Session) -> Session:
        """End the recording and save it with the `current` session's mirrors and selection.

        Parameters
        ----------
        current : Session
            The session being edited.

        Returns
        -------
        Session
            The recording, saved.

        Raises
        ------
        MirrorscanError
            When no recording runs.
        """
        with self._lock:
            if RECORD not in self._running or self.recorder is None or self._tap is None:
                raise MirrorscanError("not recording")
        recorder, tap = self.recorder, self._tap
        self._unsubscribe_count()
        tap.close()
        try:
            # always returns; a stuck source is named with what was saved
            recorded = recorder.stop(timeout=5)
        finally:
            with self._lock:
                self._running.pop(RECORD, None)
            self.recorder = self._tap = None
        recorded = replace(recorded, mirrors=current.mirrors, selection=current.selection)
        # the recorder released the folder's lock: take it again for the session's last save
        with SessionLock(recorded.root, EDITOR):
            save_session(recorded)
        self.progress(
            RECORD, None, Recorded(len(recorded.frames), Path(recorded.root), tap.dropped)
        )
        return recorded
