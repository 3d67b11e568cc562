"""The Dense panel (mirrorscan.panels.dense) on the simulated sphere rig, its mirrors calibrated:
the box, runs of each method shown and exported in the frames' colour, cancel, the view kept on
Run, the shading."""

import numpy as np
import pytest
import trimesh
from mirrorscan.panels.dense import DensePanel
from mirrorscan.view import beside_offset

from mirrorcore.io.ply import read_ply
from tests.app.panels.support import panel
from tests.waiting import wait_for

pytestmark = pytest.mark.steps("calibrated")


def test_the_dense_box_is_drawn_once_dense_is_used(calibrated):
    """No 'dense box' around every frame before Dense is opened: the box is drawn once Dense is used
    (Box around the current cloud, a corner typed, Run), and can be hidden."""
    app, headless = calibrated
    dense, scene = panel(headless.tab, DensePanel), headless.tab.scene
    wait_for(
        lambda: np.all(np.array(dense.high.value) > np.array(dense.low.value)),
        10,
        "the box around the cloud",
    )
    assert not dense.show_box.value and scene._box is None and scene._box_label is None
    dense.follow_cloud()
    wait_for(lambda: scene._box is not None, 30, "the box drawn")
    assert dense.show_box.value and scene._box_label is not None
    dense.show_box.value = False
    wait_for(lambda: scene._box is None, 30, "the box hidden")
    dense.show_box.value = True
    wait_for(lambda: scene._box is not None, 30, "the box shown again")


@pytest.mark.parametrize("method", ["carve (consistent)", "TSDF fusion (mesh)"])
def test_dense_runs_shows_and_exports(calibrated, method):
    app, headless = calibrated
    dense = panel(headless.tab, DensePanel)
    dense.method.value, dense.voxel.value = method, 4.0
    fuse = method.startswith("TSDF")  # only what the method uses is offered
    wait_for(
        lambda: (dense.frames.disabled, dense.threshold.disabled) == (not fuse, fuse),
        30,
        "the method's options",
    )
    dense.box_around_cloud()
    low, high = np.array(dense.low.value), np.array(dense.high.value)
    # the sphere (23 cm) and its margin
    assert np.all(high - low > 0.2) and np.all(high - low < 0.6)
    made = app.jobs.dense_result.made if app.jobs.dense_result else 0
    dense.start()
    result = wait_for(
        lambda: (
            app.jobs.dense_result
            if app.jobs.dense_result and app.jobs.dense_result.made > made
            else None
        ),
        180,
        "the dense result",
    )
    assert set(np.unique(result.sources)) <= {0, 1, 2} and len(result.vertices) > 500
    assert (result.faces is not None) == (method.startswith("TSDF"))
    # the simulated source has colour: the result carries it
    assert result.colours.shape == (len(result.vertices), 3)
    assert (
        np.median(np.abs(np.linalg.norm(result.vertices - [0.0, 0.0, 2.0], axis=1) - 0.115)) < 0.004
    )
    wait_for(lambda: headless.tab.scene._dense, what="the result drawn")
    # the view framed on the cloud and the result beside
    target = np.asarray(headless.tab.client.camera.look_at)
    beside = np.asarray(result.low) + beside_offset(result)
    assert beside[0] < target[0] < np.median(app.last_frame.cloud.points[:, 0])
    scene = headless.tab.scene
    assert scene._box is not None and scene._box_label is not None  # with its box, named
    # at its corner: a result drawn in place
    box_name = np.add(scene._box.position, scene._box_label.position)
    # has its own name at the top's middle
    top = np.array([(low[0] + high[0]) / 2, low[1], (low[2] + high[2]) / 2])
    assert np.linalg.norm(box_name - top) > 0.1
    dense.export_result()
    saved = sorted((app.editor.session.root / "exports").glob(f"dense-{result.method}-*.ply"))[-1]
    points, _ = read_ply(saved)
    assert len(points) == len(result.vertices)
    loaded = trimesh.load(saved, process=False)
    exported = loaded.visual.vertex_colors if fuse else loaded.colors
    np.testing.assert_array_equal(exported[:, :3], result.colours)


def test_dense_cancel(calibrated):
    app, headless = calibrated
    dense = panel(headless.tab, DensePanel)
    dense.method.value, dense.voxel.value = "carve (consistent)", 1.0
    dense.box_around_cloud()
    # 1 mm voxels: ~25 million, several seconds
    dense.start()
    app.jobs.cancel("dense")  # the Cancel button
    wait_for(lambda: dense.status.content == "cancelled", 120)
    assert not dense.progress.visible and not dense.run.disabled


def test_the_dense_box_follows_the_cloud_until_a_corner_is_typed(calibrated):
    """The box is put around the cloud again after the session changes (the mirrors' points come
    into place) and at Run; once the technician types a corner it stays where it is put, and runs do
    not grow it."""
    app, headless = calibrated
    dense = panel(headless.tab, DensePanel)
    dense.method.value, dense.voxel.value = "carve (consistent)", 4.0
    dense.follow_cloud()
    around = np.array(dense.low.value), np.array(dense.high.value)
    # the app's own change: still following
    dense.low.value = (-1.0, -1.0, 0.5)
    mirror = app.editor.session.mirrors[0]
    app.editor.rename_mirror(mirror.id, mirror.name)  # the session changed
    wait_for(
        lambda: np.allclose(dense.low.value, around[0], atol=0.01),
        10,
        "the box around the cloud again",
    )
    typed = (around[0] - 0.05, around[1] + 0.05)
    # as a corner typed in the page
    dense._box_edited(type("Typed", (), {"client": headless.tab.client})())
    dense.low.value, dense.high.value = tuple(typed[0]), tuple(typed[1])
    app.editor.rename_mirror(mirror.id, mirror.name)
    for _ in range(2):
        wait_for(lambda: not app.jobs.running("dense"), 60, "the dense job's end")
        made = app.jobs.dense_result.made if app.jobs.dense_result else 0
        dense.start()
        wait_for(
            lambda: app.jobs.dense_result and app.jobs.dense_result.made > made, 180, "the carving"
        )
        wait_for(lambda: np.allclose(dense.low.value, app.jobs.dense_result.low), 10, "the fields")
        np.testing.assert_allclose(dense.low.value, typed[0], atol=1e-9)  # where it was typed ...
        # ... to the whole voxel, no more
        assert np.all(np.array(dense.high.value) - typed[1] < 0.004 + 1e-9)
    dense.follow_cloud()


def test_run_keeps_the_view_the_technician_turned(dense_shown):
    """The first result is framed; a later Run keeps a view the technician turned, and Look at the
    dense result frames it again on request."""
    app, headless = dense_shown
    dense = panel(headless.tab, DensePanel)
    camera = headless.tab.client.camera
    wait_for(lambda: not app.jobs.running("dense"), 60, "the dense job's end")
    assert not dense.look.disabled
    # turned by the technician
    turned = np.asarray(camera.position) + [0.4, -0.2, 0.1]
    camera.position = tuple(turned)
    target = np.asarray(camera.look_at)
    made = app.jobs.dense_result.made
    dense.start()
    wait_for(lambda: app.jobs.dense_result.made > made, 180, "the second carving")
    wait_for(lambda: not app.jobs.running("dense"), 60, "the dense job's end")
    assert np.allclose(camera.position, turned) and np.allclose(camera.look_at, target)
    dense.look_at_result()
    assert not np.allclose(camera.position, turned, atol=0.01)


def test_a_carving_is_drawn_shaded_by_its_outward_normals(dense_shown):
    """The carved sphere's points carry outward normals and are drawn in varied shades."""
    app, headless = dense_shown
    result = app.jobs.dense_result
    assert result.normals is not None and result.normals.shape == result.vertices.shape
    outward = result.vertices - np.array([0.0, 0.0, 2.0])
    outward /= np.linalg.norm(outward, axis=1)[:, None]
    assert np.mean(np.einsum("ij,ij->i", result.normals, outward) > 0.7) > 0.9
    node = headless.tab.scene._dense[1]
    grey = np.asarray(node.colors, float).mean(axis=1)
    assert node.colors.shape == (len(result.vertices), 3) and grey.std() > 15
