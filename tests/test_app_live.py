"""The browser tool without a browser, on the demo: the live loop turns frames into a cloud with
every source; a tab gets it as float16 offsets within 0.3 mm, one node per source, and the depth
frame; a tab looking at the depth frame, or hidden, is not sent the cloud, and the loop slows down;
pause and step; the depth screen's pixel mapping and framing; a snapshot keeps the rig's tables
while the geometry stays."""

import itertools
import sys
import threading
import time
import warnings
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import viser
import websockets.sync.client

from mirrorscan.context import TabState
from mirrorscan.demo import calibrated_session, demo_source
from mirrorscan.events import EventBus, HeatChanged, JobProgress
from mirrorscan.editor import SESSION_SCOPE
from mirrorscan.jobs import HEAT_POOL, Jobs, planes_key
from mirrorscan.results import (
    AgreementReport,
    BackgroundCaptured,
    CalibrationReport,
    Fit,
    FitsApplied,
    FramesUsed,
    MirrorAgreement,
    NotFound,
)
from mirrorscan.wording import HEADLINE_WORDS, Message, joined, words
from mirrorscan.wording import refinement as calibration_words
from mirrorscan.wording.refinement import agreement_line, frames_used
from tests.test_app_panels import refined
from mirrorscan.live import RECENT_FRAMES, RateMeter
from mirrorscan.markup import markdown
from mirrorscan.panels.live import (
    LAG_NOTE_S,
    _from_markers,
    _no_glass,
    heat_legend_html,
    legend_html,
    source_title,
)
from mirrorscan.wording.hints import start_hint
from mirrorscan.panels.measure import fit_report
from mirrorscan.panels.mirrors import MirrorsPanel
from mirrorscan.wording.mirrors import fit_report as markers_report
from mirrorscan.wording.mirrors import (
    NO_GLASS_NOTE,
    fit_note,
    greyed_out,
    removal_question,
    report_markdown,
)
import mirrorscan.server as server_module
from mirrorscan.server import BUSY_FPS, IDLE_FPS, MirrorscanApp, quiet_closed_connections
from mirrorscan.state import Snapshot
from mirrorscan.stream import FLOAT16_EXTENT, Anchors, stream_parts
from mirrorscan.tab import MAX_LAG_S, SETTLING_S, Tab
from mirrorscan.view import home_pose, label_anchor, same_place, scene_points
from mirrorscan.bench.tabs import CAMERA_MESSAGE
from tests.waiting import wait_for
from mirrorcore.rig.cloud import Cloud
from mirrorcore.base.errors import CalibrationError, Cancelled, MirrorscanError
from mirrorcore.geometry.fitting import fit_cylinder, fit_sphere
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.calibration.residuals import ViewAgreement
from mirrorcore.io.session import Session, SessionMirror, load_session
from mirrorcore.sources import StackSource


def test_demo_planes_are_calibrated_close_to_the_truth(demo):
    app, _ = demo
    truth = app.loop.source.rig.planes
    for mirror, true in zip(app.snapshot.session.mirrors, truth):
        assert mirror.plane.angle_to(true) < 1.0
        assert abs(mirror.plane.d - true.d) < 0.01


def test_a_new_tab_starts_at_the_first_mirror(demo):
    app, headless = demo
    first = app.snapshot.session.mirrors[0]
    assert headless.tab.state.mirror_id == first.id
    assert (
        next(p for p in headless.tab.panels if isinstance(p, MirrorsPanel)).mirror.value
        == first.name
    )


def test_a_reloaded_page_takes_up_the_work_of_the_page_before(demo, monkeypatch):
    """A reload lost the corners of a boundary being drawn, the mirror, the mode, the view and the
    heat map: the page says which it is (the same through its reloads), and a reload
    within RESUME_S takes up the work of its tab before; another page, or a reload later, starts
    afresh."""
    from mirrorscan.bench.tabs import HeadlessTab

    app, _ = demo
    second = app.snapshot.session.mirrors[1].id
    with HeadlessTab(app, page="bench") as before:
        tab = wait_for(lambda: before.tab.page == "bench" and before.tab, 10, "the page's name")
        tab.state.mirror_id, tab.state.mode = second, "boundary"
        tab.state.drafts[second] = ((10.0, 20.0), (30.0, 20.0))
        # a pick is that page's: not taken up
        tab.state.picked_corner = 1
        tab.look("depth")
        tab.show_heat(True)
    # another page meanwhile: its own start
    with HeadlessTab(app) as other:
        wait_for(lambda: other.tab.page, 10, "its name")
        assert other.tab.state.view == "3d" and not other.tab.state.drafts
    with HeadlessTab(app, page="bench") as after:  # the page reloaded
        state = wait_for(
            lambda: after.tab.heat and after.tab.state.drafts and after.tab.state,
            10,
            "the work taken up (the state first, the heat map last)",
        )
        assert (state.mirror_id, state.mode, state.view) == (second, "boundary", "depth")
        assert (
            state.drafts == {second: ((10.0, 20.0), (30.0, 20.0))} and state.picked_corner is None
        )
        assert after.tab.heat and after.tab.header.heat.value
        mirrors = next(p for p in after.tab.panels if isinstance(p, MirrorsPanel))
        assert mirrors.mirror.value == app.snapshot.session.mirrors[1].name
        after.tab.show_heat(False)
    monkeypatch.setattr(server_module, "RESUME_S", 0.0)
    # reloaded after RESUME_S: a new start
    with HeadlessTab(app, page="bench") as later:
        wait_for(lambda: later.tab.page, 10, "its name")
        time.sleep(0.2)  # late state, if any, arrives meanwhile
        assert later.tab.state.view == "3d" and not later.tab.state.drafts and not later.tab.heat


def test_float16_offsets_keep_every_point_within_a_third_of_a_millimetre():
    rng = np.random.default_rng(0)
    points = (rng.uniform(-0.95, 0.95, (20_000, 3)) + [0.3, -0.2, 3.0]).astype(np.float32)
    sources = rng.integers(0, 3, len(points)).astype(np.uint8)
    parts = stream_parts(Cloud(points, sources, np.arange(len(points)), 640), range(3))
    assert [p.key for p in parts] == [(0, 0), (0, 1), (1, 0), (1, 1), (2, 0), (2, 1)]
    second = stream_parts(
        Cloud(points, sources, np.arange(len(points)), 640), range(3), halves=(1,)
    )
    # a live frame's half alone
    assert [p.key for p in second] == [(0, 1), (1, 1), (2, 1)]
    for part, whole in zip(second, parts[1::2]):
        np.testing.assert_array_equal(part.offsets, whole.offsets)
        np.testing.assert_array_equal(part.centre, whole.centre)
    for part in parts:
        assert part.offsets.dtype == np.float16 and part.offsets.flags.c_contiguous
        mine = points[sources == part.source][part.half :: 2]
        np.testing.assert_array_equal(
            part.offsets, (mine - part.centre.astype(np.float32)).astype(np.float16)
        )
        back = part.offsets.astype(np.float64) + part.centre
        np.testing.assert_array_less(np.abs(back - mine), 0.3e-3)
    wide = (
        points * [1, 1, 1] + np.where(np.arange(len(points)) % 2, 0, 2.5 * FLOAT16_EXTENT)[:, None]
    )
    parts = stream_parts(
        Cloud(wide.astype(np.float32), sources, np.arange(len(points)), 640), range(4)
    )
    # too wide for float16: float32
    assert {p.offsets.dtype for p in parts[:6]} == {np.dtype(np.float32)}
    # an absent source is cleared
    assert len(parts[6].offsets) == len(parts[7].offsets) == 0


def test_a_source_keeps_its_centre_while_its_points_stay_within_reach():
    """The walking person moves: the node keeps its centre (no pose update) until a point would
    leave float16's reach of it, and every point stays within 0.3 mm meanwhile."""
    rng = np.random.default_rng(1)
    body = rng.uniform(-0.3, 0.3, (4_000, 3)).astype(np.float32) + np.float32([0, 0, 3])
    sources = np.zeros(len(body), np.uint8)
    anchors, centres = Anchors(), []
    # 1.2 m to the side, 0.1 m a frame
    for step in np.arange(0, 1.2, 0.1, dtype=np.float32):
        points = body + np.float32([step, 0, 0])
        part = stream_parts(
            Cloud(points, sources, np.arange(len(points)), 640), [0], halves=(0,), anchors=anchors
        )[0]
        assert part.offsets.dtype == np.float16
        np.testing.assert_array_less(
            np.abs(part.offsets.astype(np.float64) + part.centre - points[0::2]), 0.3e-3
        )
        centres.append(part.centre[0])
    # the frames whose centre is new
    moved = np.flatnonzero(np.diff(centres)) + 1
    # the middle of the first frame's box, kept
    assert centres[0] == pytest.approx(0, abs=0.01)
    # until its far side (0.3 m + step) reaches 1 m
    assert len(moved) == 1 and moved[0] in (7, 8), centres
    # then the middle of the box again
    assert centres[moved[0]] == pytest.approx(0.1 * moved[0], abs=0.01)


def test_live_frames_reach_the_tab_every_point_within_a_third_of_a_millimetre(demo):
    """Two frames in a row: each refreshes one half of every source, so the tab shows every point of
    the two."""
    app, headless = demo
    tab = headless.tab
    frames = [app.loop.run_once(), app.loop.run_once()]
    counts = frames[1].cloud.counts(2)
    assert min(counts.values()) > 1000, counts
    nodes = tab.scene._clouds
    assert sorted(nodes) == [(j, h) for j in range(3) for h in range(2)]
    # each node holds its own source's half of its frame
    for (j, half), handle in nodes.items():
        frame = next(f for f in frames if f.index % 2 == half)
        assert handle.precision == "float16"
        got = handle.points.astype(np.float64) + handle.position
        expected = frame.cloud.points[frame.cloud.sources == j][half::2]
        np.testing.assert_array_less(np.abs(got - expected), 0.3e-3)
    shown = sum(len(h.points) for h in nodes.values())
    assert abs(shown - len(frames[1].cloud)) < 0.02 * len(frames[1].cloud)  # every point shown
    assert "mirror 2" in tab.header.legend.content
    tab._send_screen(force=True)
    assert tab.screen.handle.image.shape == (480, 640, 3)


def test_a_tab_looking_at_the_depth_frame_or_hidden_gets_no_cloud(demo, monkeypatch):
    app, headless = demo
    tab = headless.tab
    sent = []
    show_cloud = tab.scene.show_cloud
    monkeypatch.setattr(
        tab.scene, "show_cloud", lambda *args: (sent.append(len(args[0])), show_cloud(*args))
    )

    def bytes_per_frame(n: int = 6) -> float:
        app.loop.run_once()
        time.sleep(0.3)  # the frame reaches the tab
        start, calls = headless.bytes, len(sent)
        for _ in range(n):
            app.loop.run_once()
        time.sleep(0.5)  # let the messages reach the tab
        return (headless.bytes - start) / n, len(sent) - calls

    in_3d, clouds_3d = bytes_per_frame()
    # the depth frame does not stand in the 3D scene
    assert not tab.screen.handle.visible
    tab.look("depth")
    assert tab.screen.handle.visible
    _, clouds_depth = bytes_per_frame()
    tab.look("3d")
    assert not tab.screen.handle.visible
    tab.hidden = True
    hidden, clouds_hidden = bytes_per_frame()
    tab.hidden = False
    # half of ~41k points as float16 offsets: ~125 kB
    assert in_3d > 80_000 and clouds_3d == 6
    assert clouds_depth == clouds_hidden == 0 and hidden < 2_000, (in_3d, hidden)


def test_a_tab_that_lags_gets_no_frames_until_it_keeps_up(demo, monkeypatch):
    """A browser that draws more slowly than frames come (its answer to the visibility poll comes
    late: messages wait in it to be drawn) is sent no cloud and no depth frame, so it never shows
    frames minutes late; its header says so; once it answers in time it gets the current frame
    whole."""
    app, headless = demo
    tab = headless.tab
    sent = []
    show_cloud = tab.scene.show_cloud
    monkeypatch.setattr(
        tab.scene, "show_cloud", lambda *args: (sent.append(args[2]), show_cloud(*args))
    )
    # the header refreshed with every frame
    monkeypatch.setattr("mirrorscan.panels.live.STATS_HZ", 1000.0)
    headless.answer_delay = 1.2 * MAX_LAG_S
    # a page being built lags unsaid
    monkeypatch.setattr(tab, "_opened", time.perf_counter())
    try:
        tab.poll_visibility()
        assert tab.lagging and tab.lagged_at == -np.inf
        monkeypatch.setattr(tab, "_opened", tab._opened - SETTLING_S)  # built long ago
        tab.poll_visibility()
        assert tab.lagging
        start, screens = len(sent), tab._last_screen
        for _ in range(4):
            app.loop.run_once()
        assert len(sent) == start and tab._last_screen == screens
        assert "draws slower than frames come" in tab.header.rate.content
        headless.answer_delay = 0.0
        time.sleep(0.5)  # the late answer arrives
        tab.poll_visibility()
        assert not tab.lagging and tab._last_screen > screens  # the depth frame at once
        app.loop.run_once()
        # both halves: the whole frame
        assert sent[start:] == [None]
        app.loop.run_once()
        # said for LAG_NOTE_S more
        assert sent[start + 1] in (0, 1) and "slower" in tab.header.rate.content
        monkeypatch.setattr(tab, "lagged_at", tab.lagged_at - LAG_NOTE_S)
        app.loop.run_once()
        assert "slower" not in tab.header.rate.content
    finally:
        headless.answer_delay = 0.0
        tab.poll_visibility()


def storm(redraw, restyle, rounds: int = 150) -> list[Exception]:
    """Call redraw() over and over on a thread while restyle(k) runs `rounds` times here, threads
    switching as often as possible; the errors either raised."""
    errors, done = [], threading.Event()

    def redraw_until_done() -> None:
        try:
            while not done.is_set():
                redraw()
        except Exception as error:  # noqa: BLE001 - reported to the test
            errors.append(error)

    thread = threading.Thread(target=redraw_until_done)
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    thread.start()
    try:
        for k in range(rounds):
            restyle(k)
    except Exception as error:  # noqa: BLE001 - reported to the test
        errors.append(error)
    finally:
        done.set()
        thread.join()
        sys.setswitchinterval(interval)
    return errors


def test_restyling_the_cloud_while_frames_stream_is_safe(demo):
    """The stream thread adds and replaces cloud nodes while a GUI callback (a mirror renamed, the
    point size, a tab connecting) restyles them: neither may fail with 'dictionary changed size
    during iteration'."""
    app, headless = demo
    scene = headless.tab.scene
    frame = app.loop.run_once()

    def stream() -> None:
        scene.show_cloud([], frame.mirror_ids)  # every node removed...
        scene.show_cloud(frame.parts(), frame.mirror_ids)  # ... and added again

    def restyle(k: int) -> None:
        scene.recolour((1, 2))
        scene.set_point_size(0.004 + 0.001 * (k % 2))
        scene.show_clouds(True)

    errors = storm(stream, restyle)
    assert not errors, errors
    # the nodes are there after the storm
    assert scene._clouds


def test_hiding_labels_while_the_box_and_mirrors_are_redrawn_is_safe(demo):
    """The frames' thread redraws the dense box (it follows the cloud) and the session's redraws the
    mirrors while a GUI callback (the depth view, the virtual cameras' checkbox) shows or hides
    their labels and frusta: no write may reach a node just removed ('Cannot assign to visible on a
    removed LabelHandle', seen in CI)."""
    app, headless = demo
    scene, snapshot = headless.tab.scene, app.snapshot
    ids = tuple(m.id for m in snapshot.session.mirrors)

    def redraw() -> None:
        scene.show_box(np.array([-0.2, -0.2, 1.8]), np.array([0.2, 0.2, 2.2]))
        scene.show_rig(snapshot.rig, ids)

    def restyle(k: int) -> None:
        scene.show_labels(k % 2 == 0)
        scene.show_virtual_cameras(k % 2 == 0)

    errors = storm(redraw, restyle, rounds=300)
    assert not errors, errors
    # drawn by its 12 edges (a
    np.testing.assert_allclose(scene._box.position, (0.0, 0.0, 2.0), atol=1e-9)
    # wireframe box drew its faces' diagonals too,
    edges = np.asarray(scene._box.points)
    along = np.abs(edges[:, 1] - edges[:, 0])
    assert edges.shape == (12, 2, 3) and np.all(np.count_nonzero(along > 1e-6, axis=1) == 1)
    np.testing.assert_allclose(np.sort(along.max(axis=1)), [0.4] * 12, atol=1e-6)
    assert (
        scene._box_label is not None and scene._labels and scene._virtual and scene._virtual_labels
    )
    scene.show_virtual_cameras(True)
    scene.show_labels(False)
    assert not any(handle.visible for handle in scene._virtual_labels + scene._virtual)
    scene.show_labels(True)
    assert all(handle.visible for handle in scene._virtual_labels + scene._virtual)
    # a camera's name goes with its frustum
    scene.show_virtual_cameras(False)
    assert not any(label.visible for label in scene._virtual_labels + scene._virtual)


def test_two_threads_redrawing_the_rig_at_once_is_safe(demo):
    """Two SessionChanged events published at once (a tab's edit, the frames' grading thread, a tab
    being built) each redraw the rig: viser's add_* writes a new node's pose after registering it,
    so a second add of the same name in between (the depth camera's frustum) made the first fail
    ('Cannot assign to wxyz on a removed CameraFrustumHandle'), and the tab skipped the rest of the
    change."""
    app, headless = demo
    scene, snapshot = headless.tab.scene, app.snapshot
    ids = tuple(m.id for m in snapshot.session.mirrors)
    errors = storm(
        lambda: scene.show_rig(snapshot.rig, ids),
        lambda k: scene.show_rig(snapshot.rig, ids),
        rounds=100,
    )
    assert not errors, errors


def test_switching_the_heat_map_off_while_one_is_drawn_leaves_none(demo):
    """The heat worker's event draws a frame's map while the checkbox switches it off: once it is
    off, no map may be left in the scene (a map whose 'on' check passed before the switch-off was
    drawn after the removal)."""
    app, headless = demo
    tab = headless.tab
    frame = app.loop.run_once()
    points = np.ascontiguousarray(frame.cloud.points, dtype=np.float32)
    event = HeatChanged(frame.index, points, np.full((len(points), 3), 200, np.uint8), {})
    left = 0
    try:
        for _ in range(40):
            errors = storm(
                lambda: tab._on_heat(event), lambda k: tab.show_heat(k % 2 == 1), rounds=5
            )
            assert not errors, errors
            # the 5th round switched it off
            left += "/heat" in tab.client.scene._handle_from_node_name
    finally:
        tab.show_heat(False)
    assert left == 0, f"a heat map left after {left} of 40 switch-offs"


def test_a_tab_gone_while_it_was_built_is_not_kept(demo, monkeypatch):
    """viser calls the connect and the disconnect callbacks on its thread pool, side by side: a tab
    closed (a page reloaded) while its Tab was still being built must not stay in app.tabs,
    streaming to nobody for ever."""
    app, headless = demo
    building, go_on, built = threading.Event(), threading.Event(), []

    def slow_tab(client, services):
        building.set()
        go_on.wait(10)
        built.append(Tab(client, services))
        return built[-1]

    monkeypatch.setattr("mirrorscan.server.Tab", slow_tab)
    ws = websockets.sync.client.connect(
        f"ws://127.0.0.1:{app.port}", subprotocols=[f"viser-v{viser.__version__}"]
    )
    ws.send(CAMERA_MESSAGE)
    assert building.wait(10)
    ws.close()
    wait_for(lambda: len(app.server.get_clients()) == 1, 10, "viser to drop the client")
    time.sleep(0.2)  # its disconnect callback has run meanwhile
    go_on.set()
    wait_for(
        lambda: built and (built[0].closed or built[0].client.client_id in app.tabs),
        10,
        "the tab built",
    )
    time.sleep(0.1)  # a close still due comes meanwhile
    assert set(app.tabs) == {headless.tab.client.client_id} and built[0].closed


def test_what_viser_drops_for_a_closed_tab_is_not_shown_as_a_warning():
    """A tab closing while it is updated or built made viser warn in the technician's terminal; only
    that warning is silenced, not viser's others. viser names the caller's line as the warning's
    place (as `app/tab.py:306: UserWarning: Queued a LocalStorageGetItemRequestMessage ...`), so
    it goes whatever module it is attributed to."""
    text = ("Queued a GuiUpdateMessage on a closed connection (e.g. via a handle owned by a "
            "disconnected client)")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        quiet_closed_connections()
        warnings.warn_explicit(
            text, UserWarning, "buffer.py", 1, module="viser.infra._async_message_buffer"
        )
        warnings.warn_explicit(
            text.replace("Gui", "SceneNode"), UserWarning, "buffer.py", 1, module="viser"
        )
        warnings.warn_explicit(text, UserWarning, "tab.py", 1, module="mirrorscan.tab")
        warnings.warn_explicit("Something else", UserWarning, "buffer.py", 1, module="viser.infra")
    assert [(str(w.message), w.filename) for w in caught] == [("Something else", "buffer.py")]


def test_the_loop_gives_the_cores_to_a_calibration_from_the_object(demo):
    """Find the planes took 23 to 70 s on 2 cores with the recording playing at 30 fps, 12.6 s
    paused: while it runs (or a dense reconstruction, or a batch) the loop runs at
    BUSY_FPS, the header saying why."""
    app, headless = demo
    tab, loop = headless.tab, app.loop
    assert tab.shows_cloud and app.fps_wanted() is None
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(app.jobs, "running", lambda job: job == "refine")
        assert app.fps_wanted() == BUSY_FPS and loop.pace() == BUSY_FPS
        wait_for(
            lambda: (
                loop.run_once()
                and f"at most {BUSY_FPS:.0f} fps while the calibration from the object runs"
                in tab.header.rate.content
            ),
            5,
            "the header saying so",
        )
        # a recording keeps its rate
        patch.setattr(app.jobs, "running", lambda job: job in ("refine", "record"))
        assert app.fps_wanted() is None
    assert app.fps_wanted() is None and loop.pace() == 30.0


def test_the_recent_frames_are_distinct_frames(demo, monkeypatch):
    """A recording that loops gives the same frame again: on a one-frame session the agreement lines
    said "over 5 frames". The last RECENT_FRAMES
    frames are distinct ones."""
    app, _ = demo
    loop = app.loop
    # a one-frame recording, looping
    monkeypatch.setattr(loop.source, "frame_count", 1)
    # played from its start: no frame yet
    loop.use_source(loop.source)
    assert loop.recent_depths() is None
    frames = [loop.run_once().depth for _ in range(3)]
    assert len(loop.recent_depths()) == 1 and np.array_equal(loop.recent_depths()[0], frames[-1])
    # a live source: every frame is new
    monkeypatch.setattr(loop.source, "frame_count", None)
    frames = [loop.run_once().depth for _ in range(RECENT_FRAMES + 2)]
    np.testing.assert_array_equal(loop.recent_depths(), np.stack(frames[-RECENT_FRAMES:]))


def test_the_tabs_are_asked_less_often_while_nothing_plays(demo, monkeypatch):
    """Each question whether a tab is hidden or lags makes viser's page draw its 3D scene for 250 ms
    (Chromium's software WebGL took a core from Find the planes): the tabs are asked every
    VISIBILITY_POLL_S while the cloud plays, every QUIET_POLL_S while it is paused or a calibration
    from the object runs; session.json is looked at every FILE_POLL_S all the same."""
    app, headless = demo
    for name, seconds in (
        ("FILE_POLL_S", 0.01),
        ("VISIBILITY_POLL_S", 0.01),
        ("QUIET_POLL_S", 0.3),
    ):
        monkeypatch.setattr(server_module, name, seconds)
    asked, looked = [], []
    monkeypatch.setattr(headless.tab, "poll_visibility", lambda: asked.append(1))
    monkeypatch.setattr(app.editor, "reload_if_changed", lambda: looked.append(1) and "")

    def questions() -> tuple[int, int, float]:
        """(tabs asked, files looked at, how many QUIET_POLL_S the 0.6 s slept took)"""
        asked.clear(), looked.clear()
        started = time.perf_counter()
        time.sleep(0.6)  # the poller runs meanwhile: the point
        return len(asked), len(looked), (time.perf_counter() - started) / 0.3

    app._poller.start()
    playing = questions()
    app.pause(True)
    paused = questions()
    app.pause(False)
    monkeypatch.setattr(app.jobs, "running", lambda job: job == "refine")
    busy = questions()
    assert playing[0] >= 10 and all(1 <= n <= quiet + 1 for n, _, quiet in (paused, busy)), (
        playing,
        paused,
        busy,
    )
    assert min(playing[1], paused[1], busy[1]) >= 10, (playing, paused, busy)


def test_the_loop_speeds_up_as_soon_as_a_job_ends(demo, monkeypatch):
    """At BUSY_FPS (1) the loop does not wait out its second after the job ended: it looks at its
    pace every PACE_CHECK_S while it waits."""
    app, _ = demo
    busy = [True]
    monkeypatch.setattr(app.jobs, "running", lambda job: busy[0] and job == "refine")
    assert app.loop.pace() == BUSY_FPS == 1.0
    threading.Timer(0.2, lambda: busy.__setitem__(0, False)).start()  # the job ends 0.2 s in
    started = time.perf_counter()
    app.loop._rest(started)
    assert time.perf_counter() - started < 0.6


def test_the_loop_slows_down_while_no_tab_shows_the_cloud(demo, tmp_path, monkeypatch):
    """The source's 30 fps while a tab looks at the 3D scene, records, or collects frames; IDLE_FPS
    while every tab looks at the depth frame (sent 8 times a second) or is hidden, the header saying
    so."""
    app, headless = demo
    tab, loop = headless.tab, app.loop
    assert app.fps_wanted() is None and loop.pace() == app.source.fps == 30.0
    tab.look("depth")
    try:
        assert app.fps_wanted() == IDLE_FPS and loop.pace() == IDLE_FPS
        wait_for(
            lambda: loop.run_once() and f"at most {IDLE_FPS:.0f} fps" in tab.header.rate.content,
            5,
            # it refreshes its figures a few times a second
            "the header saying so",
        )
        # a background capture waits for frames
        loop._collectors.append(lambda frame: None)
        assert loop.pace() == 30.0
        loop._collectors.clear()
        app.jobs.start_recording(tmp_path)
        assert app.fps_wanted() is None
        app.jobs.stop_recording(app.editor.session)
        tab.look("3d")
        tab.hidden = True
        assert app.fps_wanted() == IDLE_FPS
        # a source no faster: nothing to say
        monkeypatch.setattr(app.loop.source, "fps", IDLE_FPS)
        assert app.fps_wanted() is None
    finally:
        tab.hidden = False
        tab.look("3d")
    assert app.fps_wanted() is None


def test_a_new_snapshot_keeps_the_rig_tables_while_the_geometry_stays(demo):
    """A marker added reuses the rig (its tables took ~70 ms) and the backdrop; a moved plane or
    outline, a new selection or another background builds them again."""
    app, _ = demo
    before = app._snapshot
    session = before.session
    mirror = session.mirrors[0]
    marked = replace(
        session,
        mirrors=(replace(mirror, markers=mirror.markers + ((300.0, 200.0),)), *session.mirrors[1:]),
    )
    after = Snapshot.build(marked, before.background, previous=before)
    assert after.rig is before.rig and after.backdrop is before.backdrop and after.session is marked
    moved = replace(mirror, plane=Plane(mirror.plane.normal, mirror.plane.d + 0.001))
    rebuilt = Snapshot.build(
        replace(session, mirrors=(moved, *session.mirrors[1:])), before.background, previous=before
    )
    assert rebuilt.rig is not before.rig and rebuilt.rig.mirrors[0].plane == moved.plane
    outlined = replace(mirror, boundary=mirror.boundary[:-1])
    assert (
        Snapshot.build(
            replace(session, mirrors=(outlined, *session.mirrors[1:])),
            before.background,
            previous=before,
        ).rig
        is not before.rig
    )
    assert (
        Snapshot.build(replace(session, bounces=1), before.background, previous=before).rig
        is not before.rig
    )
    selected = replace(session, selection=replace(session.selection, min_gap=0.05))
    assert (
        Snapshot.build(selected, before.background, previous=before).backdrop is not before.backdrop
    )
    assert (
        Snapshot.build(session, before.background.copy(), previous=before).backdrop
        is not before.backdrop
    )


def test_loop_thread_pause_and_step(demo):
    app, _ = demo
    app.loop.start()
    start = app.loop.index
    wait_for(lambda: app.loop.index >= start + 2)  # running
    app.pause(True)
    time.sleep(0.3)  # let a frame in progress finish
    held = app.loop.index
    time.sleep(0.5)  # time for frames that must not come
    assert app.loop.index == held  # paused: no new frames
    app.step()
    wait_for(lambda: app.loop.index == held + 1)
    time.sleep(0.3)  # time for a frame that must not come
    assert app.loop.index == held + 1  # exactly one
    # the frame slider dragged while paused
    for k in (5, 6, 7, 40):
        app.seek(k)
    wait_for(lambda: app.last_frame.index == 40)
    time.sleep(0.3)  # time for frames that must not come
    assert app.loop.index == 41  # the frame sought is shown, once
    app.pause(False)
    wait_for(lambda: app.loop.index >= held + 3)
    assert app.fps() > 0


def test_depth_screen_maps_rays_to_pixels_and_back(demo):
    screen = demo[1].tab.screen
    eye = screen.centre - [0.3, -0.2, 2.0]  # somewhere behind the screen
    for uv in [(0.0, 0.0), (319.5, 239.5), (639.0, 479.0), (100.25, 400.75)]:
        target = screen.world_of_pixel(*uv)
        got = screen.pixel_of_ray(eye, target - eye)
        np.testing.assert_allclose(got, uv, atol=1e-9)
    # u grows with x: not mirrored
    assert screen.world_of_pixel(0, 0)[0] < screen.world_of_pixel(639, 0)[0]
    # v grows with y (down)
    assert screen.world_of_pixel(0, 0)[1] < screen.world_of_pixel(0, 479)[1]
    assert screen.pixel_of_ray(eye, [0.0, 0.0, -1.0]) is None  # pointing away
    # beside it
    assert screen.pixel_of_ray(eye, screen.world_of_pixel(0, 0) - [0.5, 0, 0] - eye) is None


@pytest.mark.parametrize("aspect", [0.8, 1.04, 16 / 9])
def test_the_depth_frame_fills_the_free_area(demo, aspect):
    """From the view pose, every corner of the frame is inside the tab's view of 50 deg, and one
    side fits."""
    screen = demo[1].tab.screen
    position, target = screen.view_pose(aspect)
    distance = target[2] - position[2]
    half_h = np.tan(np.radians(25)) * distance
    half_w = half_h * aspect
    assert screen.height / 2 <= half_h and screen.width / 2 <= half_w
    # not lost in the middle
    assert max(screen.height / 2 / half_h, screen.width / 2 / half_w) > 0.95


def test_views_through_several_mirrors_are_streamed_named_and_drawn(notes):
    """On a 72-degree kaleidoscope with its true planes: the views through two mirrors in turn reach
    the tab as sources of their own, the legend names them with the mirrors' names, their virtual
    cameras are drawn, and the number of mirrors followed is a session setting that can be undone.
    """
    from mirrorscan.bench.tabs import HeadlessTab
    from mirrorcore.base.palette import FIRST_MULTI_LABEL
    from mirrorcore.sim.layouts import kaleidoscope_scene

    app = _simulated_app(kaleidoscope_scene(72.0))
    try:
        with HeadlessTab(app) as headless:
            tab = headless.tab
            frame = app.loop.run_once()
            multi = [label for label in frame.counts if label >= FIRST_MULTI_LABEL]
            assert multi and all(frame.counts[label] > 100 for label in multi)
            # streamed as their own nodes
            assert {label for label, _ in tab.scene._clouds} >= set(multi)
            assert "mirror 1 then mirror 2" in tab.header.legend.content
            # first and second order
            assert len(tab.scene._virtual) >= 2 + len(multi)
            named = {label.text for label in tab.scene._virtual_labels}
            assert {"camera in mirror 1", "camera in mirror 1 then mirror 2"} <= named
            app.editor.set_bounces(1)
            frame = app.loop.run_once()
            assert max(frame.counts) <= 2 and app.snapshot.session.bounces == 1
            # the tab's own cameras too
            assert len(tab.scene._virtual) == 2
            assert len(tab.scene._virtual_labels) == 2
            assert app.editor.undo(SESSION_SCOPE) == "mirrors followed in turn"
            assert app.snapshot.session.bounces == 3
            assert len(tab.scene._virtual) >= 2 + len(multi)
    finally:
        app.stop()


def test_a_mirrors_name_is_at_the_middle_of_its_top_edge():
    """The middle of a pane's top edge; two mirrors hinged at 90 degrees, their hinge's top corner
    listed first (as the simulator's are), get their names apart (both were on that corner)."""
    # up is -y
    pane = np.array([[-0.5, 0.4, 2.0], [0.5, 0.4, 2.0], [0.5, -0.6, 2.2], [-0.5, -0.6, 2.2]])
    np.testing.assert_allclose(label_anchor(pane), [0.0, -0.6, 2.2])
    left = np.array([[0.0, -0.5, 2.35], [-0.7, -0.5, 1.65], [-0.7, 0.5, 1.65], [0.0, 0.5, 2.35]])
    right = left * [-1, 1, 1]
    np.testing.assert_allclose(label_anchor(left), [-0.35, -0.5, 2.0])
    np.testing.assert_allclose(label_anchor(right), [0.35, -0.5, 2.0])


def _home_pixels(points: np.ndarray, canvas: tuple[int, int], scene: np.ndarray) -> np.ndarray:
    """(k, 2) pixels of `points` (k, 3) metres in the first view (home_pose of `scene`, as
    Tab.look_home frames it) of a canvas (width, height) with the tab's 50 degrees of vertical field
    of view; y grows downwards."""
    fov = np.radians(50.0)
    position, target = home_pose(scene, fov, canvas[0] / canvas[1])
    forward = (target - position) / np.linalg.norm(target - position)
    right = np.cross(forward, [0.0, -1.0, 0.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    rays = points - position
    focal = canvas[1] / 2 / np.tan(fov / 2)
    depth = rays @ forward
    return np.stack(
        [
            canvas[0] / 2 + focal * (rays @ right) / depth,
            canvas[1] / 2 + focal * (rays @ down) / depth,
        ],
        1,
    )


def _simulated_app(scene):
    """The app (not started, not saved) on a simulated scene, its planes the true ones (a perfect
    calibration)."""
    from mirrorscan.server import MirrorscanApp
    from mirrorcore.io.session import Session
    from mirrorcore.sim.export import session_mirrors
    from mirrorcore.sim.simulator import Simulator
    from mirrorcore.sources import SimulatedSource

    rig = Simulator(scene, seed=0)
    mirrors = tuple(
        replace(m, plane=p)
        for m, p in zip(session_mirrors(rig, rig.background().truth), rig.planes)
    )
    return MirrorscanApp(
        Session(Path("unused"), rig.intrinsics, mirrors),
        SimulatedSource(rig),
        port=0,
        autosave=False,
    )


def _name_boxes(
    labels, canvas: tuple[int, int], home: np.ndarray
) -> list[tuple[np.ndarray, np.ndarray]]:
    """(low, high) pixels of each label's name in the first view framing `home` (k, 3) metres: a box
    7 px a character wide and 18 px high, times its font scale, at its anchor's corner, as drawn."""
    anchors = _home_pixels(np.array([label.position for label in labels]), canvas, home)
    found = []
    for anchor, label in zip(anchors, labels):
        vertical, horizontal = label.anchor.split("-")
        size = np.array([7.0 * len(label.text), 18.0]) * label.font_screen_scale
        corner = np.array(
            [
                {"left": 0.0, "center": 0.5, "right": 1.0}[horizontal],
                {"top": 0.0, "center": 0.5, "bottom": 1.0}[vertical],
            ]
        )
        found.append((anchor - corner * size, anchor - corner * size + size))
    return found


CANVASES = [(976, 900), (620, 600)]  # the 3D view at 1400x900 and at 1024x600


@pytest.mark.parametrize("canvas", CANVASES)
def test_seen_from_home_every_virtual_camera_is_named_in_view_clear_of_the_object_and_names(
    demo, canvas
):
    """The walking figure's first view: the name of each camera seen in a mirror lies inside the 3D
    view (and the depth camera's), neither on the figure's points nor on a mirror's name, nor on
    the figure's head (2.5 frustum sizes under the frustum, seen from 24 degrees above), and seen
    from the right the right mirror's camera was out of view."""
    app, headless = demo
    frame = app.loop.run_once()
    scene = headless.tab.scene
    points = frame.cloud.points[:: max(1, len(frame.cloud) // 500)]
    home = np.concatenate([scene_points(app.snapshot.rig), points])
    figure = _home_pixels(points, canvas, home)
    mirrors = _name_boxes(
        [label for label in scene._labels if label.text.startswith("mirror")], canvas, home
    )
    cameras = _name_boxes(scene._virtual_labels, canvas, home)
    assert len(mirrors) == 2 and len(cameras) == 2
    for low, high in cameras + _name_boxes(
        [label for label in scene._labels if label.text == "depth camera"], canvas, home
    ):
        assert np.all(low >= 0) and np.all(high <= canvas), (low, high)
        assert not np.any(np.all((figure >= low) & (figure <= high), axis=1)), (low, high)
        assert not any(
            np.all(low <= other_high) and np.all(other_low <= high)
            for other_low, other_high in mirrors
        )


@pytest.mark.parametrize("scene", ["arc", "hinged", "four"])
def test_seen_from_home_the_names_of_cameras_through_several_mirrors_stand_apart(scene):
    """An arc of three mirrors around the figure, two hinged at 72 degrees, four mirrors: every name
    (the depth camera's, the mirrors', the cameras' through one mirror and through two) inside the
    3D view and none on another by more than 2 px, at both window sizes. Run inwards from every
    camera beyond the mirrors, names through two mirrors are not written over each other, nor on
    four mirrors over those through one."""
    from mirrorscan.bench.tabs import HeadlessTab
    from mirrorcore.sim.layouts import arc_scene, kaleidoscope_scene

    made = {
        "arc": lambda: arc_scene(3, object="figure", distance=3.0),
        "hinged": lambda: kaleidoscope_scene(72.0),
        "four": lambda: arc_scene(4),
    }[scene]()
    app = _simulated_app(made)
    try:
        with HeadlessTab(app) as headless:
            tab = headless.tab
            frame = app.loop.run_once()
            labels = tab.scene._labels + tab.scene._virtual_labels
            assert any(label.text.count("then") for label in tab.scene._virtual_labels)
            points = frame.cloud.points[:: max(1, len(frame.cloud) // 500)]
            home = np.concatenate([scene_points(app.snapshot.rig), points])
            for canvas in CANVASES:
                boxes = _name_boxes(labels, canvas, home)
                for (low, high), label in zip(boxes, labels):
                    assert np.all(low >= 0) and np.all(high <= canvas), (label.text, canvas)
                for (a, (low, high)), (b, (other_low, other_high)) in itertools.combinations(
                    enumerate(boxes), 2
                ):
                    assert not (np.all(low < other_high - 2) and np.all(other_low < high - 2)), (
                        labels[a].text,
                        labels[b].text,
                        canvas,
                    )
    finally:
        app.stop()


def test_virtual_cameras_in_one_place_share_one_label():
    """Between mirrors hinged at 72 degrees, calibrated from their markers, the camera seen through
    two mirrors and through three stand 1.3 to 5.4 cm apart:
    one label names both, where their two labels were written over each other; cameras 12 cm apart
    keep their own."""

    def camera(sequence, x, z):
        pose = np.eye(4)
        pose[:3, 3] = (x, 0.0, z)
        return SimpleNamespace(sequence=sequence, pose=pose)

    cameras = [
        camera((1,), -2.307, 1.677),
        camera((2,), 2.305, 1.669),
        camera((1, 2), 1.432, 4.384),
        camera((2, 1), -1.430, 4.385),
        camera((1, 2, 1), 1.422, 4.391),
        camera((2, 1, 2), -1.376, 4.385),
        camera((1, 2, 1, 2), 1.552, 4.384),
    ]
    groups = same_place(cameras)
    assert [[c.sequence for c in g] for g in groups] == [
        [(1,)],
        [(2,)],
        [(1, 2), (1, 2, 1)],
        [(2, 1), (2, 1, 2)],
        [(1, 2, 1, 2)],
    ]


def test_a_session_opened_with_its_planes_tells_how_its_views_agree():
    """No fit needed: once the frames of the session as opened are in, the views' agreement is
    reported."""
    source = demo_source()
    app = MirrorscanApp(calibrated_session(source, Path("unused")), source, port=0, autosave=False)
    app.start()
    try:
        report = wait_for(lambda: app.jobs.agreement, 60, "the agreement")
        assert [m.name for m in report.mirrors] == ["mirror 1", "mirror 2"]
        said = joined(calibration_words.agreement(report))
        assert said.startswith("mirror 1: agrees") and "\n\nmirror 2: agrees" in said
    finally:
        app.stop()


def test_the_agreement_reported_is_that_of_the_current_planes(demo, monkeypatch):
    """A change of the mirrors while the agreement is computed (an undo, a fit: here a rename) is
    not left out: the check asked for meanwhile is not started beside the running one, which checks
    again before it reports."""
    import mirrorscan.jobs.agreement as jobs_module

    app_, _ = demo
    frame, calls = app_.loop.run_once(), []
    wait_for(lambda: not app_.jobs.running("agreement"), 60, "the start-up agreement")
    real = jobs_module.view_agreement

    def renamed_meanwhile(rig, depths, masks):
        calls.append(rig)
        if len(calls) == 1:
            app_.editor.rename_mirror(1, "left")
            # asked again while it runs: not started
            app_.jobs.start_agreement(frame.depth)
        return real(rig, depths, masks)

    monkeypatch.setattr(jobs_module, "view_agreement", renamed_meanwhile)
    done = []
    unsubscribe = app_.bus.subscribe(
        JobProgress, lambda e: e.job == "agreement" and e.fraction is None and done.append(e.result)
    )
    try:
        app_.jobs.start_agreement(frame.depth)
        report = wait_for(lambda: done, 60, "the agreement")[0]
        assert (
            report.mirrors[0].name == "left" and len(calls) == 2 and app_.jobs.agreement is report
        )
    finally:
        unsubscribe()
        app_.editor.rename_mirror(1, "mirror 1")


def test_without_planes_the_agreement_says_what_to_do(demo, monkeypatch):
    """No mirror has a plane: the agreement says so and what to do (it read "no view sees what
    another sees")."""
    import mirrorscan.jobs.agreement as jobs_module

    app_, _ = demo
    frame = app_.loop.run_once()
    wait_for(lambda: not app_.jobs.running("agreement"), 60, "the start-up agreement")
    monkeypatch.setattr(jobs_module, "view_agreement", lambda rig, depths, masks: {})
    app_.jobs.start_agreement(frame.depth)
    wait_for(lambda: not app_.jobs.running("agreement"), 60, "the agreement")
    assert app_.jobs.agreement == AgreementReport(())
    assert calibration_words.agreement(app_.jobs.agreement) == [calibration_words.NO_AGREEMENT]
    monkeypatch.undo()
    app_.jobs.start_agreement(frame.depth)
    wait_for(lambda: not app_.jobs.running("agreement"), 60, "the agreement")


def test_a_refused_refinement_is_not_offered_again_for_the_glass(demo, monkeypatch):
    """After a refinement was refused, the next step does not send the technician back to it for
    the glass, but to typing the glass in,
    also after the next fit, until a refinement
    succeeds."""
    import mirrorscan.jobs.refinement as jobs_module

    app_, headless = demo
    app_.loop.run_once()
    real = jobs_module.refine_session

    def refused(*args, **kwargs):
        raise CalibrationError(
            "mirror 1: the camera and the mirror see too little of the same surface", ("mirror 1",)
        )

    monkeypatch.setattr(jobs_module, "refine_session", refused)
    hint = headless.tab.header.hint
    headless.tab.header.refresh_hint()
    assert (
        "No glass set on mirror 1 and mirror 2: **Mirrors › Refine from the object** measures it."
        in hint.content
    )
    app_.jobs.start_refine(app_.editor).join(60)
    ids = [m.id for m in app_.editor.session.mirrors]
    # the mirror it names (a search refused on
    assert app_.jobs.refused == {ids[0]: "refine"}
    headless.tab.header.refresh_hint()
    assert "this object could not measure it" in hint.content
    assert app_.jobs.refusals(app_.editor.session) == {ids[0]: "refine"}
    # its outline drawn again: refused no more
    corner = app_.editor.mirror(ids[0]).boundary[0]
    # (a search refused for an outline too
    app_.editor.move_vertex(ids[0], 0, (corner[0] + 3.0, corner[1]))
    # narrow was not offered once it was
    assert app_.jobs.refusals(app_.editor.session) == {}
    app_.editor.undo(ids[0])
    assert app_.jobs.refusals(app_.editor.session) == {ids[0]: "refine"}
    # a fit moves a plane: still so
    mirror = app_.editor.mirror(ids[0])
    app_.editor.set_planes({ids[0]: (replace(mirror.plane, d=mirror.plane.d + 0.001), mirror)})
    headless.tab.header.refresh_hint()
    assert "this object could not measure it" in hint.content
    # one that succeeds clears it
    monkeypatch.setattr(jobs_module, "refine_session", real)
    app_.jobs.start_refine(app_.editor).join(120)
    assert app_.jobs.refused == {}
    assert app_.editor.undo(ids[0]).startswith("refined planes") and app_.editor.undo(
        ids[0]
    ).startswith("plane")


def test_a_mirror_held_while_the_others_are_found_keeps_its_plane_from_its_markers(
    demo, monkeypatch
):
    """Find the planes from the object with mirror 1 fitted from its markers and held: only mirror
    2's plane comes from the object, and mirror 1 is still asked for its glass."""
    import mirrorscan.jobs.refinement as jobs_module

    app_, headless = demo
    app_.loop.run_once()
    held, found = app_.editor.session.mirrors
    app_.editor.set_planes({found.id: (None, found)})
    truth = found.plane

    def search(session, depths, masks, rng, indices, progress=None, cancel=None, with_="auto"):
        assert list(indices) == [1]
        report = refined(found.name, 1, after=truth)
        return session.with_mirror(1, replace(session.mirrors[1], plane=truth)), SimpleNamespace(
            mirrors=[report], compared="surfaces", refused=()
        )

    monkeypatch.setattr(jobs_module, "calibrate_scene", search)
    app_.jobs.start_scene(app_.editor).join(60)
    assert app_.editor.mirror(found.id).plane == truth
    assert app_.jobs.from_object(found.id, truth) and not app_.jobs.from_object(held.id, held.plane)
    headless.tab.header.refresh_hint()
    assert f"No glass set on {held.name}:" in headless.tab.header.hint.content


def test_find_applies_the_planes_it_found_and_names_the_mirror_it_did_not(demo, monkeypatch):
    """Find the planes from the object where one mirror cannot be found: the others' planes are
    applied and the one not found is named with why, in the headline and its details, and its Find
    is not offered again until its outline or markers change (before, one refusal dropped every
    plane found)."""
    import mirrorscan.jobs.refinement as jobs_module

    app_, headless = demo
    app_.loop.run_once()
    first, second = app_.editor.session.mirrors
    app_.editor.set_planes({first.id: (None, first), second.id: (None, second)})
    why = f"{first.name}: 300 readings just outside its outline lie beyond the object seen directly"

    def search(session, depths, masks, rng, indices, progress=None, cancel=None, with_="auto"):
        assert list(indices) == [0, 1]
        report = refined(second.name, 1, after=second.plane)
        return session.with_mirror(
            1, replace(session.mirrors[1], plane=second.plane)
        ), SimpleNamespace(mirrors=[report], compared="surfaces", refused=((0, why),))

    monkeypatch.setattr(jobs_module, "calibrate_scene", search)
    app_.jobs.start_scene(app_.editor).join(60)
    assert (
        app_.editor.mirror(second.id).plane == second.plane
        and app_.editor.mirror(first.id).plane is None
    )
    report = app_.jobs.refinements[planes_key(app_.editor.session)]
    assert report.not_found == (NotFound(first.name, why.removeprefix(first.name + ": ")),)
    said = calibration_words.report(report)
    assert f"⚠ {first.name} not found (why below)." in said[0].headline
    assert (
        f"Undo goes by mirror: select {second.name} to take the planes found back."
        in said[0].details
    )
    assert said[-1].headline.startswith(f"**{first.name}** ⚠ not found") and said[-1].details == (
        why.removeprefix(first.name + ": "),
    )  # named once
    assert app_.jobs.refusals(app_.editor.session) == {first.id: "scene"}
    mirrors = next(p for p in headless.tab.panels if isinstance(p, MirrorsPanel))
    # the one not found: Find greyed out, saying
    headless.tab.state.mirror_id = first.id
    # why (viser shows no hint on a button)
    mirrors.refresh()
    assert mirrors.scene.disabled and mirrors.greyed.visible
    assert (
        f"<b>Find</b>: {first.name} not found as it is (why: in the report below); offered "
        "again once an "
        "outline or a marker changes"
    ) in mirrors.greyed.content
    # nothing to undo on it (the shared demo's
    label = app_.editor.undo_label
    # earlier tests left steps): the found plane
    monkeypatch.setattr(
        app_.editor,
        "undo_label",
        # is on the other
        lambda scope: None if scope in (first.id, 0) else label(scope),
    )
    mirrors.refresh()
    assert mirrors.undo.disabled
    assert mirrors.greyed.content.endswith(
        f"<b>Undo</b>: nothing to take back on {first.name}; "
        "select "
        f"{second.name} for its changes</div>"
    )
    headless.tab.state.mirror_id = second.id
    mirrors.refresh()
    assert not mirrors.undo.disabled and "<b>Undo</b>" not in mirrors.greyed.content


def test_undoing_planes_whose_last_refinement_changed_nothing_names_the_step(demo):
    """Find, a mirror without a plane removed, then a refinement that changed nothing: its report
    holds the planes' key, and undoing the planes found names the step undone, not the refinement.
    """
    app_, headless = demo
    mirrors = next(p for p in headless.tab.panels if isinstance(p, MirrorsPanel))
    before, after = (("a",),), (("b",),)
    unchanged = CalibrationReport(
        (refined("mirror 1"),), False, "surfaces", False, FramesUsed((0, 1, 2, 3, 4))
    )
    app_.jobs.refinements[before] = unchanged
    label = "found planes of mirror 1 and mirror 2"
    assert mirrors._report_after_travel(before, after, label, True) == f"Undone: {label}."
    app_.jobs.refinements[before] = replace(unchanged, search=True, changed=True)
    assert mirrors._report_after_travel(before, after, label, True) == (
        # its advice was for the planes undone
        "Undone: the planes found from the object for mirror 1."
    )
    # a mirror removed since the report
    del app_.jobs.refinements[before]
    assert mirrors._report_after_travel(before, after, label, True) == f"Undone: {label}."
    # the planes as they were
    assert mirrors._report_after_travel(before, before, "marker 1.2", True) == ""


def _panel_with_a_new_mirror(demo):
    """The demo tab's Mirrors panel, the editor and the tab's state, after Add a mirror; and the new
    mirror's id."""
    app_, headless = demo
    mirrors = next(p for p in headless.tab.panels if isinstance(p, MirrorsPanel))
    mirrors._add()
    return mirrors, app_.editor, headless.tab.state, headless.tab.state.mirror_id


def test_undo_while_an_outline_is_drawn_takes_its_last_corner_back(demo):
    """Two corners of a new mirror's outline clicked, Undo takes them back one at a time, and only
    then the mirror."""
    mirrors, editor, state, new = _panel_with_a_new_mirror(demo)
    try:
        mirrors._boundary_click(100.0, 100.0)
        mirrors._boundary_click(200.0, 100.0)
        mirrors.refresh()
        assert mirrors.undo.label == "Undo: corner 2 of the outline" and not mirrors.undo.disabled
        mirrors._travel(editor.undo)
        assert state.drafts[new] == ((100.0, 100.0),) and editor.mirror(new) is not None
        mirrors.refresh()
        assert mirrors.undo.label == "Undo: corner 1 of the outline"
        mirrors._travel(editor.undo)
        assert new not in state.drafts and editor.mirror(new) is not None
        mirrors.refresh()
        assert mirrors.undo.label.startswith("Undo: add ")
    finally:
        editor.remove_mirror(new)
        state.mirror_id = editor.session.mirrors[0].id


def test_the_outline_buttons_are_offered_only_where_they_can_act(demo):
    """Boundary mode: Close boundary while an outline is drawn, saying how many corners it still
    needs, and Delete the picked corner once it is closed, naming the corner picked; neither where
    it cannot act."""
    mirrors, editor, state, new = _panel_with_a_new_mirror(demo)
    try:
        state.mode = "boundary"
        mirrors.refresh()

        def shown() -> tuple[bool, bool, bool]:
            return (
                mirrors.close.visible,
                mirrors.delete_corner.visible,
                mirrors.clear_boundary.visible,
            )

        assert (
            shown() == (True, False, True)
            and mirrors.close.disabled
            and mirrors.clear_boundary.disabled
        )
        assert mirrors.close.label == "Close boundary (0 of the 3 corners it needs)"
        for u, v in ((100.0, 100.0), (200.0, 100.0)):
            mirrors._boundary_click(u, v)
        mirrors.refresh()
        assert (
            mirrors.close.label == "Close boundary (2 of the 3 corners it needs)"
            and mirrors.close.disabled
        )
        assert not mirrors.clear_boundary.disabled
        mirrors._boundary_click(200.0, 200.0)
        mirrors.refresh()
        assert mirrors.close.label == "Close boundary" and not mirrors.close.disabled
        mirrors._close_boundary()
        state.mode = "boundary"
        mirrors.refresh()
        assert shown() == (False, True, True) and mirrors.delete_corner.disabled
        assert mirrors.delete_corner.label == "Delete the picked corner"
        mirrors._boundary_click(201.0, 99.0)  # near the second corner: picks it
        mirrors.refresh()
        assert (
            mirrors.delete_corner.label == "Delete corner 2" and not mirrors.delete_corner.disabled
        )
        state.mode = "markers"
        mirrors.refresh()
        assert shown() == (False, False, False)
    finally:
        editor.remove_mirror(new)
        state.mirror_id, state.mode, state.picked_corner = (
            editor.session.mirrors[0].id,
            "inspect",
            None,
        )


def test_a_report_stays_while_it_describes_every_plane(demo):
    """The report under the buttons stays when a mirror without a plane is added, and when a mirror
    is removed; it
    goes when a plane changes, and Undo of the removal brings back the report as it was."""
    app_, headless = demo
    mirrors = next(p for p in headless.tab.panels if isinstance(p, MirrorsPanel))
    editor, state = app_.editor, headless.tab.state
    first, second = editor.session.mirrors[:2]
    found = CalibrationReport(
        (refined(first.name), refined(second.name, 1)),
        True,
        "surfaces",
        True,
        FramesUsed((0, 1, 2, 3, 4)),
    )
    app_.jobs.refinements[planes_key(editor.session)] = found
    report = report_markdown(found)
    mirrors._report(report)
    try:
        new = editor.add_mirror()
        mirrors.refresh()
        assert mirrors.result.content == report
        editor.remove_mirror(new)
        checks = []
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(app_.jobs, "start_agreement", lambda: checks.append(1))
            mirrors._travel_mirrors(lambda: editor.remove_mirror(second.id))
        assert checks == [1]
        mirrors.refresh()
        assert mirrors.result.content == f"{report}\n\n*{second.name} was removed since.*"
        # the second mirror back: its report as it was
        editor.undo(SESSION_SCOPE)
        mirrors.refresh()
        assert mirrors.result.content == report
        editor.remove_mirror(second.id)
        mirrors.refresh()
        editor.set_planes(
            {first.id: (Plane.from_abcd([0.0, 0.0, -1.0, 2.0]), editor.mirror(first.id))}
        )
        mirrors.refresh()
        assert mirrors.result.content == ""
    finally:
        if editor.mirror(first.id).plane != first.plane:
            editor.undo(first.id)
        if all(m.id != second.id for m in editor.session.mirrors):
            editor.undo(SESSION_SCOPE)
        state.mirror_id = editor.session.mirrors[0].id
        mirrors.refresh()
    assert [(m.id, m.plane) for m in editor.session.mirrors] == [
        (first.id, first.plane),
        (second.id, second.plane),
    ]


def test_undoing_a_removal_brings_back_the_markers_fits_report(demo):
    """Fit all planes (applied on confirmation), a mirror removed, then Undo: the mirror is back
    with its plane, and so is the fit's report (per mirror, its markers' residuals)."""
    app_, headless = demo
    mirrors = next(p for p in headless.tab.panels if isinstance(p, MirrorsPanel))
    editor, state = app_.editor, headless.tab.state
    first, second = editor.session.mirrors[:2]
    steps = editor.undo_label(first.id), editor.undo_label(second.id)
    try:
        mirrors.fit_all_planes()
        # the demo's planes came from the object: a proposal
        assert mirrors.proposal is not None
        mirrors._apply()
        applied = app_.jobs.fits[planes_key(editor.session)]
        assert [f.mirror.name for f in applied.fits] == [first.name, second.name]
        report = report_markdown(applied)
        assert report.startswith(f"**{first.name}**: ") and f"**{second.name}**: " in report
        assert mirrors.result.content == report
        state.mirror_id = second.id
        mirrors._travel_mirrors(lambda: editor.remove_mirror(second.id))
        mirrors.refresh()
        assert mirrors.result.content == f"{report}\n\n*{second.name} was removed since.*"
        state.mirror_id = first.id
        mirrors._travel(editor.undo)  # the removal taken back first
        assert editor.mirror(second.id).plane is not None
        assert mirrors.result.content.startswith("Undone: ")
        assert mirrors.result.content.endswith(f"\n\n{report}")
        mirrors.refresh()  # and it stays
        assert report.split("\n\n")[0] in mirrors.result.content
    finally:
        if all(m.id != second.id for m in editor.session.mirrors):
            editor.undo(SESSION_SCOPE)
        for mirror_id, step in zip((first.id, second.id), steps):
            while editor.undo_label(mirror_id) not in (step, None):
                editor.undo(mirror_id)
        state.mirror_id = editor.session.mirrors[0].id
        mirrors.refresh()
    assert [(m.id, m.plane) for m in editor.session.mirrors] == [
        (first.id, first.plane),
        (second.id, second.plane),
    ]


def test_removing_a_mirror_names_what_it_has():
    plane = Plane.from_abcd([0.0, 0.0, -1.0, 2.0])
    full = SessionMirror(
        "left", markers=((1, 1),), boundary=((0, 0), (10, 0), (10, 10)), plane=plane, id=1
    )
    assert removal_question(full) == (
        "left and its 1 marker, boundary and plane leave the session. What it shows then counts as "
        "seen directly: "
        "take the mirror out of the camera's view too, or what is seen in it stands in the cloud "
        "as an object of its "
        "own. *Undo*, or *Bring back* below the Remove button, brings it back."
    )
    assert removal_question(replace(full, markers=(), plane=None)).startswith(
        "left and its boundary leave the"
    )
    assert removal_question(SessionMirror("new", id=2)) == (
        "new leaves the session. *Undo*, or *Bring back* below the Remove button, brings it back."
    )


def test_greyed_out_buttons_say_why():
    """Why each calibration button is greyed out, named, in one line of small print, names escaped
    (a mirror's name comes from a session file); nothing when every button is offered."""
    plane = Plane.from_abcd([0.0, 0.0, -1.0, 2.0])
    camera = Intrinsics.kinect_v1()
    bare = SessionMirror(
        "<b>m1</b>", plane=None, boundary=((0, 0), (10, 0), (10, 10)), markers=((1, 1),), id=1
    )
    fitted = SessionMirror("m2", plane=plane, markers=((1, 1), (2, 2), (3, 3)), id=2)
    lone = Session(Path("s"), camera, (bare,))
    text = greyed_out(lone, bare, {})
    assert (
        text.count("<b>") == 3 and "&lt;b&gt;m1&lt;/b&gt; has 1 of the 3 markers it needs" in text
    )
    assert (
        "<b>Fit all planes</b>: no mirror has 3 markers" in text
        and "<b>Refine</b>: no mirror has a plane" in text
    )
    assert "<b>Find</b>" not in text and "<b>Find</b>: &lt;b&gt;m1" in greyed_out(
        lone, bare, {1: "scene"}
    )
    # a refinement refused: Find still offered
    assert greyed_out(lone, bare, {1: "refine"}) == text
    both = Session(Path("s"), camera, (bare, fitted))
    assert greyed_out(both, fitted, {}) == ""
    # a plane without markers
    assert "<b>Fit plane</b>" not in greyed_out(both, replace(fitted, markers=()), {})
    found = Session(
        Path("s"), camera, (replace(bare, plane=plane, markers=()), replace(fitted, markers=()))
    )
    # planes found, no markers: nothing to fit
    assert greyed_out(found, found.mirrors[0], {}) == ""
    assert "select m2 for its changes" in greyed_out(both, bare, {}, ("m2",))
    assert "select m2 or m3 for their changes" in greyed_out(both, bare, {}, ("m2", "m3"))
    assert greyed_out(Session(Path("s"), camera, ()), None, {}) == ""


def test_a_mirror_the_agreement_flags_is_told_in_a_notification_once(demo, notes):
    """The agreement lines may be out of view (at 1024x600 two screens down): a mirror they flag is
    also named in a notification, not again for the same lines."""
    app_, headless = demo
    kinds: list = []
    said = notes(app_, kinds)
    mirrors = next(p for p in headless.tab.panels if isinstance(p, MirrorsPanel))
    good = ViewAgreement(10.0, 0.5, 900, 11.7, 5.0, 0.5, 9.0, 800, frames=5)
    # tilted against the camera
    bad = ViewAgreement(12.0, 3.0, 900, 11.7, 8.0, -4.2, 9.0, 800, frames=5)

    def ended(*views):
        report = AgreementReport(
            tuple(MirrorAgreement(f"mirror {k}", v, True) for k, v in enumerate(views, 1))
        )
        return JobProgress("agreement", None, joined(calibration_words.agreement(report)), report)

    mirrors._on_job(ended(good))
    assert said == []
    mirrors._on_job(ended(good, bad))
    assert said == [
        "mirror 2: ⚠ its view disagrees with the others beyond the depth noise; why "
        "and what to do "
        "are under Mirrors."
    ] and kinds == [("warning", False)]
    # the same lines again: once
    mirrors._on_job(ended(good, bad))
    mirrors._on_job(ended(bad, bad))
    assert len(said) == 2 and said[-1].startswith("mirror 1 and mirror 2: ⚠ their views disagree")


def test_reading_pixels_shows_one_note_at_a_time(demo):
    """Inspect clicks each show the pixel's reading; the previous note goes (at 1024x600 they
    stacked over the depth frame)."""
    app, headless = demo
    app.loop.run_once()
    header = headless.tab.header
    header.show_pixel(320, 240)
    first = header._pixel_note
    header.show_pixel(10.4, 3.6)
    assert first._impl.removed and not header._pixel_note._impl.removed
    assert header.pixel.content.startswith("pixel (10.4, 3.6): ")


def test_the_hint_names_the_next_step_and_not_a_mode_already_chosen(tmp_path):
    session = Session(tmp_path, Intrinsics.kinect_v1(), mirrors=(SessionMirror("left", id=1),))
    assert "Add a mirror" in start_hint(Session(tmp_path, session.camera), TabState(), True, False)
    hint = start_hint(session, TabState(mirror_id=1, view="depth"), True, False)
    assert (
        hint == "left: choose **Boundary** and click its corners; click the first corner to close."
    )
    hint = start_hint(session, TabState(mirror_id=1, view="depth", mode="boundary"), True, False)
    assert hint == "left: click its corners; click the first corner to close."
    edged = Session(
        tmp_path,
        session.camera,
        mirrors=(SessionMirror("left", id=1, boundary=((0, 0), (9, 0), (0, 9))),),
    )
    assert start_hint(edged, TabState(mirror_id=1), True, False) == (
        "Look at the **Depth frame** (View, below); left: choose **Markers** and click a marker on "
        "the mirror, or "
        "**Find the planes from the object**."
    )
    assert start_hint(edged, TabState(mirror_id=1), True, False, calibrating=0.45) == (
        "A calibration from the object runs (45% done): its progress, **Cancel** and then its "
        "report are under "
        "*Mirrors*."
    )
    assert start_hint(edged, TabState(mirror_id=1, mode="markers", view="depth"), True, False) == (
        "left: click a marker on the mirror, or **Find the planes from the object**."
    )
    assert start_hint(
        edged,
        TabState(mirror_id=1, mode="markers", view="depth"),
        True,
        False,
        refused={1: "scene"},
    ) == (
        "left: not found from the object (why: under Mirrors); or click a marker on the mirror."
    )
    one = Session(tmp_path, session.camera, mirrors=(replace(edged.mirrors[0], markers=((1, 1),)),))
    assert start_hint(one, TabState(mirror_id=1, mode="markers", view="depth"), True, False) == (
        # markers begun: no second way
        "left: click more markers (3 or more, spread out) on the mirror."
    )
    waiting = start_hint(edged, TabState(mirror_id=1, proposal_for=("left",)), True, False)
    assert waiting == "A new plane for left waits: **Mirrors › Apply** it or **Discard** it."
    done = Session(
        tmp_path,
        session.camera,
        mirrors=(
            replace(
                edged.mirrors[0],
                plane=Plane.from_point_normal([0, 0, 2], [0, 0, -1]),
                markers=((1, 1), (5, 1), (1, 5)),
            ),
        ),
    )
    assert start_hint(done, TabState(mirror_id=1), True, True).startswith(
        "Ready: the merged cloud is live"
    )
    assert start_hint(done, TabState(mirror_id=1), True, True, no_glass=("left",)) == (
        "Ready: the merged cloud is live. No glass set on left: **Mirrors › Refine from the "
        "object** measures it."
    )
    assert start_hint(
        done, TabState(mirror_id=1), True, True, no_glass=("left",), refused={1: "refine"}
    ) == (
        "Ready. No glass on left, and this object could not measure it: type it under **Mirrors › "
        "Rename, glass, "
        "remove, clear**."
    )
    assert start_hint(done, TabState(mirror_id=1), True, True, glass_unused=("left",)) == (
        "The glass typed in for left is not in its plane yet: **Mirrors › Fit plane** moves it "
        "behind the glass."
    )
    assert start_hint(done, TabState(mirror_id=1), True, True, "paused").startswith("Paused: ")
    assert start_hint(
        done, TabState(mirror_id=1), True, True, "recording", start="session gait"
    ).endswith(
        "**Back to session gait** (above) when done."
    )
    # 'the live source' while a
    # session played)
    marked = replace(done.mirrors[0], plane=None)
    assert start_hint(
        Session(tmp_path, session.camera, mirrors=(marked,)), TabState(mirror_id=1), True, True
    ) == ("left: **Fit plane**.")
    two = Session(tmp_path, session.camera, mirrors=(marked, replace(marked, name="right", id=2)))
    assert (
        start_hint(two, TabState(mirror_id=1), True, True) == "left and right: **Fit all planes**."
    )
    bare = Session(
        tmp_path,
        session.camera,
        mirrors=(done.mirrors[0], replace(marked, name="top", id=2, markers=())),
    )
    assert start_hint(bare, TabState(mirror_id=1), True, True) == (
        "Now top: select it and do the same (no markers: click 3 or more, or **Find the planes "
        "from the object**)."
    )
    assert start_hint(bare, TabState(mirror_id=1), True, True, refused={2: "scene"}) == (
        "Now top: not found from the object (why: under Mirrors); or select it and click 3 or more "
        "markers on it."
    )
    outline = Session(
        tmp_path,
        session.camera,
        mirrors=(done.mirrors[0], replace(marked, name="top", id=2, markers=(), boundary=())),
    )
    assert start_hint(outline, TabState(mirror_id=1), True, True) == (
        "Now top: select it, choose **Boundary** and click its corners."
    )
    drafted = TabState(mirror_id=2, view="depth", drafts={2: ((1.0, 1.0), (9.0, 1.0))})
    assert (
        start_hint(outline, drafted, True, True)
        == "top: 2 corners drawn; choose **Boundary** and click the next."
    )
    drafted = replace(drafted, mode="boundary", drafts={2: ((1.0, 1.0), (9.0, 1.0), (9.0, 9.0))})
    assert (
        start_hint(outline, drafted, True, True)
        == "top: 3 corners drawn; click the next, or the first to close."
    )
    assert start_hint(done, TabState(mirror_id=1), True, True, recording=True).startswith(
        "Recording (see above)"
    )
    # calibrate --method
    unmarked = Session(tmp_path, session.camera, mirrors=(replace(done.mirrors[0], markers=()),))
    # scene: no markers
    assert start_hint(unmarked, TabState(mirror_id=1), True, True).startswith("Ready: ")
    # flagged mirrors before "Ready" (it read so under three flagged mirrors, their note closed: a
    assert start_hint(done, TabState(mirror_id=1), True, True, disagreeing=("left", "right")) == (
        "⚠ left and right: their views disagree with the others (why: under *Mirrors*): "
        "**Mirrors › Refine from the object**, or fit again."
    )
    assert start_hint(done, TabState(mirror_id=1), True, True, disagreeing=("left",)).startswith(
        "⚠ left: its view disagrees with the others"
    )


def test_a_progress_bar_is_given_tenths_of_a_percent():
    assert (
        JobProgress("refine", 0.55, "").percent == 55.0
        and JobProgress("refine", 0.12345, "").percent == 12.3
    )
    assert JobProgress("refine", None, "done").percent == 0.0


def line(name, found, by_markers=True):
    """An agreement line's message (headline and details) for one mirror's figures."""
    return agreement_line(MirrorAgreement(name, found, by_markers))


def test_a_refined_mirrors_line_says_no_sign_for_a_shift_that_rounds_to_nothing():
    """Beside the details' "-0.02 mm", the headline says "moved 0.0 mm", not "+0.0"."""
    assert calibration_words.mirror_line(
        refined(shift_mm=-0.02, tilt_deg=0.05), False
    ).headline.startswith("**left** refined: moved 0.0 mm and 0.05°;")
    said = calibration_words.mirror_line(refined(shift_mm=-1.47, tilt_deg=0.05), False)
    assert said.headline.startswith("**left** refined: moved -1.5 mm and 0.05°;")
    assert "Moved -1.47 mm (> 0: away from the camera) and 0.050°." in said.details
    # typed in: kept, said so
    typed = calibration_words.mirror_line(refined(glass_typed=0.003), False)
    assert (
        "Markers 0.5 ± 1.2 mm in front of the refined plane; its glass stays 3.0 mm, as typed in."
        in typed.details
    )
    sphere = CalibrationReport(
        (refined(sphere_radius_mm=115.0),), False, "sphere", True, FramesUsed((0,))
    )
    # no glass advice from a sphere
    head = calibration_words.headline(sphere)
    assert (
        head.headline
        == "Planes refined from the sphere's centres. Undo restores the previous planes."
    )
    assert "Beyond the 1σ of each plane, the method may add 0.3 mm and 0.04°." in head.details
    found = calibration_words.mirror_line(refined(sphere_radius_mm=115.0), True)
    assert (
        found.headline.startswith("**left** found: its view agrees")
        and "moved" not in found.headline
    )
    assert any("from the centres of the sphere (radius 115.0 mm)" in d for d in found.details)


def test_a_mirror_that_no_other_view_overlaps_is_said_so_not_nan():
    said = line("left", ViewAgreement(1.234, -0.16, 1200, 1.3))
    assert said.headline == "left: agrees with the other views as the depth noise explains."
    assert said.details == (
        "1.2 mm RMS on one frame; the depth noise there 1.3 mm; mean -0.2 mm "
        "over 1,200 points "
        "seen both ways.",
    )
    assert (
        "1.2 mm RMS over 5 frames;"
        in line("left", ViewAgreement(1.234, -0.16, 1200, 1.3, frames=5)).details[0]
    )
    nan = float("nan")
    assert (
        "put the object in view to check it"
        in line("left", ViewAgreement(nan, nan, 0, nan)).headline
    )


def test_a_mirror_seen_too_little_by_the_others_is_not_judged():
    """Fewer comparisons than fix a plane in the refinement judge nothing; few with the camera leave
    the judgement to those with the mirrors."""
    few = line("left", ViewAgreement(30.0, -9.0, 150, 11.7, 30.0, -9.0, 9.0, 26, frames=5))
    assert few.headline.startswith(
        "left: too little is seen both in it and by another view to judge its plane"
    )
    assert few.details[0].startswith("150 points seen both ways over 5 frames, 200 needed")
    # the middle mirror of an arc
    arc = ViewAgreement(10.0, 0.5, 7565, 11.7, 30.0, -9.0, 9.0, 42, frames=5)
    assert line("middle", arc).headline.startswith("middle: agrees with the other views")
    off = line("middle", arc._replace(mean_mm=-4.0))
    assert (
        off.headline
        == "middle: ⚠ disagrees with the other mirrors: a plane is off. Refine from the object."
    )
    assert off.details[0] == (
        "Its points lie -4.0 mm from theirs on average (good planes within "
        "3.5 mm); RMS "
        "10.0 mm against 11.7 mm of depth noise; 7,565 points seen both ways "
        "over 5 frames."
    )


def test_a_mirror_that_agrees_worse_than_the_noise_is_flagged_and_the_one_at_fault_singled_out():
    """The comparisons with the camera single out the mirror at fault; one that agrees with the
    camera but not with another mirror says so instead of being told to fix itself."""
    good_camera = dict(
        camera_rms_mm=5.0, camera_mean_mm=0.5, camera_noise_mm=9.0, camera_points=800
    )
    tilted = line("left", ViewAgreement(12.0, 3.0, 900, 11.7, 8.0, -4.0, 9.0, 800))  # 0.44 x 9 mm
    assert tilted.headline == (
        "left: ⚠ disagrees with the camera: its plane may be tilted or its "
        "boundary off. "
        "Refine from the object, or check its markers."
    )
    assert tilted.details == (
        "Its points lie -4.0 mm from the camera's surface on average (good "
        "planes within "
        "3.6 mm); RMS 8.0 mm, the depth noise 9.0 mm; 800 points seen both "
        "ways on one "
        "frame.",
    )
    assert (
        "RMS 9.04 mm, the depth noise 9.00 mm"
        in line("left", ViewAgreement(10.0, 0.5, 900, 11.7, 9.04, 0.5, 9.0, 800)).details[0]
    )
    # the mean: 0.34 x
    neighbour = line("right", ViewAgreement(10.1, -4.0, 900, 11.7, **good_camera))
    assert neighbour.headline == (
        "right: ⚠ agrees with the camera, not with the other mirrors: a "
        "plane is off "
        "along its normal. Refine from the object."
    )
    assert neighbour.details[0].startswith(
        "Its points lie -4.0 mm from theirs on average (good planes within 3.5 mm); RMS 10.1 mm"
    )
    assert "Against the camera: mean +0.5 mm." in neighbour.details
    assert neighbour.details[-1].endswith(
        "markers on glass put it that much too near (set each mirror's glass and fit again)."
    )
    # a plane found from the object is not sent to its markers or its glass
    assert line(
        "left", ViewAgreement(12.0, 3.0, 900, 11.7, 8.0, -4.0, 9.0, 800), False
    ).headline.endswith("Refine from the object, or check its boundary.")
    found = line("right", ViewAgreement(10.1, -4.0, 900, 11.7, **good_camera), False)
    assert found.details[-1].endswith("a plane is off along its normal.")
    assert (
        "RMS 15.2 mm against 11.7 mm of depth noise"
        in line("right", ViewAgreement(15.2, 0.4, 900, 11.7, **good_camera)).details[0]
    )
    assert line("right", ViewAgreement(10.1, -3.0, 900, 11.7, **good_camera)).headline.startswith(
        "right: agrees with the other views"
    )
    # without figures against the camera alone, all the comparisons are judged together
    assert (
        "⚠ disagrees with the other mirrors: a plane is off"
        in line("right", ViewAgreement(15.2, 0.4, 900, 11.7)).headline
    )


def test_every_message_of_the_wording_has_a_short_headline():
    """Every agreement line above, the refinement's report and the next-step hints lead with a
    headline of at most HEADLINE_WORDS words."""
    figures = [
        ViewAgreement(1.234, -0.16, 1200, 1.3),
        ViewAgreement(float("nan"), float("nan"), 0, float("nan")),
        ViewAgreement(30.0, -9.0, 150, 11.7, 30.0, -9.0, 9.0, 26, frames=5),
        ViewAgreement(12.0, 3.0, 900, 11.7, 8.0, -4.0, 9.0, 800),
        ViewAgreement(10.1, -4.0, 900, 11.7, 5.0, 0.5, 9.0, 800),
        ViewAgreement(15.2, 0.4, 900, 11.7),
    ]
    messages = [line("mirror 12", f, by) for f in figures for by in (True, False)]
    mirrors = (
        refined("mirror 1"),
        refined("mirror 2", 1, agreement_after_mm=2.0),
        refined("mirror 3", 2),
    )
    for search in (False, True):
        for changed in (False, True):
            report = CalibrationReport(
                mirrors,
                search,
                "surfaces",
                changed,
                FramesUsed((0, 3, 6, 9), 10),
                (NotFound("mirror 4", "its image spills over the outline"),),
            )
            messages += [
                *calibration_words.report(report),
                calibration_words.note(report),
                calibration_words.undone(report, "Undone"),
            ]
    messages.append(calibration_words.disagreement_note(("mirror 1", "mirror 2", "mirror 3")))
    for message in messages:
        assert words(message.headline) <= HEADLINE_WORDS, message.headline


def test_every_next_step_hint_is_short(tmp_path):
    """The 'Start here' line at every stage of two mirrors is at most HEADLINE_WORDS words."""
    plane = Plane.from_abcd([0.0, 0.0, -1.0, 2.0])
    outline = ((0, 0), (9, 0), (0, 9))
    bare = (SessionMirror("mirror 1", id=1), SessionMirror("mirror 2", id=2))
    drawn = tuple(replace(m, boundary=outline) for m in bare)
    marked = tuple(replace(m, markers=((1, 1), (5, 1))) for m in drawn)
    ready = tuple(replace(m, markers=((1, 1), (5, 1), (1, 5))) for m in drawn)
    done = tuple(replace(m, plane=plane) for m in ready)
    names = ("mirror 1", "mirror 2")
    hints = []
    for mirrors in ((), bare, drawn, marked, ready, done, (done[0], drawn[1]), (done[0], bare[1])):
        session = Session(tmp_path, Intrinsics.kinect_v1(), mirrors)
        for state in (TabState(mirror_id=1), TabState(mirror_id=2, drafts={2: ((1.0, 1.0),) * 3}),
                      TabState(mirror_id=1, proposal_for=names)):
            for refused in ({}, {1: "scene", 2: "scene"}, {1: "refine"}):
                hints += [start_hint(session, state, True, background, playback, None, False, names,
                                     (), refused, "session gait", None, disagreeing, names)
                          for background in (False, True)
                          for playback in ("live", "paused", "recording")
                          for disagreeing in ((), names)]
        hints.append(start_hint(session, TabState(mirror_id=1), True, True, glass_unused=names))
        hints.append(start_hint(session, TabState(mirror_id=1), True, True, calibrating=0.45))
        hints.append(start_hint(session, TabState(mirror_id=1), True, True, batch=0.5))
    for hint in set(hints):
        assert words(hint) <= HEADLINE_WORDS, hint


def test_a_fit_that_most_points_miss_is_flagged():
    """Measure fits a sphere to whatever is selected: on a walking person most points miss it, and
    the report says so above the numbers; on a sphere it does not."""
    rng = np.random.default_rng(3)
    directions = rng.normal(size=(3000, 3))
    sphere = 0.115 * directions / np.linalg.norm(directions, axis=1, keepdims=True) + [0, 0, 2]
    good = fit_sphere(sphere, rng, threshold=0.02)
    assert not fit_report(good, str).startswith("⚠")
    clutter = rng.uniform(-1, 1, (6000, 3)) + [0, 0, 2]
    poor = fit_sphere(np.vstack([sphere, clutter]), rng, threshold=0.02)
    assert fit_report(poor, str).startswith(
        "⚠ only "
    ) and "the object may not be a sphere" in fit_report(poor, str)
    seen = sphere[sphere[:, 2] < 2.0] + rng.normal(
        scale=0.003, size=(int((sphere[:, 2] < 2.0).sum()), 3)
    )
    # Kinect-like noise, a tight band: still no warning
    tight = fit_sphere(seen, rng, threshold=0.005)
    assert not fit_report(tight, str).startswith("⚠"), fit_report(tight, str)
    # a cylinder on a sphere: most points in the band, spread
    wrong = fit_cylinder(seen, rng, threshold=0.02)
    assert fit_report(wrong, str).startswith("⚠ the points scatter"), fit_report(wrong, str)


def test_opening_a_recorded_session_plays_it_unless_a_camera_is_live():
    """Over the simulator the recording's frames play (its mirrors belong to them); a live camera
    stays, to be used with the opened session's calibration; the Record step's replay plays them
    anyway."""
    recorded = load_session(Path(__file__).resolve().parents[1] / "sessions" / "demo")
    simulator = demo_source()
    app = MirrorscanApp(
        calibrated_session(simulator, Path("unused")), simulator, port=0, autosave=False
    )
    try:
        app.open_session(recorded)
        assert app.source.frame_count == len(recorded.frames)
        app.pause(True)  # the replay paused on a frame ...
        # ... then the header's "Back to ..." button
        app.back_to_start_source()
        # live plays
        assert app.source is simulator and app.editor.session is recorded and not app.paused
        camera = StackSource(
            "camera",
            simulator.intrinsics,
            np.ones((2, *simulator.intrinsics.shape)),
            1.0,
            np.arange(2.0),
        )
        camera.frame_count = None  # live: no frame count, no seeking
        assert camera.camera and simulator.live and not simulator.camera
        app.use_source(camera)
        app.open_session(recorded)
        assert app.source is camera
        app.open_session(recorded, play=True)
        assert app.source.frame_count == len(recorded.frames)
    finally:
        app.stop()


def test_a_job_says_its_last_word_once_it_is_over():
    """The last status of a job (done, cancelled, refused) arrives once the job is not
    running: the button it enables starts the next one at once, never 'already running'."""
    bus = EventBus()
    jobs = Jobs(None, lambda: None, bus)
    ended: list[tuple[str, bool]] = []
    bus.subscribe(
        JobProgress, lambda e: e.fraction is None and ended.append((e.status, jobs.running("x")))
    )

    def cancelled(cancel):
        raise Cancelled("x")

    def refused(cancel):
        raise MirrorscanError("no frame yet")

    for work in (lambda cancel: BackgroundCaptured(3), cancelled, refused):
        jobs._start("x", work, "busy").join(10)
    assert ended == [
        ("captured from 3 frames", False),
        ("cancelled", False),
        ("not done: no frame yet", False),
    ]


def test_a_glass_measured_as_0_is_not_said_to_be_missing(tmp_path):
    """After a refinement measured 0.0 ± 0.8 mm, the mirror's line said 'measured' and the next step
    'No glass set' (the demo at 1024x600)."""
    plane = Plane.from_abcd([0.5, 0.0, -0.8, 2.4])
    mirrors = (
        SessionMirror("left", ((1.0, 1.0),) * 3, plane=plane, id=1),
        SessionMirror("right", ((1.0, 1.0),) * 3, plane=plane, id=2, marker_offset_std=8e-4),
    )
    jobs = SimpleNamespace(from_object=lambda mirror_id, plane: False)
    assert _no_glass(jobs, Session(tmp_path, Intrinsics.kinect_v1(), mirrors)) == ("left",)


def test_the_frames_a_calibration_used_are_said_plainly():
    """A recording's only frame, one frame, several frames, the last live frames."""
    assert frames_used(FramesUsed((0,), 1)) == "the recording's only frame"
    assert (
        frames_used(FramesUsed((3,), 8))
        == "frame 3 of the recording's 8 (numbered as in the header)"
    )
    assert frames_used(FramesUsed((0, 4, 9), 10)) == (
        "frames 0, 4, 9 of the recording's 10 (numbered as in the header)"
    )
    assert frames_used(FramesUsed((0, 1, 2, 3, 4))) == "the last 5 live frames"
    assert frames_used(FramesUsed((0,))) == "the last live frame"


def test_planes_fitted_behind_the_glass_typed_in_are_sent_to_the_refinement(tmp_path):
    """The glass typed in, a markers fit applied over a plane from the object: its report asked to
    refine again and the next step read "Ready". The next step names the mirrors whose
    planes a markers fit of this tool set behind a glass typed in; not those from the object, those
    fitted elsewhere, nor a glass measured."""
    plane = Plane.from_abcd([0.5, 0.0, -0.8, 2.4])
    mirrors = (
        SessionMirror("left", ((1.0, 1.0),) * 3, plane=plane, id=1, marker_offset=0.003),
        SessionMirror("right", ((1.0, 1.0),) * 3, plane=plane, id=2, marker_offset=0.003),
        SessionMirror("top", ((1.0, 1.0),) * 3, plane=plane, id=3, marker_offset=0.003),
        SessionMirror(
            "back",
            ((1.0, 1.0),) * 3,
            plane=plane,
            id=4,
            marker_offset=0.003,
            marker_offset_std=5e-4,
        ),
    )
    session = Session(
        tmp_path,
        Intrinsics.kinect_v1(),
        tuple(replace(m, boundary=((0, 0), (9, 0), (9, 9))) for m in mirrors),
    )
    jobs = SimpleNamespace(from_object=lambda mirror_id, plane: mirror_id == 2)
    editor = SimpleNamespace(fitted_on_its_markers=lambda mirror_id: mirror_id != 3)
    assert _from_markers(jobs, editor, session) == ("left",)
    assert start_hint(session, TabState(mirror_id=1), True, True, from_markers=("left",)) == (
        "Ready. The planes of left come from markers alone: **Mirrors › Refine from the object** "
        "makes them more "
        "accurate."
    )


def test_a_markers_fit_without_glass_says_how_to_measure_it():
    """Markers on 3 mm of glass gave a quiet all-clear: the planes were 2.4 and 4.3 mm
    too near."""

    def fit(name: str, glass: float, std: float | None = None, mirror_id: int = 1) -> Fit:
        mirror = SessionMirror(
            name, ((1.0, 1.0),) * 3, id=mirror_id, marker_offset=glass, marker_offset_std=std
        )
        calibration = SimpleNamespace(
            rms_mm=2.0, n_inliers=90, n_points=100, markers=None, marker_offset=glass
        )
        return Fit(calibration, mirror, SimpleNamespace(poor=(), tilt_deg=0.0, shift_mm=0.0))

    left, right = fit("left", 0.0), fit("right", 0.004, mirror_id=2)
    # right's waited for Apply, left's did not
    bare = markers_report(FitsApplied((left, right), confirmed=(2,)))
    assert [m.headline for m in bare] == [
        "**left**: plane fitted, 2.0 mm RMS",
        "**right**: plane fitted, 2.0 mm RMS (applied on confirmation)",
        NO_GLASS_NOTE.headline,
    ]
    assert bare[0].details == ("RMS 2.00 mm over 90/100 points.",)
    # glass set: nothing to add
    assert len(markers_report(FitsApplied((fit("left", 0.003),)))) == 1
    # 0 measured is set too
    assert len(markers_report(FitsApplied((fit("left", 0.0, 8e-4),)))) == 1


def test_the_header_names_the_session_edited_where_another_plays(tmp_path):
    """After Record's replay and Back to
    for edits of the session served, which the header named."""
    gait, recording = tmp_path / "gait", tmp_path / "recording-1"
    assert source_title("session gait", gait, gait) == "**session gait**"
    # the demo: not saved
    assert source_title("session gait", gait, None) == "**session gait**"
    assert source_title("session gait", gait, recording) == (
        "**session gait** · edits saved in session **recording-1**"
    )
    assert (
        source_title("Kinect v1", None, gait) == "**Kinect v1** · edits saved in session **gait**"
    )


def test_a_proposal_points_at_crossed_markers_only_when_a_marker_is_crossed():
    """A proposal for a plane turned 4 degrees (no poor marker) points at no crossed marker."""

    def fit(poor):
        return Fit(
            SimpleNamespace(marker_offset=0.003),
            SimpleNamespace(name="left"),
            SimpleNamespace(poor=poor),
        )

    assert fit_note([], [fit(())]).headline == (
        "A new plane for left waits, not applied: look at "
        "it under "
        "Mirrors, then Apply or Discard it."
    )
    assert "under Mirrors (the crossed markers), then" in fit_note([], [fit((2,))]).headline


def test_a_fit_of_several_mirrors_applies_those_that_need_no_look_and_proposes_the_others():
    """One mirror's stray marker does not hold back the other mirrors' planes: the note says both
    what was applied and what waits; the RMS in its details."""

    def fit(name, poor=()):
        return Fit(
            SimpleNamespace(rms_mm=2.0),
            SimpleNamespace(name=name, glass_set=True, marker_names=["3.1", "3.2"]),
            SimpleNamespace(poor=poor),
        )

    said = fit_note([fit("mirror 1"), fit("mirror 2")], [fit("mirror 3", (1,))], ("mirror 4",))
    assert said.headline == (
        "Applied: mirror 1 and mirror 2. mirror 3: a new plane waits, Apply or Discard it. mirror "
        "4: no markers, "
        "left as it is."
    )
    assert words(said.headline) <= HEADLINE_WORDS
    assert said.details[0] == "mirror 1 2.0 mm RMS, mirror 2 2.0 mm RMS."


def test_the_legend_says_which_mirrors_leave_their_part_out():
    """Before its plane a mirror's part of the frame is left out: the figure looked cut to a sliver
."""
    name = {0: "direct", 1: "left", 2: "right"}.get
    assert "no plane yet" not in legend_html({0: 1350, 1: 0}, name, (1, 2))
    one = legend_html({0: 1350, 1: 0}, name, (1, 2), ("left",))
    assert one.endswith(
        "<br>left: no plane yet, so all inside its outline is left out (the object "
        "in front "
        "too)</div>"
    )
    assert (
        "left and right: no plane yet, so all inside their outlines is left out (the object in "
        "front "
        "too)"
    ) in legend_html({0: 1350}, name, (1, 2), ("left", "right"))


def test_the_heat_maps_figures_pool_the_recent_frames_of_the_same_planes():
    """One frame's median jumped by 1 to 2 mm: the legend pools the last HEAT_POOL maps,
    and a new calibration starts afresh."""
    jobs, first, second = Jobs(None, lambda: None, EventBus()), object(), object()
    for k in range(HEAT_POOL + 3):
        pooled = jobs._pool_heat(first, k, np.full(2, float(k)), np.ones(2, int))
    assert len(pooled) == HEAT_POOL and pooled[-1][0][0] == HEAT_POOL + 2 and pooled[0][0][0] == 3
    # a replay's frame 5 again: in its
    pooled = jobs._pool_heat(first, 5, np.full(2, 50.0), np.ones(2, int))
    # place anew, not twice (it pooled
    assert len(pooled) == HEAT_POOL and pooled[-1][0][0] == 50.0
    assert sum(p[0][0] in (5.0, 50.0) for p in pooled) == 1
    # other planes: a new pool
    assert len(jobs._pool_heat(second, 0, np.zeros(2), np.ones(2, int))) == 1
    text = heat_legend_html({1: (-0.44, 0.07)}, HEAT_POOL, {1: "left"}.get)
    replay = Jobs(SimpleNamespace(source=SimpleNamespace(frame_count=12)), lambda: None, EventBus())
    # noqa: E731
    frame = lambda index, rig=first: SimpleNamespace(index=index, snapshot=SimpleNamespace(rig=rig))
    assert replay.heat_wanted(frame(3))  # nothing pooled yet
    replay._pool_heat(first, 3, np.zeros(2), np.ones(2, int))
    # frame 3 again (the loop's 2nd
    assert not replay.heat_wanted(frame(3)) and not replay.heat_wanted(frame(15))
    # round), not other planes
    assert replay.heat_wanted(frame(4)) and replay.heat_wanted(frame(3, second))
    for k in range(HEAT_POOL):
        replay._pool_heat(first, k, np.zeros(2), np.ones(2, int))
    # the pool full: any frame refreshes it
    assert replay.heat_wanted(frame(3))
    live = Jobs(SimpleNamespace(source=SimpleNamespace(frame_count=0)), lambda: None, EventBus())
    live._pool_heat(first, 3, np.zeros(2), np.ones(2, int))
    assert live.heat_wanted(frame(3))  # a camera's frames are all new
    assert (
        f"the last {HEAT_POOL} frames, against the camera's surface (> 0: outside it):<br>left: "
        "median -0.4 mm, "
        "7% of its points compared" in text
    )
    assert "this frame, against" in heat_legend_html({1: (-0.44, 0.07)}, 1, {1: "left"}.get)
    assert (
        "left: median -1.4 mm, under 1% of its points compared (it sees little of what the camera "
        "sees: its "
        "agreement under Mirrors compares it with every view)"
        in heat_legend_html({1: (-1.44, 0.004)}, 1, {1: "left"}.get)
    )
    # 7% compared: the camera checks it
    assert "compares it with every view" not in text
    # no line of its own
    multi = heat_legend_html({33: (float("nan"), 0.0)}, 1, {33: "left then right"}.get)
    assert (
        "left then right: none of its points seen by the camera (seen through several mirrors: "
        "the agreement "
        "lines of those mirrors under Mirrors check it)"
    ) in multi
    # no plane: what to do, not "computing"
    bare = heat_legend_html({}, 0, {1: "left"}.get, planes=False)
    assert "No mirror has a plane yet" in bare and "computing" not in bare
    assert text.endswith(
        "<i>A tilted plane or a wrong boundary colours a mirror's points; a glass "
        "hardly does (3 mm "
        "read 0.2 mm on the sphere): <b>Refine from the object</b> measures "
        "it.</i></div>"
    )
    # every glass set
    typed = heat_legend_html({1: (-0.44, 0.07)}, HEAT_POOL, {1: "left"}.get, no_glass=False)
    assert typed.endswith("a glass hardly does (3 mm read 0.2 mm on the sphere).</i></div>")
    refined = heat_legend_html({1: (-0.44, 0.07)}, HEAT_POOL, {1: "left"}.get, refined=True)
    assert (
        "Refine from the object" not in refined and "these planes come from the object" in refined
    )


def test_the_frame_rate_follows_a_slowdown_within_seconds():
    """30 fps, then the loop paced to 1 fps for a job: the rate reads about 1 within 3 s (the last
    30 frames' window would still read about 15 fps), and a steady rate reads as it is."""
    meter = RateMeter()
    assert meter.fps == 0.0
    for k in range(60):
        meter.tick(k / 30)
    assert meter.fps == pytest.approx(30.0)
    for k in range(1, 4):
        meter.tick(59 / 30 + k)
    assert meter.fps == pytest.approx(1.0)
    slow = RateMeter()
    for k in range(2):
        slow.tick(5.0 * k)  # one frame in 5 s: the last two still make a rate
    assert slow.fps == pytest.approx(0.2)


def test_the_first_view_follows_the_rig_until_the_technician_moves_it(demo):
    """Mirrors fitted after the page opened: the view framed the rig without them, and the figure's
    head was out of view with the camera filling half of it. While the camera is where
    the first view put it, a change of the rig frames it again; once turned, it stays where the
    technician put it."""
    app, headless = demo
    tab, editor = headless.tab, app.editor
    first = next(m for m in editor.session.mirrors if m.plane is not None)
    moved = Plane(first.plane.normal, first.plane.d + 0.3)
    assert not tab.heat
    tab.look("3d")  # the first view, in the 3D scene
    home = np.array(tab.client.camera.position)
    try:
        editor.set_planes({first.id: (moved, first)})
        wait_for(
            lambda: not np.allclose(tab.client.camera.position, home, atol=0.01),
            10,
            "the view framed again",
        )
        again = np.array(tab.client.camera.position)
        tab.client.camera.position = again + [0.5, 0.0, 0.0]  # turned by the technician
        editor.undo(first.id)
        time.sleep(0.3)  # time for a reframing that must not come
        assert np.allclose(tab.client.camera.position, again + [0.5, 0.0, 0.0])
    finally:
        if editor.mirror(first.id).plane != first.plane:
            editor.undo(first.id)
        tab.look_home()
    assert editor.mirror(first.id).plane == first.plane
