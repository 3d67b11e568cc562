"""The browser tool's panels without a browser, on the simulated sphere rig: background capture, plane fitting,
measuring, exporting, save as and open, and how refusals reach the user."""
import time

import numpy as np
import pytest

from app.server import MirrorscanApp
from mirrorcore.errors import MirrorscanError
from mirrorcore.ply import read_ply
from mirrorcore.session import Session, load_session
from mirrorcore.sim.export import session_mirrors
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import SimulatedSource


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    rig = Simulator(paper_scene(object="sphere"), seed=1, fps=15.0)
    root = tmp_path_factory.mktemp("panels") / "scan"
    app = MirrorscanApp(Session(root, rig.intrinsics), SimulatedSource(rig), port=0, sessions_dir=root.parent)
    app.loop.start()
    deadline = time.monotonic() + 30
    while app.last_frame is None:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    yield app
    app.stop()


def test_background_capture_with_the_object_out_of_view(app):
    app.source.objects_in_view = False
    try:
        app.selection_panel.capture_background(3)
    finally:
        app.source.objects_in_view = True
    session = app.editor.session
    assert session.background == "background.png"
    saved = load_session(session.root).read_background()
    np.testing.assert_allclose(saved, app.state.current.background, atol=0.0006)   # 1 mm units on disk
    assert not app.selection_panel.progress.visible and "captured" in app.selection_panel.background.content


def test_calibrate_both_mirrors_and_measure(app):
    rig = app.source.rig
    for j, mirror in enumerate(session_mirrors(rig, rig.background().truth)):
        app.editor.add_mirror()
        for uv in mirror.markers:
            app.editor.add_marker(j, uv)
        for uv in mirror.boundary:
            app.editor.add_vertex(j, uv)
        app.editor.close_boundary(j)
    time.sleep(0.5)                                     # a few frames for the median
    app.mirrors_panel.fit_planes(range(2))
    for fitted, true in zip(app.editor.session.mirrors, rig.planes):
        assert fitted.plane.angle_to(true) < 1.0 and abs(fitted.plane.d - true.d) < 0.01
    assert "worst marker" in app.mirrors_panel.result.content
    time.sleep(0.5)                                     # frames with the new rig
    fit = app.measure_panel.fit_current()
    assert abs(fit.shape.radius - 0.115) < 0.003
    assert "mirror 2" in app.measure_panel.report.content and app.measure_panel.plot.visible


def test_export_saves_beside_the_session(app):
    saved = app.files_panel.export_cloud(None)
    points, sources = read_ply(saved)
    assert saved.parent.name == "exports" and len(points) > 1000 and set(np.unique(sources)) == {0, 1, 2}


def test_refusals_become_notifications(app, monkeypatch):
    said = []
    monkeypatch.setattr(app, "notify", lambda client, title, message: said.append(message))
    app.act(None, lambda: app.editor.add_marker(0, (9999, 1)))
    app.act(None, lambda: app.editor.close_boundary(0))
    assert said == ["pixel (9999, 1) is outside the 640x480 image",
                    "mirror 1: no open boundary to close; click its corners first"]


def test_save_as_and_open(app):
    app.files_panel.new_name.value = "../escape"
    with pytest.raises(MirrorscanError, match="session name '../escape'"):
        app.files_panel._save_as()
    app.files_panel.new_name.value = "copy 1"
    app.files_panel._save_as()
    copy = app.sessions_dir / "copy 1"
    assert app.editor.session.root == copy and (copy / "background.png").is_file()
    assert load_session(copy).mirrors == app.editor.session.mirrors
    app.files_panel.refresh()
    assert set(app.files_panel.open_choice.options) == {"scan", "copy 1"}
    app.files_panel.open_choice.value = "scan"
    app.files_panel._open()
    assert app.editor.session.root.name == "scan"


@pytest.mark.parametrize("method", ["carve (consistent)", "TSDF fusion (mesh)"])
def test_dense_runs_shows_and_exports(app, method):
    panel = app.dense_panel
    panel.method.value, panel.voxel.value = method, 4.0
    panel.box_around_cloud()
    low, high = np.array(panel.low.value), np.array(panel.high.value)
    assert np.all(high - low > 0.2) and np.all(high - low < 0.6)        # the sphere (23 cm) and its margin
    panel.result = None
    panel.start().join(timeout=120)
    assert panel.result is not None, panel.status.content
    vertices, sources, faces = panel.result
    assert set(np.unique(sources)) <= {0, 1, 2} and len(vertices) > 500
    assert (faces is not None) == (method.startswith("TSDF"))
    centre = np.array([0.0, 0.0, 2.0])
    assert np.median(np.abs(np.linalg.norm(vertices - centre, axis=1) - 0.115)) < 0.004
    saved = app.files_panel.export_dense(None)
    points, labels = read_ply(saved)
    assert len(points) == len(vertices)


def test_dense_cancel(app):
    panel = app.dense_panel
    panel.method.value, panel.voxel.value = "carve (consistent)", 1.0
    panel.box_around_cloud()
    thread = panel.start()                                # 1 mm voxels: ~25 million, several seconds
    panel._cancel.set()                                   # the Cancel button
    thread.join(timeout=120)
    assert panel.status.content == "cancelled" and not panel.progress.visible and not panel.run.disabled


def test_record_then_replay_with_the_calibration(app):
    panel = app.record_panel
    panel.start()
    start = app.loop.index
    deadline = time.monotonic() + 30
    while app.loop.index < start + 6:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    recorded = panel.stop()
    assert len(recorded.frames) >= 4 and len(recorded.timestamps) == len(recorded.frames)
    saved = load_session(recorded.root)
    assert saved.mirrors == app.editor.session.mirrors and saved.background == "background.png"
    first = saved.read_frame(0)
    panel.play_recording()
    assert app.source.frame_count == len(recorded.frames) and app.live_panel.seek.visible
    assert app.editor.session.root == recorded.root
    app.loop.pause(True)
    time.sleep(0.3)
    app.loop.seek(0)
    app.loop.step()
    deadline = time.monotonic() + 30
    while app.last_frame.index != 0:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    np.testing.assert_array_equal(app.last_frame.depth, first)        # the replay gives the recorded frame back
    app.loop.pause(False)
