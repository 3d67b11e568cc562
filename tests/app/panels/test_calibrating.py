"""Calibrating in the Mirrors and Measure panels on the simulated sphere rig: both mirrors by
clicking, then measuring; a stray marker refused, a bad fit only a proposal; a marker with no depth;
Fit all."""
import re
import time
from dataclasses import replace

import pytest
from mirrorscan.bench.tabs import HeadlessTab
from mirrorscan.panels.dense import DensePanel
from mirrorscan.panels.measure import CANCELLED_NOTE, MeasurePanel
from mirrorscan.panels.mirrors import MirrorsPanel
from mirrorscan.panels.session import SessionPanel
from mirrorscan.server import MirrorscanApp
from mirrorscan.wording.mirrors import NO_GLASS_NOTE

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.sessionfile import load_session, save_session
from mirrorcore.sim.export import write_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import SessionSource
from tests.app.panels.support import calibrate_by_clicking, click, panel
from tests.waiting import wait_for

pytestmark = pytest.mark.steps("background")


def test_calibrate_both_mirrors_by_clicking_and_measure(background, notes, monkeypatch):
    app, headless = background
    tab = headless.tab
    calibrate_by_clicking(app, tab, fit=False)
    kinds: list[tuple[str, bool]] = []
    # an export before the planes says what it leaves out
    said, files = notes(app, kinds), panel(tab, SessionPanel)
    wait_for(
        lambda: all(m.boundary for m in app.last_frame.snapshot.session.mirrors),
        10,
        "a frame with outlines",
    )
    files.export_cloud()
    assert said[-1].endswith(
        "; mirror 1 and mirror 2 have no plane yet: what is seen inside their "
        "outlines is not "
        "in it."
    ) and kinds[-1] == ("warning", False)
    assert "⚠ mirror 1 and mirror 2 have no plane yet" in files.exported.content
    # and so do a fit and a dense result
    measure, dense = panel(tab, MeasurePanel), panel(tab, DensePanel)
    measure.fit_current()
    assert measure.report.content.startswith(
        "⚠ mirror 1 and mirror 2 have no plane yet: what is "
        "seen inside their "
        "outlines is not in it.\n\n**sphere**"
    )
    measure.history.clear()
    dense.method.value, dense.voxel.value = "carve (consistent)", 6.0
    dense.start()
    wait_for(lambda: app.jobs.dense_result is not None, 120, "the dense result")
    assert app.jobs.dense_result.left_out == ("mirror 1", "mirror 2")
    wait_for(lambda: dense.status.content.endswith("is not in it"), 30, "said under Run")
    # (a step below starts without the box)
    dense.show_box.value = False
    panel(tab, MirrorsPanel).fit_planes([m.id for m in app.editor.session.mirrors])
    for fitted, true in zip(app.editor.session.mirrors, app.source.rig.planes):
        assert fitted.plane.angle_to(true) < 1.0 and abs(fitted.plane.d - true.d) < 0.01
    mirrors = panel(tab, MirrorsPanel)
    assert "markers: 6 good" in mirrors.result.content and mirrors.proposal is None
    # where a real rig's glass is measured
    assert mirrors.result.content.endswith(NO_GLASS_NOTE.markdown())
    wait_for(lambda: set(app.snapshot.marker_grades) == {1, 2})
    assert set(app.snapshot.marker_grades[1]) == {"good"}
    # named; one fit of both, undone together
    assert mirrors.undo.label == "Undo: planes of mirror 1 and mirror 2"
    time.sleep(0.5)  # frames with the new rig
    measure = panel(tab, MeasurePanel)
    fit = measure.fit_current()
    assert abs(fit.shape.radius - 0.115) < 0.003
    assert "mirror 2" in measure.report.content and measure.plot.visible
    # a row per source, mm in the corner
    mine = fit.per_source[2]
    row = f"| mirror 2 | {mine.points:,} | {mine.rmse * 1e3:.2f} | {mine.mean_error * 1e3:+.2f} |"
    assert row in measure.report.content
    measure.fit_current()
    # seconds since the plot's first fit
    assert len(measure.history) == 2 and measure.history[0][0] == 0.0
    measure.shape.value = "cylinder"
    measure.fit_current()
    # another shape: a plot of its own
    assert len(measure.history) == 1 and measure.history[0][0] == 0.0
    measure.shape.value = "sphere"
    fitted = measure.report.content
    # the button: on a thread, with a progress bar and Cancel
    ran = measure.start_fit()
    assert measure.run.disabled and measure.cancel.visible and measure.progress.visible
    with pytest.raises(MirrorscanError, match="a fit runs: wait for it, or cancel it"):
        measure.start_fit()
    ran.join(10)
    assert not measure.run.disabled and not measure.cancel.visible and not measure.progress.visible
    # a new plot
    assert len(measure.history) == 1 and "**sphere**: radius **11" in measure.report.content
    fit_now = measure.fit

    def waits_for_cancel(frame, progress=None, cancel=None):
        assert cancel.wait(10)
        return fit_now(frame, progress, cancel)

    monkeypatch.setattr(measure, "fit", waits_for_cancel)
    fitted, ran = measure.report.content, measure.start_fit()
    measure.cancel_fit()
    ran.join(10)
    assert measure.report.content == f"{CANCELLED_NOTE}\n\n{fitted}"
    assert len(measure.history) == 1 and not measure.run.disabled
    ran = measure.start_fit()
    measure.cancel_fit()
    ran.join(10)
    # not said twice
    assert measure.report.content == f"{CANCELLED_NOTE}\n\n{fitted}"

    def fails(frame, progress=None, cancel=None):
        raise MirrorscanError("cloud: no sphere found")

    monkeypatch.setattr(measure, "fit", fails)
    kinds: list = []
    said = notes(app, kinds)
    measure.start_fit().join(10)
    assert measure.report.content == "Not done: cloud: no sphere found" and said == [
        "cloud: no sphere found"
    ]


def test_a_stray_marker_is_refused_and_a_bad_fit_is_only_a_proposal(background, notes, monkeypatch):
    app, headless = background
    kinds: list[tuple[str, bool]] = []
    shown: list = []
    tab, said = headless.tab, notes(app, kinds, shown)
    mirrors = panel(tab, MirrorsPanel)
    tab.state.mirror_id, tab.state.mode = 2, "markers"
    before = app.editor.mirror(2)
    click(tab, (630, 470))  # beside the panel, off mirror 2
    assert said and "outside its boundary" in said[-1] and app.editor.mirror(2) == before
    # refused: red
    assert kinds[-1] == ("error", False)
    # the mode's line names where the clicks go
    mirrors.refresh()
    assert mirrors.help.content.startswith(
        "**Markers** mode: click a marker's centre on **mirror 2**"
    )
    # a marker inside the outline but clicked on the floor seen through the glass: the fit moves
    # little, but the marker disagrees with the plane beyond the noise, so the new plane waits
    # for confirmation
    bottom = max(before.boundary, key=lambda p: p[1])
    click(tab, (bottom[0] - 10, bottom[1] - 6))
    assert re.fullmatch(
        r"\d+ mm \(\d+σ\) from mirror 2's plane: off the glass \(on the object "
        r"seen in it\?\)\. "
        r"Undo takes it back; a fit would ask first\.",
        said[-1],
    ), said[-1]
    # taken, but look: orange
    assert kinds[-1] == ("warning", False)
    plane = app.editor.mirror(2).plane
    mirrors.fit_planes([2])
    # not applied
    assert mirrors.proposal is not None and app.editor.mirror(2).plane == plane
    # in view at 1024x600 too
    assert said[-1].startswith("A new plane for mirror 2 waits, not applied")
    assert kinds[-1] == ("warning", False)
    # a refinement would refine the planes it replaces
    assert mirrors.refine.disabled
    with pytest.raises(
        MirrorscanError, match="a fit from the markers waits: apply or discard it first"
    ):
        mirrors._from_object(app.jobs.start_refine)
    assert not app.jobs.running("refine") and mirrors.proposal is not None
    # the next step says so
    assert "A new plane for mirror 2 waits" in tab.header.hint.content
    assert mirrors.review.visible and "⚠" in mirrors.review.content
    stray = (2, app.editor.mirror(2).markers[-1])
    # crossed on the image, whichever mirror is selected
    assert tab.state.flagged_markers == (stray,)
    drawn: list = []
    tab.state.mirror_id = 1
    with monkeypatch.context() as patch:
        patch.setattr(tab.overlay, "draw", lambda marks, region: drawn.append(marks))
        tab._redraw_overlay()
    tab.state.mirror_id = 2
    assert [k for k, mark in enumerate(drawn[-1][1].markers) if mark.flagged] == [
        len(before.markers)
    ]
    waiting = shown[-1]
    mirrors._discard()
    assert app.editor.mirror(2).plane == plane and not mirrors.review.visible
    assert waiting.removed
    mirrors.fit_planes([2])
    # one proposal at a time
    assert mirrors.fit.disabled
    waiting = shown[-1]
    # the flagged marker deleted while the proposal is up: the proposal, fitted with it, goes,
    # and Fit plane comes back
    tab.state.picked_marker = len(before.markers)
    mirrors._delete_marker()
    assert (
        mirrors.proposal is None
        and not mirrors.review.visible
        and not mirrors.fit.disabled
        and waiting.removed
    )
    assert tab.state.flagged_markers == () and "dropped: mirror 2 changed" in mirrors.result.content
    assert app.editor.mirror(2).plane == plane
    # the marker back
    mirrors._travel(app.editor.undo)
    mirrors.fit_planes([2])
    waiting = shown[-1]
    # on confirmation
    mirrors._apply()
    assert app.editor.mirror(2).plane != plane and waiting.removed
    applied, step = app.editor.mirror(2).plane, app.editor.undo_label(2)
    # the same markers again, refitted on the frames of now: applied
    mirrors.fit_planes([2])
    # the marker named,
    assert mirrors.proposal is None and app.editor.mirror(2).plane.angle_to(applied) < 0.25
    # not asked again
    assert app.editor.undo_label(2) == step
    assert said[-1] == (
        "Applied: mirror 2; ⚠ mirror 2: markers off the plane, delete the crossed "
        "ones and fit "
        "again. The report is under Mirrors."
    )
    assert kinds[-1] == ("warning", False) and tab.state.flagged_markers == (stray,)
    assert "⚠ marker(s) 2." in mirrors.result.content
    # another marker deleted: the cross stays on the stray one
    tab.state.picked_marker = 0
    mirrors._delete_marker()
    with monkeypatch.context() as patch:
        patch.setattr(tab.overlay, "draw", lambda marks, region: drawn.append(marks))
        tab._redraw_overlay()
    assert [mark.uv for mark in drawn[-1][1].markers if mark.flagged] == [stray[1]]
    # the marker back
    mirrors._travel(app.editor.undo)
    # delete just that one
    tab.state.picked_marker = len(before.markers)
    mirrors._delete_marker()
    assert app.editor.mirror(2).markers == before.markers
    mirrors.fit_planes([2])
    assert (
        mirrors.proposal is None
        and app.editor.mirror(2).plane.angle_to(app.source.rig.planes[1]) < 1.0
    )
    assert said[-1] == "Applied: mirror 2. The report is under Mirrors."
    assert kinds[-1] == ("info", False) and not mirrors.refine.disabled


def test_a_marker_with_no_depth_under_it_is_told_at_once(background, notes, monkeypatch):
    app, headless = background
    said, mirrors = notes(app), panel(headless.tab, MirrorsPanel)
    markers = app.editor.mirror(1).markers
    # as if the camera read nothing there
    k = len(markers) - 1
    frames = app.jobs.marker_frames().copy()
    u, v = (int(round(x)) for x in markers[k])
    frames[:, v - 4 : v + 5, u - 4 : u + 5] = 0
    monkeypatch.setattr(app.jobs, "marker_frames", lambda: frames)
    # and no plane to grade on:
    monkeypatch.setattr(app, "_snapshot", replace(app.snapshot, marker_residuals={}))
    mirrors._warn_if_off(1, k)
    assert said == [
        "the camera reads nothing there in the recent frames: a fit cannot use it "
        "(click the sticker's "
        "centre; Undo takes it back)"
    ]
    mirrors._warn_if_off(1, 0)  # a good one: nothing said
    assert len(said) == 1


def test_fit_all_fits_the_mirrors_with_markers_and_names_the_others(tmp_path, notes):
    """A mirror without markers (the figure hid them) does not stop Fit all from fitting the
    others; the note names it."""
    sim = Simulator(paper_scene(object="sphere"), seed=3)
    write_session(sim, tmp_path / "half", 2, progress=False)
    session = load_session(tmp_path / "half")
    session = replace(
        session, mirrors=(session.mirrors[0], replace(session.mirrors[1], markers=()))
    )
    save_session(session)
    app = MirrorscanApp(session, SessionSource(session), port=0, sessions_dir=tmp_path)
    app.start()
    try:
        with HeadlessTab(app) as headless:
            kinds: list = []
            said = notes(app, kinds)
            wait_for(lambda: app.last_frame is not None, 30, "the first frame")
            panel(headless.tab, MirrorsPanel).fit_all_planes()
            first, second = app.editor.session.mirrors
            assert (
                first.plane is not None
                and first.plane.angle_to(sim.planes[0]) < 0.5
                and second.plane is None
            )
            assert said[-1] == (
                "Applied: mirror 1. mirror 2: no markers, left as it is. The "
                "report is under "
                "Mirrors."
            )
            assert kinds[-1][0] == "warning"
    finally:
        app.stop()


def test_fit_all_applies_the_planes_that_need_no_look_and_proposes_the_others(tmp_path, notes):
    """Mirror 2 with a marker clicked on the floor seen through its glass: its new plane waits for
    Apply, mirror 1's is applied at once; Discard leaves mirror 1's, and the report says both."""
    sim = Simulator(paper_scene(object="sphere"), seed=3)
    write_session(sim, tmp_path / "stray", 2, progress=False)
    session = load_session(tmp_path / "stray")
    second = session.mirrors[1]
    bottom = max(second.boundary, key=lambda p: p[1])
    stray = replace(second, markers=second.markers + ((bottom[0] - 10, bottom[1] - 6),))
    save_session(replace(session, mirrors=(session.mirrors[0], stray)))
    app = MirrorscanApp(
        load_session(tmp_path / "stray"), SessionSource(session), port=0, sessions_dir=tmp_path
    )
    app.start()
    try:
        with HeadlessTab(app) as headless:
            said = notes(app)
            wait_for(lambda: app.last_frame is not None, 30, "the first frame")
            mirrors = panel(headless.tab, MirrorsPanel)
            mirrors.fit_all_planes()
            first, second = app.editor.session.mirrors
            # applied
            assert first.plane is not None and first.plane.angle_to(sim.planes[0]) < 0.5
            # waits
            assert second.plane is None and list(mirrors.proposal) == [second.id]
            assert said[-1].startswith("Applied: mirror 1. mirror 2: a new plane waits")
            assert mirrors.result.content.startswith("**mirror 1**: ")
            mirrors._discard()
            assert (
                app.editor.mirror(first.id).plane == first.plane
                and app.editor.mirror(second.id).plane is None
            )
            assert mirrors.result.content.startswith("**mirror 1**: ")
            assert mirrors.result.content.endswith(
                "mirror 2: the proposed plane discarded, as before."
            )
    finally:
        app.stop()
