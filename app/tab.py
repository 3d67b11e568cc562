"""One browser tab: its own state (click mode, selected mirror, drafts, picks, view), its 3D scene and depth frame,
its GUI (a status header over one tab per step of the work), and what it streams: the live cloud only while it looks
at the 3D scene, is not hidden and keeps up (MAX_LAG_S), the depth frame at most DEPTH_HZ times a second and at once
after an edit. A page reloaded takes up the work of its tab before (Resume): the page tells which it is (identify)."""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
import viser
from viser import _messages

from mirrorcore.base.palette import SOURCE_COLOURS, source_colour

from .context import MODES, Question, Services, TabState
from .depthscreen import DepthScreen
from .events import DenseChanged, FrameReady, HeatChanged, SessionChanged
from .live import LiveFrame
from .markup import markdown
from .overlays import MarkerMark, MirrorMarks, Overlay
from .panels import PANELS
from .panels.live import LivePanel
from .stream import HALVES
from .view import TabScene, beside_offset, home_pose, scene_points

DEPTH_HZ = 8.0          # the depth frame is re-sent at most this often while it is in view...
DEPTH_HZ_BEHIND = 1.0   # ... and this often while the tab looks at the 3D scene
MAX_LAG_S = 0.5         # a tab that takes longer to answer the visibility poll lags: frames wait in the browser
                        # to be drawn, so it is sent no live cloud and no depth frame until it answers in time (one
                        # that draws slower than the loop sends would otherwise queue frames and show them minutes late)
SETTLING_S = 5.0        # seconds after a tab opens while its page builds: it may lag, and is not said to
OBJECT_MARGIN = 1.6     # Look at the object: the view's nearer edge is this many radii of the object's bounding
                        # sphere from its middle (its points are drawn as discs of many pixels at that distance)
HOME_TOLERANCE = 0.01    # metres: a camera this near where the first view put it has not been moved by the technician
HIDDEN_KEY = "mirrorscan-hidden"
PAGE_KEY = "mirrorscan-page"
PAGE_NAME_CHARS = 64
# A browser tab keeps its sessionStorage through reloads and no other tab shares it: the page's name, made once.
PAGE_JS = """(() => {{
  let page = sessionStorage.getItem("{key}");
  if (!page) {{
    page = Date.now().toString(36) + Math.random().toString(36).slice(2);
    sessionStorage.setItem("{key}", page);
  }}
  localStorage.setItem("viser-user:{key}-{client}", page);
}})();"""
VISIBILITY_JS = """(() => {{
  const key = "viser-user:{key}";
  const put = () => localStorage.setItem(key, document.hidden ? "1" : "0");
  document.addEventListener("visibilitychange", put);
  put();
}})();"""


@dataclass(frozen=True)
class Resume:
    """What a closed tab leaves to the next tab of its page (a reload): its state as the technician left it (the
    click mode, the selected mirror, the boundaries and region being drawn, the view; not a pick, nor a proposal,
    which was that tab's) and whether its heat map was on."""

    state: TabState
    heat: bool


class Tab:
    """Everything of one connected browser tab (see the module docstring)."""

    def __init__(self, client: viser.ClientHandle, services: Services):
        self.client, self.services = client, services
        self.state = TabState()
        self.page: str | None = None      # which browser page this is, once identify() has asked it
        self.hidden = False
        self.lagging = False        # see MAX_LAG_S
        self.lagged_at = -np.inf    # time.perf_counter() when it last lagged, once settled (SETTLING_S)
        self._opened = time.perf_counter()
        self.closed = False
        self._lock = threading.RLock()
        self._state_listeners: list[Callable[[TabState], None]] = []
        self._click_handlers: dict[str, Callable[[float, float], None]] = {}
        self._last_screen = 0.0
        self._stale = True          # the cloud shown is not the last frame's: send both halves next
        self.dense_visible, self.dense_beside = True, True
        self.heat, self._last_heat = False, 0.0
        self.heat_figures: dict[int, tuple[float, float]] = {}   # the last heat map's, per mirror view (HeatChanged)
        self.heat_frames = 0                                      # ... over this many heat maps
        self.heat_of: int | None = None      # the mirror (id) whose points alone the heat map colours (None: all)
        self._heat_event: HeatChanged | None = None                # the heat map drawn
        self._heat_lock = threading.Lock()   # the heat worker's map is drawn, or the switch-off removes it: not both
        self._framed = False
        self._home_pose: tuple[np.ndarray, np.ndarray] | None = None   # (position, look-at) look_home last set
        camera = services.snapshot.session.camera
        self.scene = TabScene(client)
        self.screen = DepthScreen(client, camera, self._clicked)
        self.overlay = Overlay(camera.shape)
        self._session_key: tuple | None = None
        self.header = LivePanel(self)
        group = client.gui.add_tab_group()
        self.panels = []
        for panel in PANELS:
            with group.add_tab(panel.TITLE):
                self.panels.append(panel(self))
        self._unsubscribe = [services.bus.subscribe(FrameReady, self._on_frame),
                             services.bus.subscribe(SessionChanged, lambda e: self._on_session()),
                             services.bus.subscribe(DenseChanged, lambda e: self.show_dense(e.result)),
                             services.bus.subscribe(HeatChanged, self._on_heat)]
        self._on_session()
        self.show_dense(services.jobs.dense_result)
        client.camera.on_update(self._first_view)
        self._watch_visibility()

    def identify(self, timeout: float = 10.0) -> str | None:
        """Ask the page which it is (PAGE_JS: the same through its reloads, its own among tabs); the answer is kept in
        `page`. None when it does not answer in time or went away."""
        key = f"{PAGE_KEY}-{self.client.client_id}"
        self.client._websock_connection.queue_message(
            _messages.RunJavascriptMessage(source=PAGE_JS.format(key=PAGE_KEY, client=self.client.client_id)))
        try:
            answer = self.client.local_storage.get_item(key, timeout=timeout)
        except (TimeoutError, RuntimeError):
            return None
        self.page = answer[:PAGE_NAME_CHARS] if answer else None     # a name, not a store: PAGE_JS makes ~20
        return self.page

    def take_up(self, resume: Resume) -> None:
        """Go on with the work the page's tab before it left (a reload): its state, view and heat map."""
        with self._lock:
            if self.closed:                      # closed meanwhile (reloaded again at once): too late
                return
            self.state = resume.state
        self._on_session()                       # drafts of mirrors gone since are dropped; the panels follow
        if resume.state.view == "depth":
            self.look("depth")
        if resume.heat:
            self.header.heat.value = True
            self.show_heat(True)

    def resume(self) -> Resume:
        """This tab's work, for the next tab to take up (see Resume)."""
        with self._lock:
            state = replace(self.state, drafts=dict(self.state.drafts), picked_corner=None, picked_marker=None,
                            moving_marker=False, flagged_markers=(), proposal_for=())
        return Resume(state, self.heat)

    def _first_view(self, _) -> None:
        """Once the tab has reported its canvas: frame what the tab is looking at (the rig and the cloud, or the
        depth frame when the tab was switched to it before the report)."""
        if not self._framed:
            self._framed = True
            if self.state.view == "depth":
                self.screen.look_at()
            elif self.heat:                    # a reload with the heat map on: its colours are on the object
                self.look_at_object()
            else:
                self.look_home()

    # ------------------------------------------------------------------ the TabContext protocol
    @property
    def gui(self):
        return self.client.gui

    def changed(self) -> None:
        """The tab's state changed: redraw the overlay, re-send the depth frame, tell the panels."""
        self._redraw_overlay()
        self._send_screen(force=True)
        for listener in list(self._state_listeners):
            listener(self.state)

    def on_state(self, callback: Callable[[TabState], None]) -> None:
        self._state_listeners.append(callback)

    def on_click(self, mode: str, handler: Callable[[float, float], None]) -> None:
        assert mode in MODES, mode
        self._click_handlers[mode] = handler

    def act(self, action: Callable[[], object]) -> None:
        self.services.act(self.client, action)

    def ask(self, title: str, text: str, yes: str, on_yes: Callable[[], object], no: str,
            on_no: Callable[[], object] = lambda: None) -> Question:
        gui = self.client.gui
        modal = gui.add_modal(title)
        with modal:
            gui.add_markdown(markdown(text))
            yes_button = gui.add_button(yes, color="red")
            no_button = gui.add_button(no)

        def answer(action: Callable[[], object]) -> None:
            modal.close()
            self.act(action)
        question = Question(modal, lambda: answer(on_yes), lambda: answer(on_no))
        yes_button.on_click(lambda _: question.yes())
        no_button.on_click(lambda _: question.no())
        return question

    def look(self, view: str) -> None:
        """Show the 3D scene or the depth frame; clouds and labels are hidden (and not sent) while the depth frame
        is in view, and the depth frame fills the free area."""
        with self._lock:
            self.state.view = view
        depth = view == "depth"
        self._stale = True
        self.scene.show_clouds(not depth and not self.heat)
        self.scene.show_labels(not depth)
        self.scene.show_dense_layer(self.dense_visible and not depth)
        self.screen.set_visible(depth)
        if depth:
            self.screen.look_at()
            self._send_screen(force=True)
        elif self.heat:                     # its colours are on the object's rims (turned on in the depth view,
            self.look_at_object()           # it had shown the whole rig: a helper)
            self._heat_now()
        else:
            self.look_home()
        for listener in list(self._state_listeners):
            listener(self.state)

    @property
    def shows_cloud(self) -> bool:
        """Whether this tab is sent the live cloud: it looks at the 3D scene and is not hidden."""
        return self.state.view == "3d" and not self.hidden

    def show_heat(self, on: bool) -> None:
        """Show the heat map of a frame a second instead of the live cloud (or go back to the live cloud), the first
        of the last frame at once: paused, no frame comes (the view had stayed empty until Step: a helper)."""
        with self._heat_lock:
            self.heat, self._stale, self._last_heat = on, True, 0.0
            if not on:
                self.scene.show_heat(None, None)
                self.heat_figures, self._heat_event = {}, None
        if on:
            self._heat_now()
        self.scene.show_clouds(not on and self.state.view == "3d")
        if on and self.state.view == "3d":      # its colours are on the object's rims: a few pixels from home
            self.look_at_object()

    def _heat_now(self) -> None:
        """The heat map of the last frame, now (when the tab looks at the 3D scene)."""
        frame = self.services.last_frame
        if frame is not None and self.shows_cloud:
            self._last_heat = time.perf_counter()
            self.services.jobs.start_heat(frame)

    def _on_heat(self, event: HeatChanged) -> None:
        with self._heat_lock:              # a map whose check passed before a switch-off must not be drawn after it
            if self.heat and not self.closed:
                self._heat_event = event
                self._draw_heat()
                self.heat_figures, self.heat_frames = event.figures, event.frames

    def heat_only(self, mirror_id: int | None) -> None:
        """Colour only this mirror's points on the heat map (None: every mirror's), the others' grey and small as
        the camera's: which strip was whose could not be told (a helper)."""
        with self._heat_lock:
            self.heat_of = mirror_id
            if self.heat and self._heat_event is not None and not self.closed:
                self._draw_heat()

    def _draw_heat(self) -> None:
        """Draw the last heat map (under _heat_lock): the camera's points, and those of the mirrors not chosen
        (heat_of), small and grey."""
        event = self._heat_event
        if event.sources is None:
            self.scene.show_heat(event.points, event.colours)
            return
        mirrors = self.services.snapshot.session.mirrors
        label = next((k for k, m in enumerate(mirrors, start=1) if m.id == self.heat_of), None)
        small = event.sources == 0 if label is None else event.sources != label
        colours = np.where((small & (event.sources != 0))[:, None], SOURCE_COLOURS[0], event.colours)
        self.scene.show_heat(event.points, colours.astype(np.uint8), small)

    def show_dense(self, result) -> None:
        """The shared dense result in this tab's scene, as the tab's Dense step says (shown, beside the cloud)."""
        self.scene.show_dense(result, self.dense_visible and self.state.view == "3d", self.dense_beside)

    # ------------------------------------------------------------------ views
    def look_home(self) -> None:
        """The first view: the rig (camera, mirrors) and where the object is, framed for this tab's canvas."""
        self._home_pose = self._frame(np.concatenate([scene_points(self.services.snapshot.rig),
                                                      self._object_points()]))

    def look_at_object(self) -> None:
        """The object's cloud (the last frame's, all its views) filling this tab's canvas, seen as from home; the
        whole rig when there is no object in view."""
        points = self._object_points()
        if len(points) < 2:
            self.look_home()
        else:
            self._frame(points, OBJECT_MARGIN)

    def look_at_dense(self, result) -> None:
        """The object's cloud and a dense result (where this tab draws it: beside the cloud or in place) filling this
        tab's canvas, seen as from home (a Run had shown only the box, its result out of view: a helper)."""
        corners = np.array([result.low, result.high], float) + (beside_offset(result) if self.dense_beside else 0.0)
        self._frame(np.concatenate([self._object_points(), corners]), OBJECT_MARGIN)

    def _object_points(self) -> np.ndarray:
        """(k, 3) metres: about 500 of the last frame's object points (none before the first frame)."""
        frame = self.services.last_frame
        if frame is None or not len(frame.cloud):
            return np.zeros((0, 3))
        return frame.cloud.points[:: max(1, len(frame.cloud) // 500)]

    def _frame(self, points: np.ndarray, margin: float = 1.1) -> tuple[np.ndarray, np.ndarray]:
        """Move this tab's camera to frame `points` (k, 3) metres (view.home_pose, with `margin`) for its canvas;
        returns its (position, look-at), metres."""
        camera = self.client.camera
        try:
            aspect = camera.image_width / max(camera.image_height, 1)
        except AssertionError:            # the tab has not reported its canvas yet
            aspect = 16 / 9
        fov = np.radians(50.0)
        position, target = home_pose(points, fov, aspect, margin)
        with self.client.atomic():
            camera.fov = fov
            camera.up_direction = (0.0, -1.0, 0.0)
            camera.position = tuple(position)
            camera.look_at = tuple(target)
        return position, target

    # ------------------------------------------------------------------ events
    def _on_frame(self, event: FrameReady) -> None:
        if self.closed:                        # a frame in flight while the tab went away
            return
        frame = event.frame
        if self.shows_cloud and not self.lagging:
            if self.heat:
                if time.perf_counter() - self._last_heat >= 1.0 and self.services.jobs.heat_wanted(frame):
                    self._last_heat = time.perf_counter()
                    self.services.jobs.start_heat(frame)
            else:
                half = None if self.services.paused or self._stale else frame.index % HALVES
                self.scene.show_cloud(frame.parts(half), frame.mirror_ids, half)
                self._stale = False
        self._send_screen(frame=frame)
        self.header.show(frame)

    def _on_session(self) -> None:
        """Bring the tab to the app's current session. Its latest snapshot is read under the tab's lock, so that of
        two changes handled at once (SessionChanged is published outside the session's lock) the later is drawn last,
        whatever order their events arrive in."""
        with self._lock:
            snapshot = self.services.snapshot
            ids = tuple(m.id for m in snapshot.session.mirrors)
            for gone in [k for k in list(self.state.drafts) if k not in ids]:   # in place: a boundary click on
                self.state.drafts.pop(gone, None)                                # a GUI thread adds to it meanwhile
            if self.state.mirror_id not in ids:
                self.state.mirror_id = ids[0] if ids else None        # a new tab starts at the first
                self.state.picked_marker = self.state.picked_corner = None
            session = snapshot.session           # what the scene draws: mirrors, and virtual cameras to `bounces`
            key = (session.bounces, *((m.id, m.name, m.plane, m.boundary) for m in session.mirrors))
            rig_changed = key != self._session_key
            if rig_changed:
                self._session_key = key
                self.scene.show_rig(snapshot.rig, ids)
                self.scene.recolour(ids)
        if rig_changed and self.state.view == "3d" and not self.heat and self._still_home():
            self.look_home()           # the rig as it now is (the mirrors fitted after the page opened had left the
        self.changed()                 # figure's head out of view and the camera filling half of it: a helper)

    def _still_home(self) -> bool:
        """Whether this tab's camera is where look_home last put it (HOME_TOLERANCE): not turned or zoomed since."""
        if self._home_pose is None:
            return False
        try:
            position, look_at = self.client.camera.position, self.client.camera.look_at
        except AssertionError:            # the tab has not reported its camera yet
            return False
        return bool(np.allclose(position, self._home_pose[0], atol=HOME_TOLERANCE)
                    and np.allclose(look_at, self._home_pose[1], atol=HOME_TOLERANCE))

    def _clicked(self, u: float, v: float) -> None:
        handler = self._click_handlers.get(self.state.mode)
        if handler is not None:
            self.act(lambda: handler(u, v))

    # ------------------------------------------------------------------ the depth frame
    def _redraw_overlay(self) -> None:
        snapshot, state = self.services.snapshot, self.state
        mirrors = []
        for mirror in snapshot.session.mirrors:
            selected = mirror.id == state.mirror_id
            draft = state.drafts.get(mirror.id)
            grades = snapshot.marker_grades.get(mirror.id, ("unknown",) * len(mirror.markers))
            markers = tuple(MarkerMark(uv, mirror.marker_name(k), grades[k],
                                       picked=selected and state.picked_marker == k,
                                       flagged=(mirror.id, uv) in state.flagged_markers)
                            for k, uv in enumerate(mirror.markers))
            mirrors.append(MirrorMarks(tuple(int(c) for c in source_colour(1, (mirror.id,))),
                                       draft if draft is not None else mirror.boundary, draft is None, markers,
                                       state.picked_corner if selected else None, selected))
        roi = snapshot.session.selection.roi
        region = (state.region_draft, False) if state.region_draft else ((roi, True) if roi else None)
        with self._lock:
            self.overlay.draw(mirrors, region)

    def _send_screen(self, frame: LiveFrame | None = None, force: bool = False) -> None:
        """Compose the shared depth layer of the latest frame with this tab's overlay and send it, when forced (an
        edit) or when DEPTH_HZ (DEPTH_HZ_BEHIND in the 3D view) allows and the tab keeps up; never to a hidden
        tab."""
        frame = frame or self.services.last_frame
        now = time.perf_counter()
        rate = DEPTH_HZ if self.state.view == "depth" else DEPTH_HZ_BEHIND
        if frame is None or self.hidden or (not force and (self.lagging or now - self._last_screen < 1 / rate)):
            return
        self._last_screen = now
        with self._lock:
            rgb = self.overlay.over(frame.depth_rgb)
        self.screen.show(rgb)

    # ------------------------------------------------------------------ visibility
    def _watch_visibility(self) -> None:
        """Ask the browser to note in its localStorage whether this tab is hidden (viser has no message for it)."""
        key = f"{HIDDEN_KEY}-{self.client.client_id}"
        self.client._websock_connection.queue_message(   # viser's own way to run code in a tab (it loads plotly so)
            _messages.RunJavascriptMessage(source=VISIBILITY_JS.format(key=key)))

    def poll_visibility(self, timeout: float = 2.0) -> None:
        """Read whether the tab is hidden (see _watch_visibility), and whether it lags: its answer took longer
        than MAX_LAG_S, or did not come within `timeout` seconds. A tab that comes back, or catches up, gets the
        current state."""
        if self.closed:                   # polled from a list of the tabs taken before it went away
            return
        start = time.perf_counter()
        try:
            value = self.client.local_storage.get_item(f"{HIDDEN_KEY}-{self.client.client_id}", timeout=timeout)
        except TimeoutError:
            self._keeps_up(False)
            return
        except RuntimeError:             # the tab is going away
            return
        self._keeps_up(time.perf_counter() - start <= MAX_LAG_S)
        hidden = value == "1"
        if hidden != self.hidden:
            self.hidden, self._stale = hidden, True
            if not hidden:
                self._send_screen(force=True)

    def _keeps_up(self, keeps_up: bool) -> None:
        if not keeps_up and time.perf_counter() - self._opened > SETTLING_S:     # not the page's first build
            self.lagged_at = time.perf_counter()
        if keeps_up == self.lagging:
            self.lagging, self._stale = not keeps_up, True
            if keeps_up:
                self._send_screen(force=True)

    def close(self) -> None:
        self.closed = True
        for unsubscribe in self._unsubscribe:
            unsubscribe()
        for panel in [self.header, *self.panels]:
            getattr(panel, "detach", lambda: None)()
