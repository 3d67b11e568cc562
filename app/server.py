"""The browser tool: one viser server, one depth source, one session being edited; every tab sees the same state."""
from __future__ import annotations

import contextlib
import io
import logging
import threading
import time
from pathlib import Path
from typing import Callable

import numpy as np
import viser

from mirrorcore.depthio import write_depth_png
from mirrorcore.errors import MirrorscanError
from mirrorcore.session import Session
from mirrorcore.sources import DepthSource

from .depthscreen import DepthScreen
from .editor import SessionEditor
from .live import LiveFrame, LiveLoop
from .overlays import colourise_depth, draw_mask, draw_mirrors, draw_polygon
from .panels.dense import DensePanel
from .panels.files import FilesPanel
from .panels.live import LivePanel
from .panels.measure import MeasurePanel
from .panels.mirrors import MirrorsPanel
from .panels.record import RecordPanel
from .panels.selection import SelectionPanel
from .state import SharedState, Snapshot
from .view import SceneView

log = logging.getLogger("mirrorscan")

DEPTH_VIEW_HZ = 8.0   # the depth frame is re-sent at most this often while live
ROI_COLOUR = (255, 255, 255)


class MirrorscanApp:
    """Wires the session editor, the live loop, the 3D view, the depth screen and the panels.

    session : the session to edit (autosaved when `autosave`); source : where frames come from; sessions_dir : the
    folder that Open and Save as work in.
    """

    def __init__(self, session: Session, source: DepthSource, host: str = "127.0.0.1", port: int = 8080,
                 autosave: bool = True, sessions_dir: str | Path = "sessions"):
        self.source, self.sessions_dir = source, Path(sessions_dir)
        with contextlib.redirect_stdout(io.StringIO()):   # viser prints a banner; stdout may be JSON (bench --json)
            self.server = viser.ViserServer(host=host, port=port, label="mirrorscan", verbose=False)
        self.editor = SessionEditor(session, autosave)
        self._background = (session.background, session.read_background() if session.background
                            else source.background())
        self.state = SharedState(Snapshot.build(session, self._background[1]))
        self.last_frame: LiveFrame | None = None
        self._scene_lock = threading.RLock()   # the loop's thread and the browser's callbacks both redraw the scene
        self._last_screen = 0.0
        self._last_error = ""
        self.view = SceneView(self.server)
        self.view.show_rig(self.state.current.rig)
        self.screen = DepthScreen(self.server, session.camera, self._on_pixel)
        self.loop = LiveLoop(source, self.state, self._on_error)
        self.live_panel = LivePanel(self)
        self.mirrors_panel = MirrorsPanel(self)
        self.selection_panel = SelectionPanel(self)
        self.measure_panel = MeasurePanel(self)
        self.dense_panel = DensePanel(self)
        self.record_panel = RecordPanel(self)
        self.files_panel = FilesPanel(self)
        self.loop.listeners.append(self._on_frame)
        self.editor.listeners.append(lambda _: self._on_session_change())
        self.server.on_client_connect(self.view.look_from_home)

    @property
    def port(self) -> int:
        return self.server.get_port()

    def start(self) -> None:
        self.loop.start()

    def stop(self) -> None:
        self.loop.stop()
        with contextlib.redirect_stdout(io.StringIO()):
            self.server.stop()

    # ------------------------------------------------------------------ actions from the browser
    def act(self, client: viser.ClientHandle | None, action: Callable[[], object]) -> None:
        """Run a user's action; a refusal (MirrorscanError) or a file error becomes a notification on that tab."""
        try:
            action()
        except (MirrorscanError, OSError) as exc:
            self.notify(client, "Not done", str(exc))

    def notify(self, client: viser.ClientHandle | None, title: str, message: str) -> None:
        log.info("%s: %s", title, message)
        targets = [client] if client is not None else list(self.server.get_clients().values())
        for target in targets:
            target.add_notification(title, message, color="red", auto_close_seconds=8.0)

    def open_session(self, session: Session) -> None:
        """Edit another session (autosaved in its folder from now on)."""
        self.editor.autosave = True
        self._background = (None, self.source.background())   # the session's own, if any, is read on the change
        self.editor.replace_session(session)

    def use_source(self, source: DepthSource) -> None:
        """Take frames from another source of the same camera (a recording to replay)."""
        if source.intrinsics.shape != self.source.intrinsics.shape:
            raise MirrorscanError(f"{source.name}: its {source.intrinsics.width}x{source.intrinsics.height} frames "
                                  f"do not fit this session's camera")
        self.source = source
        self.loop.use_source(source)
        self.live_panel.follow_source(source)

    def set_background(self, depth: np.ndarray, relative_path: str) -> None:
        """Use `depth` (H, W metres) as the background; saved beside a saved session as `relative_path`."""
        if self.editor.autosave:
            root = Path(self.editor.session.root)
            root.mkdir(parents=True, exist_ok=True)
            write_depth_png(root / relative_path, depth, self.editor.session.camera.depth_scale)
            self._background = (relative_path, depth)
            self.editor.set_background(relative_path)
        else:
            self._background = (None, depth)
            self._on_session_change()

    def show_pixel(self, u: float, v: float) -> None:
        frame = self.last_frame
        if frame is not None:
            rows, cols = frame.depth.shape
            depth = float(frame.depth[min(int(round(v)), rows - 1), min(int(round(u)), cols - 1)])
            self.live_panel.show_pixel(u, v, depth)

    # ------------------------------------------------------------------ reactions
    def _on_session_change(self) -> None:
        with self._scene_lock:
            self._apply_session()

    def _apply_session(self) -> None:
        session = self.editor.session
        try:
            if session.background and session.background != self._background[0]:
                self._background = (session.background, session.read_background())
            elif not session.background and self._background[0] is not None:
                self._background = (None, self.source.background())
            self.state.replace(Snapshot.build(session, self._background[1]))
        except MirrorscanError as exc:   # a broken background file, a bad selection: keep the last state
            self.notify(None, "Session not applied", str(exc))
            return
        self.view.show_rig(self.state.current.rig)
        self.mirrors_panel.refresh()
        self.selection_panel.refresh()
        self.files_panel.refresh()
        self.redraw_screen()

    def _on_pixel(self, u: float, v: float, client: viser.ClientHandle) -> None:
        self.mirrors_panel.handle_click(u, v, client)

    def _on_frame(self, frame: LiveFrame) -> None:
        with self._scene_lock:
            self._show_frame(frame)

    def _show_frame(self, frame: LiveFrame) -> None:
        self.last_frame = frame
        self._last_error = ""
        self.view.show_cloud(frame.cloud, len(frame.snapshot.rig.mirrors) + 1)
        self.live_panel.show(frame)
        self.measure_panel.on_frame(frame)
        now = time.perf_counter()
        if now - self._last_screen >= 1 / DEPTH_VIEW_HZ or self.loop.paused:
            self.redraw_screen()

    def redraw_screen(self) -> None:
        """The depth frame with the object mask, mirrors (and drafts), the picked vertex and the region of interest."""
        with self._scene_lock:
            self._draw_screen()

    def _draw_screen(self) -> None:
        frame = self.last_frame
        if frame is None:
            return
        self._last_screen = time.perf_counter()
        valid = frame.depth[frame.depth > 0]
        near, far = np.percentile(valid, [1, 99]) if len(valid) else (0.5, 4.5)
        rgb = draw_mask(colourise_depth(frame.depth, near, far), frame.mask)
        draw_mirrors(rgb, self.editor.session.mirrors, self.editor.open_drafts(), self.mirrors_panel.selected_vertex)
        roi = self.state.current.session.selection.roi
        if roi:
            draw_polygon(rgb, roi, ROI_COLOUR, closed=True)
        if self.selection_panel.roi_draft:
            draw_polygon(rgb, self.selection_panel.roi_draft, ROI_COLOUR, closed=False)
        self.screen.show(rgb)
        self.live_panel.depth_range.content = f"depth frame: {near:.2f} m (red) to {far:.2f} m (blue), black: no reading"

    def _on_error(self, exc: Exception) -> None:
        message = f"{type(exc).__name__}: {exc}"
        if message != self._last_error:      # say it once, not thirty times a second
            self.notify(None, "Live frame failed", message)
        self._last_error = message
