"""One browser tab: its own state (click mode, selected mirror, drafts, picks, view), its 3D scene
and depth frame, its GUI (a status header over one tab per step of the work), and what it streams.

It is sent the live cloud only while it looks at the 3D scene, is not hidden and keeps up
(`mirrorscan.presence`), and the depth frame at most DEPTH_HZ times a second and at once after an
edit. A page reloaded takes up the work of its tab before (Resume); the page tells which it is
(identify).

Its actions run one at a time, each on the session as the tab last drew it (`drawn`): an edit
that another tab has made stale is refused and the tab redrawn (`mirrorscan.guards.made_on`).
"""
from __future__ import annotations

import threading
import time
from typing import Callable

import numpy as np
import viser

from mirrorcore.base.palette import source_colour

from .context import MODES, Question, Services, TabState
from .depthscreen import DepthScreen
from .events import DenseChanged, FrameReady, HeatChanged, SessionChanged
from .framing import TabFraming
from .guards import StaleEdit, made_on
from .liveframe import LiveFrame
from .markup import markdown
from .overlays import MarkerMark, MirrorMarks, Overlay
from .page import frame_late
from .panels import PANELS
from .panels.live import LivePanel
from .presence import MAX_LAG_S, PAGE_KEY, SETTLING_S, Resume, TabPresence
from .stream import HALVES
from .tabheat import TabHeat
from .view import TabScene
from .wording.mirrors import outline_taken_note

__all__ = ["DEPTH_HZ", "DEPTH_HZ_BEHIND", "MAX_LAG_S", "PAGE_KEY", "SETTLING_S", "Resume", "Tab"]

DEPTH_HZ = 8.0          # the depth frame is re-sent at most this often while it is in view
DEPTH_HZ_BEHIND = 1.0   # the same while the tab looks at the 3D scene
HEAT_HZ = 1.0           # heat maps a second while the heat map is on


class Tab(TabPresence, TabFraming, TabHeat):
    """Everything of one connected browser tab (see the module docstring).

    Parameters
    ----------
    client : viser.ClientHandle
        The tab's connection.
    services : Services
        What the app shares with every tab.
    """

    def __init__(self, client: viser.ClientHandle, services: Services):
        self.client, self.services = client, services
        self.state = TabState()
        # the session as the tab last drew it: what its actions are made on
        self.drawn = services.editor.session
        self._init_presence()
        self.closed = False
        self._lock = threading.RLock()
        # the tab's actions, one at a time: each is made on what the one before left drawn
        self._acting = threading.RLock()
        self._state_listeners: list[Callable[[TabState], None]] = []
        self._click_handlers: dict[str, Callable[[float, float], None]] = {}
        self._last_screen = 0.0
        # the cloud shown is not the last frame's: send both halves next
        self._stale = True
        self.dense_visible, self.dense_beside = True, True
        self.heat, self._last_heat = False, 0.0
        # the cloud in its points' colours (else its sources'), when the heat map is off
        self.true_colour = True
        # the last heat map's figures per mirror view (HeatChanged), over heat_frames heat maps
        self.heat_figures: dict[int, tuple[float, float]] = {}
        self.heat_frames = 0
        # the mirror (id) whose points alone the heat map colours (None: every mirror's)
        self.heat_of: int | None = None
        self._heat_event: HeatChanged | None = None      # the heat map drawn
        # the heat worker's map is drawn, or the switch-off removes it: never both
        self._heat_lock = threading.Lock()
        self._framed = False
        # (position, look-at) metres, where look_home last put the camera
        self._home_pose: tuple[np.ndarray, np.ndarray] | None = None
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
        bus = services.bus
        self._unsubscribe = [bus.subscribe(FrameReady, self._on_frame),
                             bus.subscribe(SessionChanged, lambda e: self._on_session()),
                             bus.subscribe(DenseChanged, lambda e: self.show_dense(e.result)),
                             bus.subscribe(HeatChanged, self._on_heat)]
        self._on_session()
        self.show_dense(services.jobs.dense_result)
        client.camera.on_update(self._first_view)
        frame_late(client, self._first_view)
        self._watch_visibility()
        self._watch_acknowledgements()

    def _first_view(self, _) -> None:
        """Once the tab has reported its canvas, frame what it looks at.

        The rig and the cloud, the object under a heat map (a reload), or the depth frame when the
        tab was switched to it before the report.
        """
        if not self._framed and not self.closed:
            self._framed = True
            if self.state.view == "depth":
                self.screen.look_at()
            elif self.heat:
                self.look_at_object()
            else:
                self.look_home()

    # ------------------------------------------------------------------ the TabContext protocol
    @property
    def gui(self):
        """The tab's GUI (the client's)."""
        return self.client.gui

    def changed(self) -> None:
        """The tab's state changed: redraw the overlay, re-send the depth frame, tell the panels."""
        self._redraw_overlay()
        self._send_screen(force=True)
        for listener in list(self._state_listeners):
            listener(self.state)

    def on_state(self, callback: Callable[[TabState], None]) -> None:
        """Call callback(state) after every change of the tab's state.

        Parameters
        ----------
        callback : callable
            Called with the TabState.
        """
        self._state_listeners.append(callback)

    def on_click(self, mode: str, handler: Callable[[float, float], None]) -> None:
        """Route clicks on the depth frame in `mode` to handler(u, v).

        Parameters
        ----------
        mode : str
            One of MODES.
        handler : callable
            Called with the clicked pixel's column and row.
        """
        assert mode in MODES, mode
        self._click_handlers[mode] = handler

    def act(self, action: Callable[[], object], drawn=None) -> None:
        """Run a user's action of this tab; a refusal becomes a notification on this tab.

        Actions run one at a time, their edits made on the session as this tab drew it: an edit
        that another tab made stale is refused (StaleEdit) and the tab redrawn.

        Parameters
        ----------
        action : callable
            The action, called with no arguments.
        drawn : Session, optional
            The session the action was made on (a click taken in as it came, a question's
            answer); by default, the one the tab drew last.
        """
        def run() -> None:
            try:
                with made_on(self.drawn if drawn is None else drawn):
                    action()
            except StaleEdit:
                self._on_session()
                raise
        with self._acting:
            self.services.act(self.client, run)

    def ask(self, title: str, text: str, yes: str, on_yes: Callable[[], object], no: str,
            on_no: Callable[[], object] = lambda: None) -> Question:
        """Ask before an action that loses something: a modal with two buttons; either closes it.

        Parameters
        ----------
        title : str
            The modal's title.
        text : str
            The question (markdown, any HTML shown as text).
        yes : str
            The first button's label (red); it runs `on_yes` as a user's action (act).
        on_yes : callable
        no : str
            The second button's label; it runs `on_no` as a user's action.
        on_no : callable, optional

        Returns
        -------
        Question
        """
        gui = self.client.gui
        modal = gui.add_modal(title)
        with modal:
            gui.add_markdown(markdown(text))
            yes_button = gui.add_button(yes, color="red")
            no_button = gui.add_button(no)

        # answered on the session it was asked on
        drawn = self.drawn

        def answer(action: Callable[[], object]) -> None:
            modal.close()
            self.act(action, drawn)
        question = Question(modal, lambda: answer(on_yes), lambda: answer(on_no))
        yes_button.on_click(lambda _: question.yes())
        no_button.on_click(lambda _: question.no())
        return question

    def look(self, view: str) -> None:
        """Show the 3D scene or the depth frame.

        Clouds and labels are hidden, and not sent, while the depth frame is in view; the depth
        frame fills the free area. Back in the 3D scene with the heat map on, the view frames the
        object, whose rims carry its colours.

        Parameters
        ----------
        view : str
            '3d' or 'depth'.
        """
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
        elif self.heat:
            self.look_at_object()
            self._heat_now()
        else:
            self.look_home()
        for listener in list(self._state_listeners):
            listener(self.state)

    @property
    def shows_cloud(self) -> bool:
        """Whether this tab is sent the live cloud: it looks at the 3D scene and is not hidden."""
        return self.state.view == "3d" and not self.hidden

    def show_dense(self, result) -> None:
        """Show the shared dense result in this tab's scene as the tab's Dense step says.

        Shown or not, and beside the cloud or not; never while the depth frame is in view.

        Parameters
        ----------
        result : DenseResult or None
        """
        self.scene.show_dense(result, self.dense_visible and self.state.view == "3d",
                              self.dense_beside)

    # ------------------------------------------------------------------ events
    def _on_frame(self, event: FrameReady) -> None:
        # a frame in flight while the tab went away
        """Send a frame: its cloud (or a heat map) when the tab shows it, and the depth frame."""
        if self.closed:
            return
        frame = event.frame
        if self.shows_cloud and not self.lagging:
            if self.heat:
                if (time.perf_counter() - self._last_heat >= 1 / HEAT_HZ
                        and self.services.jobs.heat_wanted(frame)):
                    self._last_heat = time.perf_counter()
                    self.services.jobs.start_heat(frame)
            else:
                half = None if self.services.paused or self._stale else frame.index % HALVES
                self.scene.show_cloud(frame.parts(half, self.true_colour), frame.mirror_ids, half)
                self._stale = False
        self._send_screen(frame=frame)
        self.header.show(frame)

    def _on_session(self) -> None:
        """Bring the tab to the app's current session.

        Its latest snapshot is read under the tab's lock, so that of two changes handled at once
        (SessionChanged is published outside the session's lock) the later is drawn last, whatever
        order their events arrive in. A camera still at home is moved to frame the rig as it now
        is.
        """
        with self._lock:
            snapshot = self.services.snapshot
            before = {m.id: m.boundary for m in self.drawn.mirrors}
            self.drawn = self.services.editor.session
            ids = tuple(m.id for m in snapshot.session.mirrors)
            # dropped in place: a boundary click on a GUI thread may add to the drafts meanwhile
            for gone in [k for k in list(self.state.drafts) if k not in ids]:
                self.state.drafts.pop(gone, None)
            # a draft of a mirror whose outline was closed in another tab since: not over it
            taken = [m for m in self.drawn.mirrors
                     if m.boundary and m.boundary != before.get(m.id)
                     and self.state.drafts.pop(m.id, None) is not None]
            # a new tab starts at the first mirror
            if self.state.mirror_id not in ids:
                self.state.mirror_id = ids[0] if ids else None
                self.state.picked_marker = self.state.picked_corner = None
            # what the scene draws: mirrors, and virtual cameras up to `bounces`
            session = snapshot.session
            key = (session.bounces, *((m.id, m.name, m.plane, m.boundary) for m in session.mirrors))
            rig_changed = key != self._session_key
            if rig_changed:
                self._session_key = key
                self.scene.show_rig(snapshot.rig, ids)
                self.scene.recolour(ids)
        if rig_changed and self.state.view == "3d" and not self.heat and self._still_home():
            self.look_home()
        self.changed()
        self._unseen.set()
        for mirror in taken:
            self.services.notify(self.client, *outline_taken_note(mirror.name), kind="warning")

    def _clicked(self, u: float, v: float) -> None:
        """Route a click on the depth frame to the current mode's handler, as an action."""
        handler = self._click_handlers.get(self.state.mode)
        if handler is not None:
            self.act(lambda: handler(u, v))

    # ------------------------------------------------------------------ the depth frame
    def _redraw_overlay(self) -> None:
        """Draw this tab's overlay: every mirror's outline (or draft) and markers, the region."""
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
            colour = tuple(int(c) for c in source_colour(1, (mirror.id,)))
            outline = draft if draft is not None else mirror.boundary
            mirrors.append(MirrorMarks(colour, outline, draft is None, markers,
                                       state.picked_corner if selected else None, selected))
        roi = snapshot.session.selection.roi
        if state.region_draft:
            region = (state.region_draft, False)
        else:
            region = (roi, True) if roi else None
        with self._lock:
            self.overlay.draw(mirrors, region)

    def _send_screen(self, frame: LiveFrame | None = None, force: bool = False) -> None:
        """Compose the shared depth layer of the latest frame with this tab's overlay and send it.

        Sent when forced (an edit), or when DEPTH_HZ (DEPTH_HZ_BEHIND in the 3D view) allows and
        the tab keeps up; never to a hidden tab.
        """
        frame = frame or self.services.last_frame
        now = time.perf_counter()
        rate = DEPTH_HZ if self.state.view == "depth" else DEPTH_HZ_BEHIND
        waits = self.lagging or now - self._last_screen < 1 / rate
        if frame is None or self.hidden or (not force and waits):
            return
        self._last_screen = now
        with self._lock:
            rgb = self.overlay.over(frame.screen_rgb(self.state.colour_image))
        self.screen.show(rgb)

    def close(self) -> None:
        """Stop listening to the app's events and detach the panels; the tab is closed."""
        self.closed = True
        self._unseen.set()
        for unsubscribe in self._unsubscribe:
            unsubscribe()
        for panel in [self.header, *self.panels]:
            getattr(panel, "detach", lambda: None)()
