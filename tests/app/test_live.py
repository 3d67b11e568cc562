"""The live loop (mirrorscan.live) on the demo: calibrated planes, frames kept, the pace of the loop
with and without jobs or tabs showing the cloud, pause and step, snapshots, the frame rate meter."""
import threading
import time
from dataclasses import replace
from functools import cached_property

import mirrorscan.server as server_module
import numpy as np
import pytest
from mirrorscan.live import RECENT_FRAMES, LiveLoop, RateMeter
from mirrorscan.server import BUSY_FPS, IDLE_FPS
from mirrorscan.liveframe import process_frame
from mirrorscan.state import RAY_TABLES, Snapshot
from mirrorscan.stream import Anchors

from mirrorcore.base.errors import FileFormatError
from mirrorcore.geometry.plane import Plane
from mirrorcore.rig.colour import point_colours
from mirrorcore.rig.model import Rig
from mirrorcore.sources import DepthSource, Frame
from tests.waiting import wait_for


def test_demo_planes_are_calibrated_close_to_the_truth(demo):
    app, _ = demo
    truth = app.loop.source.rig.planes
    for mirror, true in zip(app.snapshot.session.mirrors, truth):
        assert mirror.plane.angle_to(true) < 1.0
        assert abs(mirror.plane.d - true.d) < 0.01


def test_demo_mirrors_have_their_colour_gains_within_2_percent_of_their_tints(demo):
    """The demo measures each mirror's colour gain as `mirrorscan calibrate` does."""
    app, _ = demo
    scene = app.loop.source.rig.scene
    for mirror, true in zip(app.snapshot.session.mirrors, scene.mirrors):
        assert mirror.colour_gain == pytest.approx(true.tint, rel=0.02)


def test_the_loop_gives_the_cores_to_a_calibration_from_the_object(demo):
    """While a calibration from the object runs (or a dense reconstruction, or a batch) the loop
    runs at BUSY_FPS, the header saying why."""
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


def test_a_live_frame_carries_the_colour_of_its_points(demo):
    """The simulated source gives colour: each point of the live cloud takes its pixel's colour,
    the direct view's as the camera saw it, a mirror's with the mirror's gain undone."""
    app, _ = demo
    assert app.source.has_colour
    frame = app.loop.run_once()
    cloud, image = frame.cloud, frame.colour
    assert image is not None and image.shape == (*frame.depth.shape, 3)
    assert cloud.rgb is not None and cloud.rgb.shape == (len(cloud), 3)
    seen = image.reshape(-1, 3)[cloud.pixel_index]
    direct = cloud.sources == 0
    assert direct.any() and (~direct).any()
    np.testing.assert_array_equal(cloud.rgb[direct], seen[direct])
    np.testing.assert_array_equal(
        cloud.rgb, point_colours(image, cloud.pixel_index, cloud.sources,
                                 frame.snapshot.rig.colour_correction))


def test_a_colour_gain_set_is_applied_to_the_next_frame_keeping_the_rig_tables(demo):
    """A gain set (by calibrate, the refinement or an edit) gives a rig with the new gains and the
    tables of the one before (they depend on the rays alone); the next frame's mirror points are
    divided by it. The same gains keep the rig itself."""
    app, _ = demo
    # the demo's session without its measured gains: the camera's levels pass as they are
    current = app._snapshot
    session = replace(current.session, mirrors=tuple(replace(m, colour_gain=None)
                                                     for m in current.session.mirrors))
    before = Snapshot.build(session, current.background, previous=current)
    before.rig.reflection_table
    gain = (0.5, 0.8, 1.0)
    tinted = replace(session, mirrors=(replace(session.mirrors[0], colour_gain=gain),
                                       *session.mirrors[1:]))
    after = Snapshot.build(tinted, before.background, previous=before)
    assert after.rig is not before.rig and after.rig.colour_gains[0] == gain
    assert after.rig.reflection_table is before.rig.reflection_table
    assert after.rig.inside_bits is before.rig.inside_bits
    np.testing.assert_allclose(after.rig.colour_correction[1, :3], 1 / np.array(gain), rtol=1e-6)
    np.testing.assert_array_equal(after.rig.colour_correction[2], 1.0)
    assert Snapshot.build(tinted, before.background, previous=after).rig is after.rig
    # every table the rig caches but the colour correction depends on the rays alone
    cached = {name for name, value in vars(Rig).items() if isinstance(value, cached_property)}
    assert cached - set(RAY_TABLES) == {"colour_correction"}
    frame = app.source.read(3)
    plain = process_frame(before, 3, frame, Anchors()).cloud
    gained = process_frame(after, 3, frame, Anchors()).cloud
    first = plain.sources == 1
    assert first.any()
    raw = frame.colour.reshape(-1, 3)[plain.pixel_index[first]].astype(float)
    np.testing.assert_allclose(gained.rgb[first], np.minimum(np.rint(raw / gain), 255), atol=1)
    # before the gain, the levels as the camera saw them; after it, red doubled and blue kept
    np.testing.assert_array_equal(plain.rgb[first], raw)
    dark = raw[:, 0] < 100
    assert dark.sum() > 100
    np.testing.assert_array_equal(gained.rgb[first][dark, 0], 2 * raw[dark, 0])
    np.testing.assert_array_equal(gained.rgb[first, 2], raw[:, 2])
    np.testing.assert_array_equal(gained.rgb[~first], plain.rgb[~first])


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


class _NoRate(DepthSource):
    """The demo's frames at a rate of 0 frames a second, as a TUM folder whose stamps span ±1e308
    made; its third frame fails to read."""

    def __init__(self, inner: DepthSource):
        self.inner, self.name, self.intrinsics = inner, "TUM broken", inner.intrinsics
        self.fps, self.frame_count = 0.0, None

    def read(self, i: int) -> Frame:
        if i == 2:
            raise FileFormatError("d.png: not a 16-bit PNG")
        return self.inner.read(i)


def test_the_live_thread_never_dies_on_a_sources_error(demo):
    """A rate of 0 and a frame that fails are each told once; the thread plays on past them."""
    app, _ = demo
    frames, errors = [], []
    loop = LiveLoop(_NoRate(app.source), lambda: app.snapshot, frames.append, errors.append)
    loop.start()
    try:
        wait_for(lambda: len(frames) >= 4, what="frames after the errors")
        assert loop._thread.is_alive()
    finally:
        loop.stop()
    said = {str(e) for e in errors}
    assert said == {"TUM broken: plays at 0 frames a second; played at 2 instead",
                    "d.png: not a 16-bit PNG"}
    assert len(errors) == 2
