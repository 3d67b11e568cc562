"""The browser tool: one viser server, one depth source, one session being edited, shared by every
tab.

The app is the mediator: it owns the shared services (the session editor, the live loop, the jobs,
the event bus) and gives each connected tab a Tab of its own; tabs and their panels talk to it only
through mirrorscan.context.Services.
"""
from __future__ import annotations

import contextlib
import io
import logging
import math
import threading
import time
import warnings
from pathlib import Path

import viser

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.session import Session
from mirrorcore.sources import DepthSource

from .appsources import IN_MEMORY, AppSources
from .editor import SessionEditor
from .events import EventBus, FrameReady, LoopChanged, SessionChanged
from .jobs import BATCH, DENSE, RECORD, REFINE, Jobs
from .live import RECENT_FRAMES, LiveLoop
from .liveframe import LiveFrame
from .notices import LastingNote, Notifier
from .panels.session import MAX_UPLOAD_MB
from .security import protect
from .state import Snapshot
from .tab import Resume, Tab
from .wording.saving import saving_note

log = logging.getLogger("mirrorscan")
# how often session.json is looked at: did another program change it (it is then reloaded)
FILE_POLL_S = 0.5
# how often the tabs are asked whether they are hidden or lag, while the live cloud plays
VISIBILITY_POLL_S = 0.5
# the same while it is paused or a job of BUSY_JOBS runs: each question makes viser's page draw
# its 3D scene for 250 ms, which keeps a browser without a GPU busy on one core
QUIET_POLL_S = 5.0
# the live loop's rate while no tab shows the cloud and nothing records (depth frame: 8 Hz)
IDLE_FPS = 10.0
# the live loop's rate while a job that needs the cores runs: each cloud sent makes the page draw
# for 250 ms
BUSY_FPS = 1.0
BUSY_JOBS = {REFINE: "the calibration from the object", DENSE: "the dense reconstruction",
             BATCH: "the batch"}
# the scene's ambient light (no environment map): the mirrors' panes show their colours
AMBIENT_LIGHT = 1.5
# CSS pixels: the side panel, docked right; the 3D view and the depth frame use the rest
PANEL_WIDTH = 400
# seconds between two tries to save a session whose save failed (each edit tries too)
SAVE_RETRY_S = 3.0
# seconds: a page reloaded within this takes up its work (Tab.identify tells the page)
RESUME_S = 600.0
GRADING_WAIT_S = 10.0     # seconds a stop waits for the first frames' grading of the markers to end


def quiet_closed_connections() -> None:
    """Silence viser's warning that something was queued for a tab that has gone.

    The warning reads "Queued a ... on a closed connection".

    A tab can close at any moment, also between the server's check and its send, and viser then
    drops the message, which is what is wanted (the Tab is closed when viser reports the
    disconnection). viser attributes the warning to the caller's line, so the filter goes by its
    words alone.
    """
    warnings.filterwarnings("ignore", message=r"Queued a \w+ on a closed connection",
                            category=UserWarning)


# once, on import: for the whole process, whichever thread viser warns on
quiet_closed_connections()


class MirrorscanApp(Notifier, AppSources):
    """Wires the session editor, the live loop, the jobs and the tabs (see the module docstring).

    The server is protected before it accepts a page.

    Parameters
    ----------
    session : Session
        The session to edit, autosaved when `autosave`.
    source : DepthSource
        Where frames come from.
    host, port
        Where the server listens.
    sessions_dir : str or Path
        The folder that Open and Save as work in.
    token : str or None
        The secret a browser must give (required beyond loopback; a new one when None; see
        mirrorscan.security).
    read_only : str or None
        Why the session is open read-only (another program edits it), else None.

    Raises
    ------
    SessionLocked
        Another editor holds the session's folder (see mirrorscan.editing.EditorCore).
    """

    def __init__(self, session: Session, source: DepthSource, host: str = "127.0.0.1",
                 port: int = 8080, autosave: bool = True, sessions_dir: str | Path = "sessions",
                 token: str | None = None, read_only: str | None = None):
        # first: refused while another editor holds the session
        self.editor = SessionEditor(session, autosave, read_only)
        self._source, self.sessions_dir = source, Path(sessions_dir)
        # the camera or simulator served from the start: replays come back to it
        self.start_source = source
        # viser prints a banner; stdout may be JSON (bench --json)
        with contextlib.redirect_stdout(io.StringIO()):
            self.server = viser.ViserServer(host=host, port=port, label="mirrorscan", verbose=False)
        # before any page can connect: Host, Origin and token checks, upload limits
        try:
            self.guard = protect(self.server, host, token, max_upload_bytes=MAX_UPLOAD_MB << 20)
        except MirrorscanError:
            self.server.stop()
            raise
        self.server.gui.configure_theme(show_share_button=False, brand_color=(0, 114, 178))
        self.server.gui.main_panel.dock_right()
        # Nothing in the scene is glossy: no environment map and no shadows, which cost a laptop
        # without a GPU (and headless Chromium) a third of its frame rate; an ambient light keeps
        # the panes in their mirrors' colours.
        self.server.scene.configure_environment_map(hdri=None)
        self.server.scene.configure_default_lights(enabled=True, cast_shadow=False)
        self.server.scene.add_light_ambient("/ambient", intensity=AMBIENT_LIGHT)
        self.server.gui.main_panel.set_width(PANEL_WIDTH)
        self.bus = EventBus()
        # what stays on every tab while the session is not saved (or open read-only)
        self.unsaved = LastingNote(self.server)
        self.unsaved.set(saving_note(self.editor))
        self._background = (session.background, session.read_background() if session.background
                            else source.background())
        self._snapshot = Snapshot.build(session, self._background[1])
        self.last_frame: LiveFrame | None = None
        self._last_error = ""
        self.loop = LiveLoop(source, lambda: self._snapshot, self._on_frame, self._on_error,
                             self.fps_wanted)
        self.jobs = Jobs(self.loop, lambda: self._snapshot, self.bus)
        self.tabs: dict[int, Tab] = {}
        # page -> (time.monotonic(), work) of its closed tab
        self._left: dict[str, tuple[float, Resume]] = {}
        self._tabs_lock = threading.Lock()
        # snapshots are rebuilt one at a time, in order
        self._session_lock = threading.Lock()
        self._stop = threading.Event()
        # the first frames' grading of the markers (_on_frame)
        self._grading: threading.Thread | None = None
        self._poller = threading.Thread(target=self._poll_tabs, name="mirrorscan-tabs",
                                        daemon=True)
        self.editor.listeners.append(lambda _: self._on_session_change())
        self.editor.listeners.append(lambda _: self.unsaved.set(saving_note(self.editor)))
        self.server.on_client_connect(self._connect)
        self.server.on_client_disconnect(self._disconnect)

    @property
    def port(self) -> int:
        """The port the viser server listens on."""
        return self.server.get_port()

    def start(self) -> None:
        """Start the live loop and the thread that polls the tabs and the session file."""
        self.loop.start()
        self._poller.start()

    def stop(self) -> None:
        """End a recording (its frames are kept), then the loop, the jobs (cancelled), the server.

        Waits up to GRADING_WAIT_S for the first frames' grading of the markers, so that the
        process exits with its own status.
        """
        self._stop.set()
        if self.jobs.running(RECORD):
            try:
                self.jobs.stop_recording(self.editor.session)
            except MirrorscanError as exc:
                log.warning("recording not finished cleanly: %s", exc)
        self.loop.stop()
        self.jobs.stop()
        if self._grading is not None:
            self._grading.join(GRADING_WAIT_S)
        with contextlib.redirect_stdout(io.StringIO()):
            self.server.stop()
        self.editor.close()

    # ------------------------------------------------------------------ tabs
    def _connect(self, client: viser.ClientHandle) -> None:
        """Make a Tab for a new client and find out which page it is."""
        tab = Tab(client, self)
        self.unsaved.connected(client)
        with self._tabs_lock:
            # viser runs this and _disconnect on its thread pool, side by side: a tab closed (or
            # reloaded) while its Tab was built may have run its _disconnect already, which found
            # nothing to close. viser drops the client from get_clients() before it calls
            # _disconnect, so checked under the lock one of the two closes it.
            if client.client_id in self.server.get_clients():
                self.tabs[client.client_id] = tab
                threading.Thread(target=self._resume, args=(tab,), name="mirrorscan-resume",
                                 daemon=True).start()
                return
        tab.close()

    def _resume(self, tab: Tab) -> None:
        """Which page the tab is (tab.identify).

        A reload of a page closed within RESUME_S takes up its work.
        """
        page = tab.identify()
        with self._tabs_lock:
            now = time.monotonic()
            self._left = {p: left for p, left in self._left.items() if now - left[0] <= RESUME_S}
            left = self._left.pop(page, None) if page else None
        if left is not None:
            tab.take_up(left[1])

    def _disconnect(self, client: viser.ClientHandle) -> None:
        """Close a client's Tab, keeping its work for a reload of its page."""
        self.unsaved.disconnected(client)
        with self._tabs_lock:
            tab = self.tabs.pop(client.client_id, None)
            if tab is not None and tab.page is not None:
                self._left[tab.page] = (time.monotonic(), tab.resume())
        if tab is not None:
            tab.close()

    def tab(self, client: viser.ClientHandle) -> Tab:
        """The Tab of a connected client.

        Parameters
        ----------
        client : viser.ClientHandle
            A connected tab.

        Returns
        -------
        Tab
        """
        with self._tabs_lock:
            return self.tabs[client.client_id]

    def _poll_tabs(self) -> None:
        # time.monotonic() when the tabs were last asked
        """Ask the tabs whether they are hidden or lag, and reload a changed session file."""
        asked = -math.inf
        while not self._stop.wait(FILE_POLL_S):
            if time.monotonic() - asked >= self._visibility_poll_s():
                asked = time.monotonic()
                with self._tabs_lock:
                    tabs = list(self.tabs.values())
                for tab in tabs:
                    tab.poll_visibility()
                    tab.header.poll_draws()
            self.act(None, self._reload_if_changed)
            self.act(None, lambda: self.editor.retry_save(SAVE_RETRY_S))

    def _visibility_poll_s(self) -> float:
        """Seconds between two questions to the tabs.

        VISIBILITY_POLL_S while the live cloud plays, else QUIET_POLL_S (nothing is streamed that a
        hidden or lagging tab should be spared, and each question costs the page a draw).
        """
        return QUIET_POLL_S if self.paused or self._busy() is not None else VISIBILITY_POLL_S

    def _busy(self) -> str | None:
        """What runs of BUSY_JOBS (its words), or None."""
        return next((what for job, what in BUSY_JOBS.items() if self.jobs.running(job)), None)

    def _reload_if_changed(self) -> None:
        """Reload session.json when another program changed it, and say so."""
        message = self.editor.reload_if_changed()
        if message:
            self.notify(None, "Session file changed", message, "info")
            # the agreement lines, for the planes as the file now has them
            self.jobs.start_agreement()

    # ------------------------------------------------------------------ the Services protocol
    @property
    def snapshot(self) -> Snapshot:
        """The current state (replaced whole on every change of the session or its background)."""
        return self._snapshot

    @property
    def source(self) -> DepthSource:
        """The depth source the live loop takes its frames from."""
        return self._source

    @property
    def paused(self) -> bool:
        """Whether the live loop is paused."""
        return self.loop.paused

    def pause(self, paused: bool) -> None:
        """Pause or resume the live loop, and publish LoopChanged.

        Parameters
        ----------
        paused : bool
            Pause it (True) or let it play (False).
        """
        self.loop.pause(paused)
        self.bus.publish(LoopChanged(paused, self._source))

    def step(self) -> None:
        """Process exactly one more frame while paused."""
        self.loop.step()

    def seek(self, index: int) -> None:
        """Play on from frame `index` (see LiveLoop.seek).

        Parameters
        ----------
        index : int
            The frame's index in the source.
        """
        self.loop.seek(index)

    def fps(self) -> float:
        """The live loop's measured rate, frames per second."""
        return self.loop.rate.fps

    def fps_wanted(self) -> float | None:
        """The live loop's rate when it should be lower than the source's (pacing), else None."""
        paced = self.pacing()
        return None if paced is None else paced[0]

    def pacing(self) -> tuple[float, str] | None:
        """(frames per second, why) when the live loop runs slower than its source, else None.

        None means the source's rate: never slower while a recording runs; BUSY_FPS while a job of
        BUSY_JOBS runs (it needs the cores more than the live cloud does); IDLE_FPS while every tab
        looks at the depth frame (sent at most 8 times a second) or is hidden, as processing 30
        frames a second would only take the cores from the browser on the same laptop.
        """
        if self.jobs.running(RECORD):
            return None
        busy = self._busy()
        with self._tabs_lock:
            tabs = list(self.tabs.values())
        if busy is not None:
            fps, why = BUSY_FPS, f"while {busy} runs"
        elif any(tab.shows_cloud for tab in tabs):
            return None
        else:
            fps, why = IDLE_FPS, "while no tab shows the 3D scene"
        return (fps, why) if self.loop.source.fps > fps else None

    # ------------------------------------------------------------------ reactions
    def _on_session_change(self) -> None:
        """Build the new state of the session and its background, and publish it."""
        with self._session_lock:
            session = self.editor.session
            try:
                if session.background and session.background != self._background[0]:
                    self._background = (session.background, session.read_background())
                elif not session.background and self._background[0] not in (None, IN_MEMORY):
                    self._background = (None, self._source.background())
                snapshot = Snapshot.build(session, self._background[1], self.jobs.marker_frames(),
                                          self._snapshot)
            # a broken background file, a bad selection: keep the last state
            except MirrorscanError as exc:
                self.notify(None, "Session not applied", str(exc))
                return
            self._snapshot = snapshot
        self.bus.publish(SessionChanged(snapshot))

    def _on_frame(self, frame: LiveFrame) -> None:
        """Keep and publish a processed frame; after RECENT_FRAMES, grade the markers."""
        self.last_frame = frame
        self._last_error = ""
        # enough frames to grade the markers of the session as opened
        if frame.index + 1 == RECENT_FRAMES:
            self._grading = threading.Thread(target=self._on_session_change,
                                             name="mirrorscan-grade", daemon=True)
            self._grading.start()
            # enough, too, to tell how its planes agree, before any fit
            if any(m.plane is not None for m in frame.snapshot.session.mirrors):
                self.jobs.start_agreement()
        self.bus.publish(FrameReady(frame))

    def _on_error(self, exc: Exception) -> None:
        """Tell every tab of a failed live frame, once per message."""
        message = f"{type(exc).__name__}: {exc}"
        # said once, not thirty times a second
        if message != self._last_error:
            self.notify(None, "Live frame failed", message)
        self._last_error = message
