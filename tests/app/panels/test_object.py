"""The Object panel (mirrorscan.panels.object) on the simulated sphere rig: the background captured
with the object out of view, and with it in view used only on confirmation."""

import numpy as np
import pytest
from mirrorscan.panels.object import ObjectPanel

from mirrorcore.io.sessionfile import load_session
from tests.app.panels.support import capture_background, panel
from tests.waiting import wait_for

pytestmark = pytest.mark.steps("sphere")


def test_background_capture_with_the_object_out_of_view(sphere):
    app, headless = sphere
    capture_background(app, headless, objects_in_view=False)
    wait_for(lambda: app.snapshot.background is not None and app.snapshot.session.background)
    saved = load_session(app.editor.session.root).read_background()
    np.testing.assert_allclose(saved, app.snapshot.background, atol=0.0006)  # 1 mm units on disk
    object_panel = panel(headless.tab, ObjectPanel)
    wait_for(lambda: "captured" in object_panel.status.content)
    assert not object_panel.progress.visible


def test_a_background_captured_with_the_object_in_view_is_used_only_on_confirmation(sphere):
    app, headless = sphere
    object_panel = panel(headless.tab, ObjectPanel)
    wait_for(lambda: app.last_frame.mask.sum() > 5000, what="the sphere selected")
    good = app.snapshot.background
    capture_background(app, headless, objects_in_view=True)
    assert object_panel.confirm is not None and "answer the question" in object_panel.status.content
    # not used until confirmed
    assert app.snapshot.background is good
    object_panel.confirm.yes()  # 'Use it anyway'
    wait_for(lambda: app.last_frame.mask.sum() < 2000, what="the sphere taken for background")
    # the right way: nothing asked
    capture_background(app, headless, objects_in_view=False)
    wait_for(lambda: app.last_frame.mask.sum() > 5000, what="the sphere selected again")
