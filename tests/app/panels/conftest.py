"""The session states the panels' tests start from, each module with an app of its own: on the
simulated sphere rig, `background` (the background captured with the object out of view),
`calibrated` (then both mirrors calibrated by clicking their outlines and markers, and fitted) and
`dense_shown` (then a dense result shown); on the demo, `demo_refined` (its planes refined from
the object)."""
import numpy as np
import pytest
from mirrorscan.panels.dense import DensePanel

from tests.app.panels.support import calibrate_by_clicking, capture_background, panel
from tests.waiting import wait_for


@pytest.fixture(scope="module")
def background(sphere):
    """(app, HeadlessTab) on the sphere rig, the background captured with the object out of view."""
    app, headless = sphere
    capture_background(app, headless, objects_in_view=False)
    wait_for(lambda: app.snapshot.background is not None and app.snapshot.session.background)
    wait_for(lambda: app.last_frame.mask.sum() > 5000, what="the sphere selected")
    return sphere


@pytest.fixture(scope="module")
def calibrated(background):
    """(app, HeadlessTab) on the sphere rig, the background captured and both mirrors calibrated
    by clicking and fitting, the live cloud through both mirrors, the tab showing the 3D view."""
    app, headless = background
    calibrate_by_clicking(app, headless.tab)
    for fitted, true in zip(app.editor.session.mirrors, app.source.rig.planes):
        assert fitted.plane.angle_to(true) < 1.0 and abs(fitted.plane.d - true.d) < 0.01

    def through_the_fitted_mirrors() -> bool:
        frame = app.last_frame
        return frame.snapshot.session.mirrors == app.editor.session.mirrors and set(
            np.unique(frame.cloud.sources)
        ) == {0, 1, 2}

    wait_for(through_the_fitted_mirrors, 30, "a cloud through both fitted mirrors")
    headless.tab.look("3d")
    return background


@pytest.fixture(scope="module")
def dense_shown(calibrated):
    """(app, HeadlessTab) on the sphere rig, calibrated, then a dense result (carving, 4 mm voxels)
    run and shown."""
    app, headless = calibrated
    dense = panel(headless.tab, DensePanel)
    dense.method.value, dense.voxel.value = "carve (consistent)", 4.0
    dense.box_around_cloud()
    dense.start()
    wait_for(lambda: app.jobs.dense_result is not None, 180, "the dense result")
    wait_for(lambda: headless.tab.scene._dense, what="the result drawn")
    return calibrated


@pytest.fixture(scope="module")
def demo_refined(demo):
    """(app, HeadlessTab) on the built-in demo, a frame processed and its planes refined from the
    object (so a markers fit replaces planes from the object)."""
    app, _ = demo
    app.loop.run_once()
    app.jobs.start_refine(app.editor).join(120)
    assert all(app.jobs.from_object(m.id, m.plane) for m in app.editor.session.mirrors)
    return demo
