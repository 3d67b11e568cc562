"""Refine from the object on a recording or a live source with colour also measures the mirrors'
colour gains and applies them with the planes, through the editor (one undo step, saved); the
Mirrors step shows each mirror's gain. A recording without colour leaves the gains as they are."""
from dataclasses import replace

import numpy as np
import pytest
from mirrorscan.bench.tabs import HeadlessTab
from mirrorscan.panels.mirrors import MirrorsPanel
from mirrorscan.server import MirrorscanApp
from mirrorscan.wording import joined
from mirrorscan.wording.jobs import say

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.sessionfile import load_session, save_session
from mirrorcore.sim.export import write_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import SessionSource, SimulatedSource
from tests.app.panels.support import panel
from tests.waiting import wait_for

TINTS = ((0.55, 0.9, 0.75), (0.85, 0.7, 0.95))


@pytest.mark.parametrize("colour", [True, False], ids=["colour", "no-colour"])
def test_refine_from_the_object_sets_the_colour_gains_with_the_planes(tmp_path, colour):
    scene = paper_scene(object="sphere")
    scene = replace(scene, mirrors=tuple(replace(m, tint=t)
                                         for m, t in zip(scene.mirrors, TINTS)))
    folder = write_session(Simulator(scene, seed=2), tmp_path / "s", 4, progress=False,
                           true_planes=True)
    session = load_session(folder)
    if not colour:
        session = replace(session, colour_frames=None)
        save_session(session)
    app = MirrorscanApp(session, SessionSource(session), port=0, sessions_dir=tmp_path)
    app.start()
    try:
        with HeadlessTab(app) as headless:
            wait_for(lambda: app.last_frame is not None, 30, "the first frame")
            before = app.editor.session
            job = app.jobs.start_refine(app.editor)
            job.join(120)
            report = next(iter(app.jobs.refinements.values()))
            shown = joined(say(report))
            mirrors = app.editor.session.mirrors
            if not colour:
                assert report.gains is None and "colour" not in shown.lower()
                assert all(m.colour_gain is None for m in mirrors)
                return
            for m, tint in zip(mirrors, TINTS):
                np.testing.assert_allclose(m.colour_gain, tint, rtol=0.02)
            assert "Colour gain measured for mirror 1 and mirror 2" in shown
            # saved, as every edit
            saved = load_session(folder)
            assert [m.colour_gain for m in saved.mirrors] == [m.colour_gain for m in mirrors]
            # the Mirrors step shows the selected mirror's gain in its details
            tab = headless.tab
            tab.state.mirror_id = mirrors[1].id
            step = panel(tab, MirrorsPanel)
            step.refresh()
            percent = " / ".join(f"{100 * g:.0f}" for g in mirrors[1].colour_gain)
            assert f"colour {percent} %" in step.status.content
            # one undo step with the planes: undone together
            app.editor.undo(mirrors[0].id)
            assert [m.colour_gain for m in app.editor.session.mirrors] == [None, None]
            assert [m.plane for m in app.editor.session.mirrors] == [
                m.plane for m in before.mirrors]
            app.editor.redo(mirrors[0].id)
            assert app.editor.session.mirrors == mirrors
    finally:
        app.stop()


def test_refine_on_a_live_source_with_colour_measures_the_gains_on_its_last_frames(tmp_path):
    scene = paper_scene(object="sphere")
    scene = replace(scene, mirrors=tuple(replace(m, tint=t)
                                         for m, t in zip(scene.mirrors, TINTS)))
    rig = Simulator(scene, seed=3, fps=15.0)
    session = replace(load_session(write_session(rig, tmp_path / "s", 1, progress=False,
                                                 true_planes=True)),
                      frames=(), colour_frames=None)
    save_session(session)
    app = MirrorscanApp(session, SimulatedSource(rig), port=0, sessions_dir=tmp_path)
    app.start()
    try:
        with HeadlessTab(app):
            wait_for(lambda: len((app.loop.recent_frames() or ((),))[0]) >= 3, 60,
                     "three live frames")
            app.jobs.start_refine(app.editor).join(120)
            for m, tint in zip(app.editor.session.mirrors, TINTS):
                np.testing.assert_allclose(m.colour_gain, tint, rtol=0.02)
    finally:
        app.stop()


def test_gains_alone_are_one_undo_step_and_a_gain_the_session_refuses_changes_nothing(demo):
    app, _ = demo
    editor = app.editor
    first, second = editor.session.mirrors
    measured = [first.colour_gain, second.colour_gain]
    gains = {first.id: (0.8, 0.9, 0.85), second.id: (0.85, 0.8, 0.9)}
    plane_only = {first.id: (first.plane, first)}
    assert editor.set_planes(plane_only, gains=gains)
    assert [m.colour_gain for m in editor.session.mirrors] == list(gains.values())
    assert [m.plane for m in editor.session.mirrors] == [first.plane, second.plane]
    # the same again: no step
    assert not editor.set_planes(plane_only, gains=gains)
    assert editor.undo(first.id) == "colour gains of mirror 1 and mirror 2"
    assert [m.colour_gain for m in editor.session.mirrors] == measured
    # beyond what a session holds (more than all of the light, twice): refused, nothing set
    with pytest.raises(MirrorscanError, match="colour_gain"):
        editor.set_planes(plane_only, gains={first.id: (0.8, 0.9, 0.85),
                                              second.id: (2.5, 0.8, 0.9)})
    assert [m.colour_gain for m in editor.session.mirrors] == measured
