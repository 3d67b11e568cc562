"""Step 5, "Record": record the live frames into a new session folder (with the current calibration and object
selection), see it count, stop, and replay it with the frame slider (Playback, in the header). One recording at a
time, shared by every tab."""
from __future__ import annotations

from mirrorcore.errors import MirrorscanError
from mirrorcore.session import Session
from mirrorcore.sources import SessionSource

from ..context import TabContext
from ..events import JobProgress
from ..jobs import RECORD

TITLE = "Record"


class RecordPanel:
    TITLE = TITLE

    def __init__(self, tab: TabContext):
        gui, self.tab, self.services = tab.gui, tab, tab.services
        self.recorded: Session | None = None
        self.start_button = gui.add_button("Record", color="red")
        self.stop_button = gui.add_button("Stop recording", disabled=True)
        self.status = gui.add_markdown("Records the live frames into a new session folder.")
        self.replay = gui.add_button("Replay the recording", disabled=True)
        self.start_button.on_click(lambda _: tab.act(self.start))
        self.stop_button.on_click(lambda _: tab.act(self.stop))
        self.replay.on_click(lambda _: tab.act(self.play_recording))
        self._unsubscribe = self.services.bus.subscribe(JobProgress, self._on_job)
        self._on_job(JobProgress(RECORD, 0.0 if self.services.jobs.running(RECORD) else None, ""))

    def detach(self) -> None:
        """Stop listening to the app (the tab closed)."""
        self._unsubscribe()

    def start(self) -> None:
        self.services.jobs.start_recording(self.services.sessions_dir)

    def stop(self) -> Session:
        """End the recording; it is saved with the current mirrors and object selection."""
        self.recorded = self.services.jobs.stop_recording(self.services.editor.session)
        self.replay.disabled = False
        return self.recorded

    def play_recording(self) -> None:
        """Edit the recorded session and play its frames (header › Playback: pause and the frame slider)."""
        if self.recorded is None:
            raise MirrorscanError("nothing recorded yet")
        self.services.open_session(self.recorded)
        self.services.use_source(SessionSource(self.recorded))

    def _on_job(self, event: JobProgress) -> None:
        if event.job != RECORD:
            return
        running = event.fraction is not None
        self.start_button.disabled, self.stop_button.disabled = running, not running
        if event.status:
            self.status.content = event.status
