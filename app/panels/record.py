"""Step 5, "Record": record the live frames into a new session folder (with the current calibration
and object selection), see it count, stop, and replay it with the frame slider (in the header); then
reconstruct every frame of the session being edited in a batch (mirrorcore.batch), with its
progress, time left and a cancel. One recording and one batch at a time, shared by every tab."""

from __future__ import annotations

from pathlib import Path

from mirrorcore.batch import BATCH_METHODS
from mirrorcore.batch.executor import cores
from mirrorcore.dense import DenseOptions
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.fields import shown
from mirrorcore.io.session import Session
from mirrorcore.sources import DepthSource, SessionSource

from ..context import TabContext
from ..events import JobProgress, LoopChanged, SessionChanged
from ..jobs import BATCH, RECORD
from ..results import BatchStarting
from ..wording import Message
from ..wording.jobs import recording, say, status

TITLE = "Record"
CANCELLING = " · **cancelling…**"  # after the batch's status from Cancel until it stops
BATCH_IDLE = (
    "One PLY per frame and a manifest in the session's exports/ folder; a second run goes on where "
    "the first stopped."
)
IDLE = (
    "Records the frames as they come into a new session folder (from a recording that plays: up to "
    "its last "
    "frame, none twice)."
)
# the batch's temporal smoothing unless changed: on the walking figure the still body 42 % less
# noisy, the limbs as they were (README, Temporal smoothing for moving people)
BATCH_TEMPORAL = 2


def batch_label(session: Session) -> str:
    """The batch button's label: it names the session whose frames it reconstructs.

    After a replay and Back to, that is the recording's, not the session that plays.

    Parameters
    ----------
    session : Session

    Returns
    -------
    str
    """
    count = len(session.frames)
    frames = f"{count} frame{'s' if count != 1 else ''}"
    name = shown(Path(session.root).name)
    return f"Reconstruct every frame of session {name} ({frames})"


class RecordPanel:
    """Step 5, "Record": record, replay and reconstruct every frame (see the module docstring).

    Parameters
    ----------
    tab : TabContext
        The tab it is built in.
    """
    TITLE = TITLE

    def __init__(self, tab: TabContext):
        gui, self.tab, self.services = tab.gui, tab, tab.services
        self.recorded: Session | None = None
        self.start_button = gui.add_button("Record", color="red")
        self.stop_button = gui.add_button("Stop recording", disabled=True)
        state = self.services.jobs.recording_state()
        self.status = gui.add_markdown(IDLE if state is None else recording(state).markdown())
        self.replay = gui.add_button("Replay the recording", disabled=True)
        with gui.add_folder("Reconstruct every frame (batch)", expand_by_default=False):
            self.method = gui.add_dropdown("Method", BATCH_METHODS, initial_value="raw")
            self.temporal = gui.add_slider(
                "Temporal smoothing (neighbours)",
                min=0,
                max=5,
                step=1,
                initial_value=BATCH_TEMPORAL,
                hint="each pixel averaged with the same pixel of this many frames before and "
                "after, where the "
                "scene is still there (0: none)",
            )

            self.workers = gui.add_slider(
                "Worker processes", min=1, max=cores(), step=1, initial_value=1
            )
            self.batch = gui.add_button(batch_label(self.services.editor.session))
            self.batch_cancel = gui.add_button("Cancel the batch", visible=False)
            self.batch_progress = gui.add_progress_bar(0.0, visible=False)
            self.batch_status = gui.add_markdown(BATCH_IDLE)
        self.batch.on_click(lambda _: tab.act(self.start_batch))
        self.batch_cancel.on_click(lambda _: self.cancel_batch())
        self.start_button.on_click(lambda _: tab.act(self.start))
        self.stop_button.on_click(lambda _: tab.act(self.stop))
        self.replay.on_click(lambda _: tab.act(self.play_recording))
        # the session the batch line speaks of
        self._batch_root = self.services.editor.session.root
        self._batch_said = Message(BATCH_IDLE)  # ... and its last message
        self._unsubscribe = [
            self.services.bus.subscribe(JobProgress, self._on_job),
            self.services.bus.subscribe(LoopChanged, lambda e: self._offer_replay(e.source)),
            self.services.bus.subscribe(SessionChanged, self._session_changed),
        ]
        self._on_job(
            JobProgress(RECORD, 0.0 if self.services.jobs.running(RECORD) else None, "", None)
        )
        # a tab opened while one runs shows it and its settings
        if self.services.jobs.running(BATCH):
            self._show_batch()

    def detach(self) -> None:
        """Stop listening to the app (the tab closed)."""
        for unsubscribe in self._unsubscribe:
            unsubscribe()

    def start(self) -> None:
        """Start recording the live frames into a new session folder."""
        self.services.jobs.start_recording(self.services.sessions_dir)

    def stop(self) -> Session:
        """End the recording; it is saved with the current mirrors and object selection."""
        self.recorded = self.services.jobs.stop_recording(self.services.editor.session)
        self._offer_replay(self.services.source)
        return self.recorded

    def _offer_replay(self, source: DepthSource) -> None:
        """Offer the replay once something is recorded, but not while that recording plays."""
        playing = (
            isinstance(source, SessionSource)
            and self.recorded is not None
            and source.session.root == self.recorded.root
        )
        self.replay.disabled = self.recorded is None or playing

    def play_recording(self) -> None:
        """Edit the recorded session and play its frames.

        Header › Playback has the pause button and the frame slider.
        """
        if self.recorded is None:
            raise MirrorscanError("nothing recorded yet")
        self.services.open_session(self.recorded, play=True)

    def start_batch(self) -> None:
        """Reconstruct every frame of the session being edited (a saved recording, say).

        With the chosen method, on the chosen number of worker processes (1: in this process; more:
        a local Dask cluster).
        """
        self.services.jobs.start_batch(
            self.services.editor.session,
            self.method.value,
            DenseOptions(),
            int(self.temporal.value),
            int(self.workers.value),
        )

    def _session_changed(self, event: SessionChanged) -> None:
        """Another session edited: the last batch's line, which named the other's exports, goes."""
        root = event.snapshot.session.root
        if root != self._batch_root and not self.services.jobs.running(BATCH):
            self.batch_status.content = BATCH_IDLE
        self._batch_root = root
        self.batch.label = batch_label(event.snapshot.session)

    def _show_batch(self) -> None:
        """The batch that runs, as its tab started it.

        Its settings (once they are set, just after it starts) and a running status until its next
        progress.
        """
        settings = self.services.jobs.batch_settings
        if settings is not None:
            self.method.value, self.temporal.value, self.workers.value = settings
        starting = BatchStarting(self.method.value)
        self._on_job(JobProgress(BATCH, 0.0, status(starting), starting))

    def cancel_batch(self) -> None:
        """Ask the batch to stop.

        The frame under way finishes; every frame written stays (a new start goes on).
        """
        self.services.jobs.cancel(BATCH)
        self.batch_cancel.disabled = True
        self.batch_status.content = self._batch_line(self._batch_said, cancelling=True)

    @staticmethod
    def _batch_line(said: Message, cancelling: bool) -> str:
        """The batch's line: its message, said to be cancelling after Cancel until it stops."""
        return Message(said.headline + (CANCELLING if cancelling else ""), said.details).markdown()

    def _on_job(self, event: JobProgress) -> None:
        """Follow the recording and the batch: buttons, progress bars and status."""
        if event.job == BATCH:
            running = event.fraction is not None
            self.batch.disabled, self.batch_cancel.visible, self.batch_progress.visible = (
                running,
                running,
                running,
            )
            if running:
                self.batch_progress.value = event.percent
            self._batch_said = say(event.result)[0]
            self.batch_status.content = self._batch_line(
                self._batch_said, running and self.batch_cancel.disabled
            )
            if not running:
                self.batch_cancel.disabled = False
            return
        if event.job != RECORD:
            return
        running = event.fraction is not None
        self.start_button.disabled, self.stop_button.disabled = running, not running
        if event.status:
            self.status.content = event.status
