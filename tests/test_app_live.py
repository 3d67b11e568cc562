"""The browser tool without a browser: the demo session is calibrated from its markers, and the live loop turns
frames into a cloud with every source, shown in the scene and the panel."""
import time
from pathlib import Path

import numpy as np
import pytest

from app.demo import calibrated_session, demo_source
from app.server import MirrorscanApp


@pytest.fixture(scope="module")
def app():
    source = demo_source()
    session = calibrated_session(source, Path("unused"))
    app = MirrorscanApp(session, source, port=0, autosave=False)
    yield app
    app.stop()


def test_demo_planes_are_calibrated_close_to_the_truth(app):
    truth = app.loop.source.rig.planes
    for mirror, true in zip(app.state.current.session.mirrors, truth):
        assert mirror.plane.angle_to(true) < 1.0
        assert abs(mirror.plane.d - true.d) < 0.01


def test_live_frames_reach_the_view(app):
    frame = app.loop.run_once()
    counts = frame.cloud.counts(2)
    assert min(counts.values()) > 1000, counts
    assert app.port > 0
    nodes = app.view._clouds
    assert sorted(nodes) == [0, 1, 2]
    shown = sum(len(h.points) for h in nodes.values())
    assert 0 < shown <= 60_000 and shown >= min(len(frame.cloud), 60_000) * 0.95
    for j, handle in nodes.items():                       # each node holds only its own source's points
        assert handle.points.dtype == np.float32
        assert len(handle.points) == pytest.approx(counts["direct" if j == 0 else f"mirror {j}"] / max(
            1, int(np.ceil(len(frame.cloud) / 60_000))), rel=0.05, abs=3)
    assert "mirror 2" in app.live_panel.legend.content
    assert app.screen.handle.image.shape == (480, 640, 3)
    assert "depth frame:" in app.live_panel.depth_range.content


def wait_for(condition, seconds=20.0):
    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.02)


def test_loop_thread_pause_and_step(app):
    app.loop.start()
    start = app.loop.index
    wait_for(lambda: app.loop.index >= start + 2)             # running
    app.loop.pause(True)
    time.sleep(0.3)                                            # let a frame in progress finish
    held = app.loop.index
    time.sleep(0.5)
    assert app.loop.index == held                              # paused: no new frames
    app.loop.step()
    wait_for(lambda: app.loop.index == held + 1)
    time.sleep(0.3)
    assert app.loop.index == held + 1                          # exactly one
    app.loop.pause(False)
    wait_for(lambda: app.loop.index >= held + 3)
    assert app.loop.rate.fps > 0


def test_depth_screen_maps_rays_to_pixels_and_back(app):
    screen = app.screen
    eye = screen.centre - [0.3, -0.2, 2.0]                            # somewhere behind the screen
    for uv in [(0.0, 0.0), (319.5, 239.5), (639.0, 479.0), (100.25, 400.75)]:
        target = screen.world_of_pixel(*uv)
        got = screen.pixel_of_ray(eye, target - eye)
        np.testing.assert_allclose(got, uv, atol=1e-9)
    assert screen.world_of_pixel(0, 0)[0] < screen.world_of_pixel(639, 0)[0]      # u grows with x: not mirrored
    assert screen.world_of_pixel(0, 0)[1] < screen.world_of_pixel(0, 479)[1]      # v grows with y (down)
    assert screen.pixel_of_ray(eye, [0.0, 0.0, -1.0]) is None                      # pointing away
    assert screen.pixel_of_ray(eye, screen.world_of_pixel(0, 0) - [0.5, 0, 0] - eye) is None   # beside it
