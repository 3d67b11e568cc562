"""The plan in the browser (`mirrorscan plan --serve`, docs/planning.md): the room, the camera,
the mirrors and the subject in 3D, the subject's samples coloured by how many views see them;
each mirror moves on the floor and turns about the vertical by viser's transform controls, and the
figures follow; *Optimise* searches from the layout, *Save plan* writes the plan folder, and
*Simulate* serves the layout as a live simulated rig beside it.

Everything is drawn in the plan's level frame (x right, y down, z forward, the camera at 0).
"""
from __future__ import annotations

import contextlib
import io
import logging
import threading
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import viser

from mirrorcore.base.errors import CalibrationError, MirrorscanError
from mirrorcore.io.session import Session
from mirrorcore.base.palette import source_colour
from mirrorcore.plan.planfile import SCENE_FILE
from mirrorcore.sim.export import session_mirrors
from mirrorcore.sources.sim import open_simulated

from .demo import calibrated_session
from .events import EventBus, JobProgress
from .jobs.plan import OPTIMISE, PlanJobs
from .results import Cancelled
from .notices import Notifier, place_notes
from .plandesk import PlanDesk
from .security import protect
from .server import AMBIENT_LIGHT, PANEL_WIDTH, MirrorscanApp
from .wording import plan as words

log = logging.getLogger("mirrorscan")
POINT_SIZE = 0.02          # metres, the subject's samples
HANDLE_SCALE = 0.5         # metres, the transform controls' size
FRUSTUM_SCALE = 0.3        # metres, the camera's frustum
# metres from the subject's middle to the page's first viewpoint (level frame, y down)
VIEW_FROM = np.array([1.2, -1.6, 2.4])


def _box_edges(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(12, 2, 3) edges of the box between corners lo and hi (3,)."""
    corners = np.array([[a, b, c] for a in (0, 1) for b in (0, 1) for c in (0, 1)], float)
    points = lo + corners * (hi - lo)
    pairs = [(i, j) for i in range(8) for j in range(i + 1, 8)
             if np.count_nonzero(corners[i] != corners[j]) == 1]
    return np.array([[points[i], points[j]] for i, j in pairs])


class PlanApp(Notifier):
    """The plan's viser server (see the module docstring).

    Parameters
    ----------
    desk : PlanDesk
    folder : str or Path
        Where *Save plan* writes the plan folder.
    host, port, token
        As for `mirrorscan serve`.
    """

    def __init__(self, desk: PlanDesk, folder: str | Path, host: str = "127.0.0.1",
                 port: int = 8080, token: str | None = None):
        self.desk, self.folder, self.host = desk, Path(folder), host
        with contextlib.redirect_stdout(io.StringIO()):
            self.server = viser.ViserServer(host=host, port=port, label="mirrorscan plan",
                                            verbose=False)
        try:
            self.guard = protect(self.server, host, token)
        except MirrorscanError:
            self.server.stop()
            raise
        self.server.gui.configure_theme(show_share_button=False, brand_color=(0, 114, 178))
        self.server.gui.main_panel.dock_right()
        self.server.gui.main_panel.set_width(PANEL_WIDTH)
        self.server.scene.set_up_direction("-y")
        self.server.scene.configure_environment_map(hdri=None)
        self.server.scene.add_light_ambient("/ambient", intensity=AMBIENT_LIGHT)
        self.bus = EventBus()
        self.jobs = PlanJobs(self.bus)
        self.bus.subscribe(JobProgress, self._ended)
        self.simulated: MirrorscanApp | None = None
        # the latest pose of each mirror dragged, not yet evaluated; and whether one is
        self._pending: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._evaluating = False
        self._pending_lock = threading.Lock()
        self.last_eval_s = 0.0
        self._draw_room()
        self._build_panel()
        self.handles = [self._add_mirror(j) for j in range(desk.result.space.mirrors)]
        self._show(desk.coverage, None)
        self.server.on_client_connect(self._connect)

    @property
    def port(self) -> int:
        """The port the server listens on."""
        return self.server.get_port()

    def stop(self) -> None:
        """Cancel the search, stop the simulated rig, then the server."""
        self.jobs.stop()
        if self.simulated is not None:
            self.simulated.stop()
        with contextlib.redirect_stdout(io.StringIO()):
            self.server.stop()

    def _connect(self, client: viser.ClientHandle) -> None:
        """Place the tab's notifications and look at the subject from above and behind it (the
        side the mirrors see), the camera beyond it."""
        place_notes(client)
        subject = self.desk.result.space.subject
        client.camera.position = tuple(subject.centre + VIEW_FROM)
        client.camera.look_at = tuple(subject.centre)
        client.camera.up_direction = (0.0, -1.0, 0.0)

    # ------------------------------------------------------------------ the 3D scene
    def _draw_room(self) -> None:
        """The room's outline, the camera's frustum and the subject's samples."""
        result = self.desk.result
        room, cam = result.space.room, result.camera.intrinsics
        lo = np.array([-room.width / 2, room.ceiling_y, 0.0])
        hi = np.array([room.width / 2, room.floor_y, room.depth])
        self.server.scene.add_line_segments("/plan/room", _box_edges(lo, hi), (120, 120, 120),
                                            thickness=1.5, thickness_units="screen")
        self.frustum = self.server.scene.add_camera_frustum(
            "/plan/camera", fov=2 * np.arctan(cam.height / 2 / cam.fy),
            aspect=cam.width / cam.height, scale=FRUSTUM_SCALE, color=(40, 40, 40),
            wxyz=_tilt_quaternion(result.tilt))
        self.subject = self.server.scene.add_point_cloud(
            "/plan/subject", self.desk.model.samples.points.astype(np.float32),
            words.COUNT_COLOURS[self.desk.counts()], point_size=POINT_SIZE,
            precision="float32")

    def _add_mirror(self, j: int) -> viser.TransformControlsHandle:
        """Mirror j: transform controls that move it on the floor and turn it about y, the glass
        as their child."""
        position, wxyz = self.desk.pose(j)
        handle = self.server.scene.add_transform_controls(
            f"/plan/mirror {j + 1}", scale=HANDLE_SCALE, active_axes=(True, False, True),
            depth_test=False, position=position, wxyz=wxyz)
        self._draw_glass(j)
        handle.on_update(lambda event, j=j: self._updated(j, event))
        return handle

    def _draw_glass(self, j: int) -> None:
        """Mirror j's pane in its colour, in its handle's frame, and its name."""
        result = self.desk.result
        glass = result.glass
        position, wxyz = self.desk.pose(j)
        turn = _yaw_matrix(wxyz)
        local = (glass.corners()[j] - position) @ turn
        name = f"/plan/mirror {j + 1}/glass"
        self.server.scene.add_mesh_simple(
            name, local.astype(np.float32), np.array([[0, 1, 2], [0, 2, 3]]),
            color=tuple(int(c) for c in source_colour(j + 1)), side="double", opacity=0.8)
        self.server.scene.add_label(f"/plan/mirror {j + 1}/name", f"mirror {j + 1}",
                                    position=(0.0, -glass.half[j, 1] - 0.1, 0.0))

    def _redraw(self) -> None:
        """Every mirror and the camera as the desk now has them (after a search)."""
        tilt = self.desk.result.tilt
        self.frustum.wxyz = _tilt_quaternion(tilt)
        for j, handle in enumerate(self.handles):
            handle.position, handle.wxyz = self.desk.pose(j)
            self._draw_glass(j)

    # ------------------------------------------------------------------ dragging
    def _updated(self, j: int, event) -> None:
        """A handle moved (evaluate it) or was let go (put it where the desk has it)."""
        self._moved(j, event.target)
        if event.phase == "end":
            self._put_back(j)

    def _moved(self, j: int, handle) -> None:
        """A mirror's handle moved: evaluate its latest pose (one evaluation at a time, the
        poses that came meanwhile dropped but the last)."""
        with self._pending_lock:
            self._pending[j] = (np.array(handle.position), np.array(handle.wxyz))
            if self._evaluating:
                return
            self._evaluating = True
        while True:
            with self._pending_lock:
                if not self._pending:
                    self._evaluating = False
                    return
                k, (position, wxyz) = self._pending.popitem()
            # a bug in one evaluation is told and must not stop the next ones
            self.act(None, lambda: self.move(k, position, wxyz))

    def move(self, j: int, position, wxyz) -> bool:
        """Put mirror j at `position`, turned to `wxyz`, and show the figures; or show why the
        limits refuse it. Returns whether it moved."""
        if self.jobs.running(OPTIMISE):
            self.note.content = words.refused(words.SEARCHING).markdown()
            return False
        began = time.perf_counter()
        try:
            cov = self.desk.move(j, position, wxyz)
        except MirrorscanError as exc:
            self.note.content = words.refused(str(exc)).markdown()
            return False
        self.last_eval_s = time.perf_counter() - began
        self._show(cov, self.last_eval_s)
        self.note.content = ""
        return True

    def _put_back(self, j: int) -> None:
        """At the end of a drag, the handle goes where the desk has the mirror (back, when the
        last pose was refused)."""
        with self._pending_lock:
            waiting = bool(self._pending) or self._evaluating
        if not waiting:
            self.handles[j].position, self.handles[j].wxyz = self.desk.pose(j)

    def _show(self, cov, seconds: float | None) -> None:
        """The figures and the subject's colours of a coverage."""
        self.figures.content = words.figures(cov, seconds).markdown()
        self.subject.colors = words.COUNT_COLOURS[self.desk.counts()]

    # ------------------------------------------------------------------ the panel
    def _build_panel(self) -> None:
        """The side panel: the title, the key, the figures, the buttons and their lines."""
        gui = self.server.gui
        gui.add_markdown(f"**{words.TITLE}**\n\n{words.HELP}")
        gui.add_html(words.legend_html())
        self.figures = gui.add_markdown("")
        self.note = gui.add_markdown("")
        self.optimise_button = gui.add_button("Optimise", icon=viser.Icon.WAND)
        self.cancel_button = gui.add_button("Cancel", visible=False, color="red")
        self.bar = gui.add_progress_bar(0.0, visible=False)
        self.save_button = gui.add_button("Save plan", icon=viser.Icon.DEVICE_FLOPPY)
        self.simulate_button = gui.add_button("Simulate", icon=viser.Icon.PLAYER_PLAY)
        self.saved = gui.add_markdown("")
        self.simulation = gui.add_markdown("")
        self.optimise_button.on_click(lambda e: self.act(e.client, self.optimise))
        self.cancel_button.on_click(lambda e: self.jobs.cancel(OPTIMISE))
        self.save_button.on_click(lambda e: self.act(e.client, self.save))
        self.simulate_button.on_click(
            lambda e: self.act(e.client, lambda: self.jobs.simulate(self._simulate)))

    def optimise(self) -> threading.Thread:
        """Start the search from the layout as it stands."""
        def done(before: float, seconds: float) -> None:
            self._redraw()
            cov = self.desk.coverage
            self._show(cov, None)
            self.note.content = words.optimised(before, cov.coverage, seconds).markdown()
            self._busy(False)

        # busy first: a search cancelled at once must find the buttons to put back
        self._busy(True)
        try:
            return self.jobs.optimise(self.desk,
                                      lambda f: setattr(self.bar, "value", 100 * f), done)
        except MirrorscanError:
            self._busy(False)
            raise

    def _busy(self, running: bool) -> None:
        """The buttons while the search runs, or once it is over."""
        self.bar.value = 0.0
        self.bar.visible = self.cancel_button.visible = running
        self.optimise_button.disabled = running

    def _ended(self, event: JobProgress) -> None:
        """A job ended without its result (cancelled, refused, failed): say so."""
        if event.job == OPTIMISE:
            self._busy(False)
        cancelled = isinstance(event.result, Cancelled)
        self.note.content = words.CANCELLED if cancelled else event.status

    def save(self) -> list[Path]:
        """Write the plan folder of the layout as it stands."""
        files = self.desk.save(self.folder)
        message = words.saved(self.folder, files)
        self.saved.content = message.markdown()
        self.notify(None, "Plan saved", message.plain, "info")
        return files

    def _simulate(self) -> None:
        """Save the plan, then serve its scene.json as a live simulated rig on a port of its
        own, calibrated from its markers (the demo's way), or with the simulator's true planes
        when the markers do not give them; the panel links to it."""
        self.save()
        if self.simulated is not None:
            self.simulated.stop()
            self.simulated = None
        source = open_simulated(str(self.folder / SCENE_FILE), None)
        root = self.folder / "session"
        try:
            session, why = calibrated_session(source, root), None
        except CalibrationError as exc:
            rig = source.rig
            mirrors = tuple(replace(m, plane=true.plane) for m, true in
                            zip(session_mirrors(rig, rig.background().truth), rig.scene.mirrors))
            session, why = Session(root, rig.intrinsics, mirrors), str(exc)
        app = MirrorscanApp(session, source, self.host, 0, autosave=False,
                            sessions_dir=self.folder)
        app.start()
        self.simulated = app
        self.simulation.content = words.simulating(app.guard.url, why).markdown()


def _yaw_matrix(wxyz) -> np.ndarray:
    """(3, 3) rotation of a turn about y given as wxyz."""
    w, _, y, _ = wxyz
    c, s = w * w - y * y, 2 * w * y
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _tilt_quaternion(tilt_deg: float) -> np.ndarray:
    """(4,) wxyz from the tilted camera's frame to the level frame (tilt_rotation's inverse)."""
    half = -np.radians(tilt_deg) / 2
    return np.array([np.cos(half), np.sin(half), 0.0, 0.0])

