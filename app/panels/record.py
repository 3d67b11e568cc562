"""The "Record" folder: record the live frames into a new session folder (with the current calibration), count them,
stop, and replay the recording with the frame slider of the Live folder."""
from __future__ import annotations

import time
from dataclasses import replace
from typing import TYPE_CHECKING

from mirrorcore.errors import MirrorscanError
from mirrorcore.session import Session, save_session
from mirrorcore.sources import SessionSource
from mirrorcore.sources.record import Recorder

from ..recording import LiveTap

if TYPE_CHECKING:
    from ..live import LiveFrame
    from ..server import MirrorscanApp


class RecordPanel:
    def __init__(self, app: "MirrorscanApp"):
        gui, self.app = app.server.gui, app
        self.recorder: Recorder | None = None
        self.tap: LiveTap | None = None
        self.recorded: Session | None = None
        with gui.add_folder("Record", expand_by_default=False):
            self.start_button = gui.add_button("Record")
            self.stop_button = gui.add_button("Stop recording", disabled=True, color="red")
            self.status = gui.add_markdown("Records the live frames into a new session folder.")
            self.replay = gui.add_button("Replay the recording", disabled=True)
        self.start_button.on_click(lambda e: app.act(e.client, self.start))
        self.stop_button.on_click(lambda e: app.act(e.client, self.stop))
        self.replay.on_click(lambda e: app.act(e.client, self.play_recording))
        app.loop.listeners.append(self._count)

    def start(self) -> None:
        if self.recorder is not None:
            raise MirrorscanError("already recording")
        folder = self.app.sessions_dir / time.strftime("recording-%Y%m%d-%H%M%S")
        self.tap = LiveTap(self.app.loop)
        self.recorder = Recorder(self.tap, folder).start()
        self.start_button.disabled, self.stop_button.disabled = True, False
        self.status.content = f"recording into `{folder}`…"

    def stop(self) -> Session:
        """End the recording; the session is saved with the current mirrors and object selection."""
        if self.recorder is None or self.tap is None:
            raise MirrorscanError("not recording")
        self.tap.close()
        recorder, self.recorder = self.recorder, None
        self.start_button.disabled, self.stop_button.disabled = False, True
        recorded = recorder.stop()
        current = self.app.editor.session
        self.recorded = replace(recorded, mirrors=current.mirrors, selection=current.selection)
        save_session(self.recorded)
        dropped = f" ({self.tap.dropped} dropped: the disk was too slow)" if self.tap.dropped else ""
        self.status.content = f"recorded {len(recorded.frames)} frames into `{recorded.root}`{dropped}"
        self.replay.disabled = False
        return self.recorded

    def play_recording(self) -> None:
        """Edit the recorded session and play its frames (Live: Pause and the frame slider)."""
        if self.recorded is None:
            raise MirrorscanError("nothing recorded yet")
        self.app.open_session(self.recorded)
        self.app.use_source(SessionSource(self.recorded))

    def _count(self, frame: "LiveFrame") -> None:
        if self.recorder is not None and frame.index % 10 == 0:
            self.status.content = f"recording: {self.recorder.frames} frames into `{self.recorder.folder}`"
