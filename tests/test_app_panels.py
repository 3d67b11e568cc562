"""The browser tool's steps without a browser, on the simulated sphere rig, through a headless tab:
background capture, both mirrors calibrated by clicking boundaries and markers, a stray marker
refused, a bad fit shown as a proposal and applied only on confirmation, measuring, exports that
never overwrite, save as and open, dense runs and cancel, record and replay, and two tabs that keep
their own click mode and mirror. The tests are the steps of one technician's session on one app (the
module's `sphere`), in order: each starts where the one before left the session (a dense run needs
the background and the mirrors of the steps before), so run the module, not a test alone."""

import logging
import re
import time
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from mirrorscan.demo import calibrated_session, demo_source
from mirrorscan.events import JobProgress
from mirrorscan.jobs import HEAT, planes_key
from mirrorscan.results import (
    AgreementReport,
    CalibrationReport,
    FramesUsed,
    MirrorAgreement,
    NotFound,
)
from mirrorcore.calibration.refine import MirrorRefinement
from mirrorcore.geometry.plane import Plane
from mirrorscan.wording import HEADLINE_WORDS, Message, joined, words
from mirrorscan.wording import refinement as calibration_words
from mirrorscan.markup import markdown
from mirrorscan.panels.dense import DensePanel
from mirrorscan.panels.measure import CANCELLED_NOTE, MeasurePanel
from mirrorscan.panels.mirrors import MirrorsPanel
from mirrorscan.wording import refusal
from mirrorscan.wording import mirrors as mirror_words
from mirrorscan.wording.mirrors import NO_GLASS_NOTE, fit_report, mirror_status
from mirrorscan.wording.jobs import dense as dense_message
from mirrorscan.panels.object import ObjectPanel
from mirrorscan.panels.record import BATCH_IDLE, RecordPanel
from mirrorscan.panels.session import SessionPanel
from mirrorscan.server import MirrorscanApp
from mirrorscan.view import HEAT_DIRECT_SIZE, beside_offset
from mirrorscan.bench.tabs import HeadlessTab
from tests.waiting import wait_for
from mirrorcore.calibration.fit import calibration_depth
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.calibration.markers import marker_residuals
from mirrorcore.base.palette import SOURCE_COLOURS
from mirrorcore.geometry.plane import Plane
from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.io.ply import read_ply
from mirrorcore.calibration.residuals import view_agreement
from mirrorcore.io.session import SessionMirror, load_session, save_session
from mirrorcore.sim.export import session_mirrors, write_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import SessionSource
from tests.conftest import sphere_app

pytestmark = pytest.mark.steps("sphere")


def panel(tab, kind):
    return next(p for p in tab.panels if isinstance(p, kind))


def click(tab, uv) -> None:
    """A click on the tab's depth frame at pixel uv (as the screen reports it)."""
    tab._clicked(float(uv[0]), float(uv[1]))


def calibrate_by_clicking(app, tab, fit: bool = True) -> None:
    """Add both mirrors and click their outlines and markers where the simulator shows them, then
    fit all (`fit`)."""
    mirrors = panel(tab, MirrorsPanel)
    rig = app.source.rig
    for truth in session_mirrors(rig, rig.background().truth):
        mirrors._add()  # Add a mirror: selects it, boundary mode
        assert tab.state.mode == "boundary" and tab.state.view == "depth"
        for uv in truth.boundary:
            click(tab, uv)
        click(tab, truth.boundary[0])  # the first corner again closes it
        assert tab.state.mode == "markers"
        for uv in truth.markers:
            click(tab, uv)
    time.sleep(0.5)  # a few frames for the median
    if fit:
        mirrors.fit_planes([m.id for m in app.editor.session.mirrors])


def capture_background(app, headless, objects_in_view: bool) -> None:
    """Capture the background from the Object step, the simulated objects in view or not."""
    app.source.objects_in_view = objects_in_view
    ended: list[str] = []  # the capture's last status, told once the job is over
    unsubscribe = app.bus.subscribe(
        JobProgress,
        lambda e: e.job == "background" and e.fraction is None and ended.append(e.status),
    )
    try:
        panel(headless.tab, ObjectPanel)._capture()
        wait_for(lambda: ended, what="the capture")
    finally:
        unsubscribe()
        app.source.objects_in_view = True


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


def test_calibrate_both_mirrors_by_clicking_and_measure(sphere, notes, monkeypatch):
    app, headless = sphere
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
    # and so do a fit and a dense result (a
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


def test_a_stray_marker_is_refused_and_a_bad_fit_is_only_a_proposal(sphere, notes, monkeypatch):
    app, headless = sphere
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
    # little, but the
    # marker disagrees with the plane beyond the noise, so the new plane waits for confirmation
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
    # crossed on the image,
    assert tab.state.flagged_markers == (stray,)
    # whichever mirror is selected
    drawn: list = []
    tab.state.mirror_id = 1
    # once it was selected)
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
    # the flagged marker deleted while the proposal is up: the
    tab.state.picked_marker = len(before.markers)
    # proposal, fitted with it, goes, and Fit plane comes back
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


def test_a_long_refusal_leads_with_a_short_headline_and_keeps_all_in_its_details():
    long = (
        "not done: mirror 1: the camera and the mirror see too little of the same surface to "
        "determine its "
        "plane (18 readings agree over 10 frame(s), 200 are needed; the 72,126 it shares with "
        "the other "
        "mirrors fix nothing, as the camera fixes none of them); refine on an object that both "
        "see from the "
        "side"
    )
    said = refusal(long, "why is in the details")
    assert said.headline == (
        "not done: mirror 1: the camera and the mirror see too little of the "
        "same surface "
        "to determine its plane; why is in the details."
    )
    assert said.details == (long,) and words(said.headline) <= HEADLINE_WORDS
    assert refusal("not done: a short one (here)").headline == "not done: a short one (here)"
    search = calibration_words.calibration_refused(long, ("mirror 1",), search=True)
    assert search.headline.startswith(
        "mirror 1 not found from the object: the planes are as they were"
    )
    assert search.details == (long,) and words(search.headline) <= HEADLINE_WORDS


def refined(name="left", index=0, **figures) -> MirrorRefinement:
    """A mirror's refinement with plausible figures (mm, degrees), `figures` replacing some."""
    plane = Plane.from_abcd([0.0, 0.0, -1.0, 2.0])
    values = dict(
        index=index,
        name=name,
        before=plane,
        after=plane,
        agreement_before_mm=1.42,
        agreement_after_mm=0.91,
        offset_before_mm=0.61,
        offset_after_mm=0.05,
        shift_mm=-2.7,
        tilt_deg=0.18,
        shift_std_mm=0.4,
        tilt_std_deg=0.02,
        agreements=5000,
        camera_agreements=5000,
        noise_mm=1.0,
        marker_offset=5e-4,
        marker_offset_std=1.2e-3,
    )
    return MirrorRefinement(**{**values, **figures})


def test_a_calibrations_headline_is_short_and_its_figures_are_in_the_details():
    used = FramesUsed((0, 1, 2, 3, 4))
    report = CalibrationReport((refined(),), False, "surfaces", True, used)
    head = calibration_words.headline(report)
    assert head.headline == (
        "Planes refined. Undo restores the previous planes. Glass measured: "
        "type it in if "
        "you know it (how: in the details)."
    )
    assert head.details[-1].startswith("Type it in under Mirrors › Rename, glass, remove, clear.")
    assert (
        "Over the last 5 live frames." in head.details
        and "A move > 0 is away from the camera." in head.details
    )
    line = calibration_words.mirror_line(report.mirrors[0], search=False)
    assert line.headline == (
        "**left** refined: moved -2.7 mm and 0.18°; its view agrees with the "
        "others as the "
        # the sign kept
        "depth noise allows."
    )
    assert (
        "RMS 1.42 mm before, 0.91 mm after; mean +0.61 mm before, +0.05 mm after; the depth "
        "noise alone "
        "gives 1.00 mm RMS."
    ) in line.details
    assert (
        "Glass: markers 0.5 ± 1.2 mm in front of the silver (saved as its glass)." in line.details
    )
    worse = calibration_words.mirror_line(refined(agreement_after_mm=1.2), search=False)
    assert (
        "⚠ its view agrees less well than the depth noise explains: check its boundary"
        in worse.headline
    )
    found = CalibrationReport(
        (refined(),),
        True,
        "surfaces",
        True,
        used,
        (NotFound("middle", "its image spills over the outline"),),
    )
    said = calibration_words.report(found)
    assert said[0].headline.startswith("Planes found; ⚠ middle not found (why below). Undo takes")
    assert said[-1].headline.startswith("**middle** ⚠ not found") and said[-1].details == (
        "its image spills over the outline",
    )
    assert calibration_words.note(found).plain.endswith("The report is under Mirrors.")
    for message in [*said, *calibration_words.report(report), calibration_words.note(report)]:
        assert words(message.headline) <= HEADLINE_WORDS, message.headline
    assert "<details><summary>Details</summary>" in said[0].markdown()


def test_a_mirrors_line_says_where_its_plane_comes_from_its_glass_and_its_markers():
    mirror = SessionMirror("left", ((10.0, 10.0),), id=3)
    assert mirror_status(None, False) == ""
    assert mirror_status(mirror, False) == "no plane yet · no glass set · 1 marker"
    placed = replace(mirror, plane=Plane.from_abcd([0.0, 0.0, -1.0, 2.0]), marker_offset=0.0042)
    assert mirror_status(placed, False) == "plane calibrated · glass 4.2 mm typed in · 1 marker"
    assert mirror_status(placed, True).startswith("plane from the object · ")
    assert mirror_status(placed, False, glass_unused=True) == (
        "plane calibrated · glass 4.2 mm typed in, not in the plane yet: **Fit plane** moves it "
        "behind the "
        "glass · 1 marker"
    )
    # measured by a refinement: with its 1 sigma
    read = replace(placed, marker_offset_std=0.0008)
    assert mirror_status(read, True) == (
        "plane from the object · glass 4.2 ± 0.8 mm measured (type it in if you know it) · 1 marker"
    )
    assert mirror_status(placed, True, glass_unused=True) == (
        "plane from the object · glass 4.2 mm typed in: the next markers fit uses it, this plane "
        "does not depend on "
        "it · 1 marker"
    )
    measured = replace(placed, marker_offset=0.0)  # no glass read (one marker): not "0.0 mm"
    assert mirror_status(measured, True) == "plane from the object · glass not measured · 1 marker"
    assert mirror_status(measured, False).startswith("plane calibrated · no glass set")
    assert mirror_status(replace(measured, markers=()), True) == "plane from the object · 0 markers"


def test_a_marker_with_no_depth_under_it_is_told_at_once(sphere, notes, monkeypatch):
    app, headless = sphere
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


def test_refine_from_the_object_and_the_heat_map(sphere, notes, caplog):
    """After the markers fit: the views' agreement is reported, 'Refine from the object' refines
    both planes on a worker and reports each mirror (agreement before and after, the change, how
    well determined), the glass in front of the silver can be set per mirror, and a tab's heat map
    shows a frame's points one colour each."""
    app, headless = sphere
    tab = headless.tab
    mirrors = panel(tab, MirrorsPanel)
    wait_for(
        lambda: "agrees with the other views" in mirrors.agreement.content, 60, "the agreement"
    )
    # each mirror under its own name,
    snapshot, depths = app.snapshot, app.loop.recent_depths()
    masks = [
        prepare_frame(snapshot.rig, d, snapshot.backdrop, snapshot.session.selection)[1]
        for d in depths
    ]
    # with its own figures, over frames
    found = view_agreement(snapshot.rig, depths, np.stack(masks))
    expected = joined(
        calibration_words.agreement(
            AgreementReport(
                tuple(
                    MirrorAgreement(m.name, found[j], True)
                    for j, m in enumerate(snapshot.session.mirrors)
                )
            )
        )
    )
    app.jobs.start_agreement(depths)
    wait_for(
        lambda: mirrors.agreement.content == expected, 60, f"the agreement to read {expected!r}"
    )
    assert expected.startswith("mirror 1: agrees") and "\n\nmirror 2: agrees" in expected
    # the figures in the fold
    assert len(depths) == 5 and expected.count("mm RMS over 5 frames") == 2
    # a good one
    assert expected.count("agrees with the other views as the depth noise explains.") == 2
    assert expected.count("<details><summary>Details</summary>") == 2
    # a tab opening now shows it too
    with HeadlessTab(app) as later:
        assert panel(later.tab, MirrorsPanel).agreement.content == expected
    before = {m.id: m.plane for m in app.editor.session.mirrors}
    # markers with no glass: the next step says so
    tab.header.refresh_hint()
    assert tab.header.hint.content.endswith(
        "No glass set on mirror 1 and mirror 2: **Mirrors › Refine from the object** measures it."
    )
    kinds: list[tuple[str, bool]] = []
    shown: list = []
    said = notes(app, kinds, shown)
    # (job, status) as each job ended
    ended: list[tuple[str, str]] = []
    app.bus.subscribe(JobProgress, lambda e: e.fraction is None and ended.append((e.job, e.status)))
    # the hint while it runs
    hints: list[str] = []
    app.bus.subscribe(
        JobProgress,
        lambda e: (
            e.job == "refine" and e.fraction is not None and hints.append(tab.header.hint.content)
        ),
    )
    # cancelled: the planes and their report as they were
    app.jobs.start_refine(app.editor)
    app.jobs.cancel("refine")
    wait_for(lambda: ("refine", "cancelled") in ended, 30, "the cancel")
    wait_for(
        lambda: mirrors.result.content.startswith("Cancelled: the planes are as they were."),
        30,
        "its report",
    )
    # no note: it was asked
    assert {m.id: m.plane for m in app.editor.session.mirrors} == before and not said
    ended.clear()
    # a second tab: told too, the server's log says it once
    other = HeadlessTab(app).__enter__()
    caplog.set_level(logging.INFO, "mirrorscan")
    app.jobs.start_refine(app.editor)
    # while it runs, Undo would take back what it refines from
    mirrors.refresh()
    assert mirrors.undo.disabled and mirrors.redo.disabled and mirrors.refine.disabled
    # it applies what it computed on the planes
    assert mirrors.fit.disabled and mirrors.fit_all.disabled
    with pytest.raises(
        MirrorscanError, match="a calibration from the object runs: wait for it, or cancel it"
    ):
        # as they were: no fit meanwhile
        mirrors.fit_planes([1])
    wait_for(
        lambda: not app.jobs.running("refine") and "refined:" in mirrors.result.content,
        120,
        "the refinement",
    )
    wait_for(lambda: not mirrors.undo.disabled, 10, "Undo back")
    assert hints and all(
        re.match(
            r"➜ A calibration from the object runs \(\d+% done\): "
            r"",
            h,
        )
        for h in hints
    )
    # by 5 %: it moves, not at every step
    assert len(set(hints)) <= 21 and len(set(hints)) > 1
    # and says what next after it
    assert "calibration from the object runs" not in tab.header.hint.content
    assert (
        tab.header.hint.content.startswith("➜ Ready: ")
        and "No glass set" not in tab.header.hint.content
    )
    # the agreement lines under the report are checked again, with the refined planes
    wait_for(
        lambda: sorted(job for job, _ in ended) == ["agreement", "refine"],
        60,
        "the agreement after it",
    )
    # (it may end before the refinement says so)
    checked = dict(ended)["agreement"]
    assert mirrors.agreement.content == checked and "agrees with the other views" in checked
    assert (
        mirrors.result.content.count("its view agrees with the others as the depth noise allows.")
        == 2
    )
    assert "The data fix it to ±" in mirrors.result.content
    assert "from the centres of the sphere" in mirrors.result.content
    # first, in a line, and told at once
    headline = mirrors.result.content.split("\n\n")[0]
    assert (
        headline == "Planes refined from the sphere's centres. Undo restores the previous planes."
    ), headline
    assert re.search(
        r"\*\*mirror 1\*\* refined: moved [+-]?\d+\.\d mm and \d+\.\d\d°; its view "
        r"agrees",
        mirrors.result.content,
    ), mirrors.result.content
    # in its details
    assert "Over the last 5 live frames." in mirrors.result.content
    # it stays: the report may be out of view
    told = f"{headline} The report is under Mirrors."
    # a note on each tab
    assert said == [told] * 2 and kinds == [("info", True)] * 2
    other.__exit__(None, None, None)
    logged = [r.getMessage() for r in caplog.records if "Planes refined" in r.getMessage()]
    assert len(logged) == 1 and logged[0].startswith(
        "refine: Planes refined from the sphere's centres"
    ), logged
    for truth, mirror in zip(app.source.rig.planes, app.editor.session.mirrors):
        assert mirror.plane != before[mirror.id]  # refined...
        # ...and still right
        assert mirror.plane.angle_to(truth) < 0.5 and abs(mirror.plane.d - truth.d) < 0.005
    # one step, from either
    assert app.editor.undo_label(1) == "refined planes of mirror 1 and mirror 2"
    refined, report = {m.id: m.plane for m in app.editor.session.mirrors}, mirrors.result.content
    # the first tab's (the other tab is closed)
    assert not shown[0].removed
    panel(tab, MirrorsPanel)._travel(app.editor.undo)
    # the refinement undone
    assert {m.id: m.plane for m in app.editor.session.mirrors} == before
    assert shown[0].removed
    # then the report of the markers fit now back
    fitted = app.jobs.fits[planes_key(app.editor.session)]
    assert mirrors.result.content == joined(
        [
            Message("Undone: the planes refined from the object for mirror 1 and mirror 2."),
            *fit_report(fitted),
        ]
    )
    panel(tab, MirrorsPanel)._travel(app.editor.redo)
    assert {m.id: m.plane for m in app.editor.session.mirrors} == refined  # and redone,
    # its report back
    assert mirrors.result.content == report
    # the markers again: shown, not applied
    mirrors.fit_planes([m.id for m in app.editor.session.mirrors])
    concerns = [c for fit in mirrors.proposal.values() for c in mirror_words.concerns(fit)]
    assert sum("it replaces the plane found from the object" in c for c in concerns) == 2, concerns
    assert {m.id: m.plane for m in app.editor.session.mirrors} == refined
    mirrors._discard()
    # a page opened (or reloaded) now shows it
    with HeadlessTab(app) as reloaded:
        assert panel(reloaded.tab, MirrorsPanel).result.content == report
    app.editor.set_marker_offset(1, 0.003)
    assert app.editor.mirror(1).marker_offset == 0.003
    tab.state.mirror_id = 1
    # the selected mirror's line: its plane, glass and markers
    mirrors.refresh()
    markers = len(app.editor.mirror(1).markers)
    assert mirrors.status.content == (
        "plane from the object · glass 3.0 mm typed in: the next "
        "markers fit uses it, "
        f"this plane does not depend on it · {markers} markers"
    )
    with pytest.raises(MirrorscanError, match="must be 0 to 50 mm, got 80 mm"):
        app.editor.set_marker_offset(1, 0.08)
    # typed in the page: refused, and the field shows
    mirrors.glass.value = -5.0
    with pytest.raises(MirrorscanError, match="must be 0 to 50 mm, got -5 mm"):
        mirrors._set_glass()
    assert mirrors.glass.value == 3.0 and app.editor.mirror(1).marker_offset == 0.003
    # the glass typed in is said as typed (the
    mirrors.fit_planes([m.id for m in app.editor.session.mirrors])
    concerns = {i: " ".join(mirror_words.concerns(fit)) for i, fit in mirrors.proposal.items()}
    assert "(the refinement moved it; the markers fit uses the glass typed in)" in concerns[1]
    assert "(the refinement moved it, and set the glass the markers fit now uses)" in concerns[2]
    # one of them changed: dropped, and fitted again as it was fitted
    app.editor.set_marker_offset(2, 0.004)
    mirrors._drop_stale_proposal()
    assert mirrors.proposal is None and mirrors.result.content == (
        "The proposal was dropped: mirror 2 changed since it was fitted. **Fit all planes** again."
    )
    app.editor.undo(2)
    # mirror 1 changed since the refinement of both: undo from mirror 2 takes
    tab.state.mirror_id = 2
    mirrors.refresh()
    assert mirrors.undo.label == "Undo: refined plane of mirror 2 only: mirror 1 changed since"
    mirrors._travel(app.editor.undo)
    assert (
        mirrors.result.content == "Undone: refined plane of mirror 2 only: mirror 1 changed since."
    )
    assert app.editor.mirror(1).plane == refined[1] and app.editor.mirror(2).plane == before[2]
    mirrors._travel(app.editor.redo)
    assert {m.id: m.plane for m in app.editor.session.mirrors} == refined
    tab.state.mirror_id = 1
    tab.look("3d")
    tab.show_heat(True)
    wait_for(lambda: "/heat" in tab.client.scene._handle_from_node_name, 60, "the heat map")
    # the camera's points smaller: the mirrors'
    nodes = tab.client.scene._handle_from_node_name
    # colours show between
    direct = wait_for(lambda: nodes.get("/heat/direct"), 10, "the camera's points")
    assert direct.point_size == pytest.approx(HEAT_DIRECT_SIZE * nodes["/heat"].point_size)
    # the camera's points in their own node only
    grey = np.asarray(SOURCE_COLOURS[0], np.uint8)
    assert len(direct.points) and np.all(direct.colors == grey)
    assert not np.all(nodes["/heat"].colors == grey, axis=1).any()
    legend = wait_for(
        lambda: "mirror 2: median" in tab.header.legend.content and tab.header.legend.content,
        10,
        "the heat map's legend",
    )
    assert "not seen by the camera" in legend and re.search(
        r"this frame, against the camera's "
        r"surface \(> 0: "
        r"outside it\):<br>mirror 1: median "
        r"[+-]\d+\.\d mm, "
        r"\d+% of its points compared",
        legend,
    )
    # refined
    assert "these planes come from the object" in legend and "Refine from the object" not in legend
    wait_for(
        lambda: "the last 2 frames, against" in tab.header.legend.content, 20, "the next map pooled"
    )
    tab.show_heat(False)
    assert "/heat" not in tab.client.scene._handle_from_node_name
    wait_for(lambda: "direct <b>" in tab.header.legend.content, 10, "the sources' legend back")
    # paused, no frame comes: the map of the frame shown, at once (the
    app.pause(True)
    time.sleep(0.3)  # a frame in progress finishes
    tab.show_heat(True)
    wait_for(
        lambda: "/heat" in tab.client.scene._handle_from_node_name, 10, "the heat map while paused"
    )
    wait_for(lambda: not app.jobs.running(HEAT) and tab._heat_event, 10, "the paused frame's map")
    # one mirror's points alone (which strip was whose could
    header = tab.header
    header._heat_choices()
    assert header.heat_of.visible and header.heat_of.options == (
        "every mirror",
        "mirror 1",
        "mirror 2",
    )
    sources = tab._heat_event.sources
    header.heat_of.value = "mirror 2"
    tab.heat_only(header._heat_mirror())
    nodes = tab.client.scene._handle_from_node_name
    assert len(nodes["/heat"].points) == np.count_nonzero(sources == 2)
    assert np.all(nodes["/heat/direct"].colors == grey) and len(
        nodes["/heat/direct"].points
    ) == np.count_nonzero(sources != 2)
    header.heat_of.value = "every mirror"
    tab.heat_only(header._heat_mirror())
    assert len(tab.client.scene._handle_from_node_name["/heat"].points) == np.count_nonzero(
        sources != 0
    )
    tab.show_heat(False)
    app.pause(False)
    # turned on in the depth view: the 3D view then frames the object, as
    tab.look("depth")
    tab.show_heat(True)
    tab.look("3d")
    points, target = app.last_frame.cloud.points, np.asarray(tab.client.camera.look_at)
    assert np.all(target > points.min(axis=0)) and np.all(target < points.max(axis=0))
    tab.show_heat(False)
    tab.look("depth")
    header.heat.value = True
    header._show_heat(ticked=True)
    assert tab.state.view == "3d" and tab.heat
    header.heat.value = False
    header._show_heat(ticked=True)
    assert tab.state.view == "3d" and not tab.heat


def test_look_at_the_object_frames_the_object_not_the_rig(sphere):
    app, headless = sphere
    tab = headless.tab
    tab.look("3d")
    home = np.linalg.norm(np.subtract(tab.client.camera.position, tab.client.camera.look_at))
    tab.look_at_object()
    points = app.last_frame.cloud.points
    target = np.asarray(tab.client.camera.look_at)
    # at the object...
    assert np.all(target > points.min(axis=0)) and np.all(target < points.max(axis=0))
    near = np.linalg.norm(np.asarray(tab.client.camera.position) - target)
    radius = np.linalg.norm(points - target, axis=1).max()
    # ...and it fills it
    assert 2 * radius < near < 5 * radius and near < home / 2


def test_exports_never_overwrite(sphere):
    app, headless = sphere
    session = panel(headless.tab, SessionPanel)
    first, second = session.export_cloud(), session.export_cloud()
    # which frame went out
    assert re.fullmatch(
        r"Live frame \d+: [\d,]+ points, saved as "
        r"`.*frame-\d{6}.*\.ply`",
        session.exported.content,
    ), session.exported.content
    assert first != second and first.parent.name == second.parent.name == "exports"
    points, sources = read_ply(first)
    assert len(points) > 1000 and set(np.unique(sources)) == {0, 1, 2}


def test_refusals_become_notifications(sphere, notes):
    app, headless = sphere
    said = notes(app)
    headless.tab.act(lambda: app.editor.add_marker(1, (9999, 1)))
    headless.tab.act(lambda: app.editor.set_boundary(1, [(1, 1), (2, 2)]))
    # a bug is told too, never a silent click
    headless.tab.act(lambda: {}["a bug"])
    assert said == [
        "pixel (9999, 1) is outside the 640x480 image",
        "mirror 1: boundary: a polygon needs at least 3 vertices, got 2",
        "KeyError: 'a bug'",
    ]


def test_two_tabs_keep_their_own_mode_and_mirror(sphere):
    app, first = sphere
    with HeadlessTab(app) as second:
        first.tab.state.mode, first.tab.state.mirror_id = "boundary", 1
        panel(second.tab, MirrorsPanel)._set_mode("inspect")
        panel(second.tab, MirrorsPanel)._select("mirror 2")
        assert first.tab.state.mode == "boundary" and first.tab.state.mirror_id == 1
        assert second.tab.state.mode == "inspect" and second.tab.state.mirror_id == 2


def test_save_as_and_open(sphere):
    app, headless = sphere
    files = panel(headless.tab, SessionPanel)
    files.new_name.value = "../escape"
    with pytest.raises(MirrorscanError, match="session name '../escape'"):
        files._save_as()
    files.new_name.value = "copy 1"
    files._save_as()
    copy = app.sessions_dir / "copy 1"
    assert app.editor.session.root == copy and (copy / "background.png").is_file()
    assert load_session(copy).mirrors == app.editor.session.mirrors
    files.refresh()
    assert files.open_choice.options == ("", "copy 1", "scan") and files.open_choice.value == ""
    # nothing chosen: nothing opens
    with pytest.raises(MirrorscanError, match="choose a session"):
        files._open()
    files.open_choice.value = "scan"
    # as the demo's: not saved, so opening asks first
    app.editor.autosave = False
    files._open()
    assert app.editor.session.root == copy and files.confirm_open is not None
    files.confirm_open.no()
    assert app.editor.session.root == copy
    files._open()
    playing = app.source
    files.export_cloud()
    # (not saved: downloaded only)
    assert files.exported.content.endswith("points, downloaded")
    files.confirm_open.yes()  # 'Open scan, discard this one'
    wait_for(lambda: app.editor.session.root.name == "scan")
    wait_for(lambda: files.exported.content == "", what="the other session's export line gone")
    # no recorded frames: the source plays on
    assert app.source is playing
    assert app.editor.session.root.name == "scan" and app.editor.autosave


def test_the_dense_box_is_drawn_once_dense_is_used(sphere):
    """No 'dense box' around every frame before Dense is opened: the box is drawn once Dense is used
    (Box around the current cloud, a corner typed, Run), and can be hidden."""
    app, headless = sphere
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
def test_dense_runs_shows_and_exports(sphere, method):
    app, headless = sphere
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


def test_dense_cancel(sphere):
    app, headless = sphere
    dense = panel(headless.tab, DensePanel)
    dense.method.value, dense.voxel.value = "carve (consistent)", 1.0
    dense.box_around_cloud()
    # 1 mm voxels: ~25 million, several seconds
    dense.start()
    app.jobs.cancel("dense")  # the Cancel button
    wait_for(lambda: dense.status.content == "cancelled", 120)
    assert not dense.progress.visible and not dense.run.disabled


def test_the_dense_box_follows_the_cloud_until_a_corner_is_typed(sphere):
    """The box is put around the cloud again after the session changes (the mirrors' points come
    into place) and at Run; once the technician types a corner it stays where it is put, and runs do
    not grow it."""
    app, headless = sphere
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


def test_record_then_replay_with_the_calibration(sphere):
    app, headless = sphere
    record = panel(headless.tab, RecordPanel)
    # the source served from the start is playing
    assert not headless.tab.header.back.visible
    record.start()
    # however loaded the machine is
    wait_for(lambda: app.jobs.recorder.frames >= 4, 60, "4 frames on disk")
    header = headless.tab.header
    wait_for(
        lambda: header.rate.content.startswith("● **recording** "), 10, "the header's recording"
    )
    assert "Recording (see above): **Record › Stop recording** saves it" in header.hint.content
    recorded = record.stop()
    wait_for(lambda: "recording" not in header.rate.content, 10, "the header without it")
    assert "Stop recording" not in header.hint.content
    assert len(recorded.frames) >= 4 and len(recorded.timestamps) == len(recorded.frames)
    saved = load_session(recorded.root)
    assert saved.mirrors == app.editor.session.mirrors and saved.background == "background.png"
    first = saved.read_frame(0)
    # of the simulator's frames
    dense, result = panel(headless.tab, DensePanel), app.jobs.dense_result
    assert result is not None and dense.show.value and headless.tab.scene._dense[0].visible
    record.play_recording()
    assert app.source.frame_count == len(recorded.frames) and headless.tab.header.seek.visible
    assert not dense.show.value and not headless.tab.scene._dense[0].visible
    assert dense.status.content == (
        f"{dense_message(result).headline}, of the frames of "
        f"{result.source}: hidden while "
        f"{app.source.name} plays (Show the dense result shows it)"
    )
    # a fit from the markers reads what `mirrorscan calibrate` reads, whenever it is clicked (it
    # read the last
    np.testing.assert_array_equal(app.jobs.marker_frames(), calibration_depth(recorded))
    # and each marker's grade reads them too (the list said
    read = calibration_depth(recorded)
    wait_for(
        lambda: (
            app.snapshot.marker_residuals
            == {
                m.id: marker_residuals(recorded.camera, read, m.markers, m.marker_plane)
                for m in app.snapshot.session.mirrors
                if m.plane is not None and m.markers
            }
        ),
        10,
        "the grades of those frames",
    )
    assert headless.tab.header.back.visible and headless.tab.header.back.label.startswith(
        "Back to "
    )
    assert app.editor.session.root == recorded.root
    app.pause(True)
    time.sleep(0.3)  # a frame in progress finishes
    # paused: the frame sought is shown at once (no step needed)
    app.seek(0)
    wait_for(lambda: app.last_frame.index == 0)
    # the replay gives the recorded frame back
    np.testing.assert_array_equal(app.last_frame.depth, first)
    app.step()  # exactly one more frame
    wait_for(lambda: app.last_frame.index == 1)
    count = len(recorded.frames)
    # the recording looped: its frame 1 again
    app.seek(count + 1)
    wait_for(lambda: app.last_frame.index == count + 1)
    wait_for(
        lambda: headless.tab.header.rate.content.startswith(f"frame 1 of {count} "),
        what="the header",
    )
    files = panel(headless.tab, SessionPanel)
    # named alike, and said
    assert files.export_cloud().name.startswith("frame-000001-")
    assert files.exported.content.startswith(f"Frame 1 of {count}: ")
    assert record.replay.disabled  # it plays: not offered again
    playing = app.source
    app.back_to_start_source()
    # its frames' source again
    assert dense.show.value and dense.status.content == dense_message(result).markdown()
    assert not app.paused and not record.replay.disabled and not headless.tab.header.back.visible
    # the edits still go to the recording's session, and
    assert app.editor.session.root == recorded.root
    wait_for(
        lambda: header.title.content.endswith(
            f" · edits saved in session **{recorded.root.name}**"
        ),
        5,
        "the header naming it",
    )
    # (the steps below use the recording)
    app.use_source(playing)
    assert not dense.show.value
    dense.show.value = True  # shown by hand over the replay: it is
    assert headless.tab.scene._dense[0].visible


def test_a_batch_reconstructs_every_frame_of_the_recording(sphere):
    """After the replay, the session being edited is the recording: the Record step's batch writes
    one PLY per frame and a manifest into its exports/ folder, with progress on the bus, in this
    process (1 worker)."""
    app, headless = sphere
    record = panel(headless.tab, RecordPanel)
    session = app.editor.session
    assert session.frames and session.root == record.recorded.root
    named = f"Reconstruct every frame of session {session.root.name} ({len(session.frames)} frames)"
    assert record.batch.label == named
    statuses: list[str] = []
    app.bus.subscribe(JobProgress, lambda e: e.job == "batch" and statuses.append(e.status))
    record.start_batch()
    wait_for(
        lambda: not app.jobs.running("batch") and statuses and statuses[-1].startswith("batch "),
        120,
        "the batch",
    )
    # smoothed in time unless asked not to
    out = session.root / "exports" / "frames-raw-temporal2"
    assert (
        statuses[-1]
        == f"batch done: {len(session.frames)} of {len(session.frames)} frames in `{out}`"
    )
    assert sorted(p.name for p in out.glob("*.ply")) == [
        f"{Path(f).stem}.ply" for f in session.frames
    ]
    points, sources = read_ply(out / f"{Path(session.frames[0]).stem}.ply")
    assert len(points) > 1000 and set(np.unique(sources)) == {0, 1, 2}
    assert any(" of " in s and "fps" in s for s in statuses)  # progress while it ran
    wait_for(lambda: record.batch_status.content.startswith("batch done"), 30, "the batch's line")
    elsewhere = SimpleNamespace(
        snapshot=SimpleNamespace(session=SimpleNamespace(root=Path("/x"), frames=()))
    )
    # another session edited: the line of this one's batch goes
    record._session_changed(elsewhere)
    assert record.batch_status.content == BATCH_IDLE and record.batch.label.endswith(
        "session x (0 frames)"
    )


def test_a_batch_being_cancelled_says_so(sphere):
    """Cancel says at once that the batch is stopping (the frame under way finishes) and is not
    offered twice; the batch's last word replaces it, and Cancel is offered again to the next batch.
    """
    app, headless = sphere
    record = panel(headless.tab, RecordPanel)
    ended: list[str] = []
    app.bus.subscribe(
        JobProgress, lambda e: e.job == "batch" and e.fraction is None and ended.append(e.status)
    )
    # a frame at a time: slow enough to stop on the way
    record.method.value = "carve"
    record.start_batch()
    record.cancel_batch()
    assert (
        record.batch_status.content.endswith("· **cancelling…**") and record.batch_cancel.disabled
    )
    wait_for(lambda: ended, 120, "the batch's end")
    wait_for(lambda: "cancelling" not in record.batch_status.content, 10, "the last word")
    assert ended[0].startswith("batch ") and not record.batch_cancel.disabled
    record.method.value = "raw"


def test_a_tab_opened_while_a_batch_runs_shows_it(sphere, monkeypatch):
    """A tab opened during a TSDF batch shows the batch's settings and that it runs, and the next
    step says where."""
    app, _ = sphere
    running = app.jobs.running
    monkeypatch.setattr(app.jobs, "running", lambda kind: kind == "batch" or running(kind))
    monkeypatch.setattr(app.jobs, "batch_settings", ("tsdf", 3, 1))
    with HeadlessTab(app) as opened:
        record = panel(opened.tab, RecordPanel)
        assert (record.method.value, record.temporal.value, record.workers.value) == ("tsdf", 3, 1)
        assert (
            record.batch_cancel.visible
            and record.batch.disabled
            and "starting tsdf on every frame" in record.batch_status.content
        )
        opened.tab.header.refresh_hint()
        assert "A batch reconstructs every frame (0% done)" in opened.tab.header.hint.content


def test_recording_a_recording_that_plays_ends_at_its_last_frame(sphere):
    app, headless = sphere
    # the recording of the test above plays
    assert app.source.frame_count
    record = panel(headless.tab, RecordPanel)
    count = app.source.frame_count
    app.pause(True)
    time.sleep(0.3)  # a frame in progress finishes
    # near its end: the Record step says how to take all of it (a
    app.seek(count - 2)
    wait_for(lambda: app.last_frame.index == count - 2 and app.loop.index == count - 1)
    # its index already
    record.start()
    assert (
        f"The recording that plays is at frame {count - 2} of {count}: it is taken up to its "
        "last one (1 "
        "more); to take all of it, stop, set the Frame slider to 0, and record "
        "again."
    ) in record.status.content
    app.pause(False)
    wait_for(lambda: app.jobs._tap.replay_ended, 60, "the replay's last frame")
    wait_for(
        lambda: "came to its last frame" in record.status.content, 10, "the Record step saying so"
    )
    wait_for(
        lambda: headless.tab.header.rate.content.startswith("● **recording ended** at "),
        10,
        "the header saying so (it is written at most once a second)",
    )
    # one count of the take everywhere (the header, the Record
    taken = app.jobs._tap.taken
    # step and the
    assert headless.tab.header.rate.content.startswith(f"● **recording ended** at {taken} frames")
    assert f"came to its last frame: {taken} frames taken into " in record.status.content
    again = record.stop()
    assert len(again.frames) == taken and 1 <= taken <= app.source.frame_count
    assert list(again.timestamps) == sorted(again.timestamps)  # its time never runs back


def test_a_background_captured_before_saving_is_saved_with_the_session(tmp_path):
    """The demo is not saved: a background captured there is held in memory (the Object step says
    captured, and an edit keeps it), and Save as writes it into the new session."""
    source = demo_source()
    app = MirrorscanApp(
        calibrated_session(source, Path("unused")),
        source,
        port=0,
        autosave=False,
        sessions_dir=tmp_path,
    )
    try:
        with HeadlessTab(app) as headless:
            # a capture a centimetre off the source's
            captured = source.background() + np.float32(0.01)
            captured[source.background() == 0] = 0
            app.set_background(captured)
            object_panel = panel(headless.tab, ObjectPanel)
            object_panel.refresh()
            assert object_panel.status.content.startswith(
                "Background: captured. Depth range: 0.40 to 6.00 m."
            )
            # an edit keeps it
            app.editor.rename_mirror(app.editor.session.mirrors[0].id, "left")
            assert app.snapshot.background is captured
            files = panel(headless.tab, SessionPanel)
            files.new_name.value = "kept"
            files._save_as()
            saved = load_session(tmp_path / "kept").read_background()
            np.testing.assert_allclose(saved, captured, atol=0.0006)  # 1 mm units on disk
    finally:
        app.stop()


def test_a_session_file_written_by_calibrate_reaches_the_open_tabs(tmp_path, notes):
    """`mirrorscan calibrate SESSION` run in a terminal while the tool serves SESSION: the tool
    reloads the file (within a second), tells every tab, and its next edit goes on from the file as
    calibrate left it."""
    app = sphere_app(tmp_path / "scan")
    said = notes(app)
    app.start()
    try:
        with HeadlessTab(app) as headless:
            app.editor.add_mirror()
            mirrors = panel(headless.tab, MirrorsPanel)
            mirrors._report("Planes refined: a report of the planes before")
            session = load_session(tmp_path / "scan")
            plane = Plane.from_point_normal([0, 0, 2.5], [0, 0, -1])
            save_session(
                replace(session, mirrors=(replace(session.mirrors[0], name="left", plane=plane),))
            )
            wait_for(
                lambda: mirrors.mirror.options == ("left",),
                10,
                "the tab showing the reloaded session",
            )
            wait_for(
                lambda: any(
                    "was changed by another program (mirrorscan calibrate?): reloaded" in s
                    for s in said
                ),
                10,
                "the notification (it follows the tab's refresh: asserted at once, it "
                "failed once in CI)",
            )
            wait_for(lambda: mirrors.result.content == "", 10, "the report of other planes gone")
            app.editor.add_marker(app.editor.session.mirrors[0].id, (100, 100))
            assert load_session(tmp_path / "scan").mirrors[0].name == "left"
    finally:
        app.stop()


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


def test_mirrors_with_boundaries_and_no_markers_are_calibrated_from_a_recording(tmp_path):
    """The technician only drew the boundaries: the Mirrors step offers to find the planes from the
    object, over the recording's frames spread as `mirrorscan calibrate --method scene` picks them
    (the same result whenever it is clicked), and applies them as one undo step."""
    sim = Simulator(paper_scene(object="sphere"), seed=3)
    write_session(sim, tmp_path / "drawn", 4, progress=False)
    session = load_session(tmp_path / "drawn")
    session = replace(session, mirrors=tuple(replace(m, markers=()) for m in session.mirrors))
    save_session(session)
    app = MirrorscanApp(session, SessionSource(session), port=0, sessions_dir=tmp_path)
    app.start()
    try:
        with HeadlessTab(app) as headless:
            mirrors = panel(headless.tab, MirrorsPanel)
            wait_for(lambda: app.last_frame is not None, 30, "the first frame")
            headless.tab.changed()
            assert mirrors.scene.visible and not mirrors.scene.disabled and mirrors.refine.disabled
            with pytest.raises(
                MirrorscanError,
                match="mirror 1 has no markers: click 3 or more in "
                "Markers mode, or "
                "use Find the planes from the object",
            ):
                mirrors.fit_planes([m.id for m in app.editor.session.mirrors])
            with pytest.raises(
                MirrorscanError,
                match="no mirror has markers: click 3 or more on "
                "each in Markers "
                "mode, or use Find the planes from the "
                "object",
            ):
                mirrors.fit_all_planes()
            assert "**Find the planes from the object**" in headless.tab.header.hint.content
            app.jobs.start_scene(app.editor)
            wait_for(
                lambda: not app.jobs.running("refine") and "found:" in mirrors.result.content,
                240,
                "the planes found",
            )
            headline = mirrors.result.content.split("\n\n")[0]
            assert headline == (
                "Planes found from the sphere's centres (no markers): check the "
                "agreement "
                "below. Undo takes them back."
            ), headline
            content = mirrors.result.content  # the figures in the folds
            assert (
                "Over frames 0, 1, 2, 3 of the recording's 4 (numbered as in the header)."
                in content
            )
            assert (
                len(
                    re.findall(
                        r"The data fix it to ±\d\.\d\d mm and "
                        r"±\d\.\d{3}°",
                        content,
                    )
                )
                == 2
            ), content
            found = [m.plane for m in app.editor.session.mirrors]
            for plane, truth in zip(found, sim.planes):
                assert plane.angle_to(truth) < 0.3 and abs(plane.d - truth.d) < 0.003
            assert not mirrors.scene.visible and not mirrors.refine.disabled
            assert app.editor.undo_label(1) == "found planes of mirror 1 and mirror 2"
            app.editor.undo(1)
            # again: the same frames, the same planes
            app.jobs.start_scene(app.editor)
            wait_for(
                lambda: not app.jobs.running("refine") and "found:" in mirrors.result.content,
                240,
                "again",
            )
            assert [m.plane for m in app.editor.session.mirrors] == found
            report = mirrors.result.content
            # refined from there, the sphere's centres give them again: said so, no undo step, and
            # Undo still takes
            # back the planes found
            app.jobs.start_refine(app.editor)
            wait_for(
                lambda: not app.jobs.running("refine") and "refined:" in mirrors.result.content,
                240,
                "refined",
            )
            assert mirrors.result.content.startswith(
                "Nothing changed: the planes and the glass already fit this object (no undo "
                "step).\n\n<details>"
            )
            assert "Undo still takes back the step before." in mirrors.result.content
            assert [m.plane for m in app.editor.session.mirrors] == found
            assert app.editor.undo_label(1) == "found planes of mirror 1 and mirror 2"
            panel(headless.tab, MirrorsPanel)._travel(app.editor.undo)
            assert (
                mirrors.result.content
                == "Undone: the planes found from the object for mirror 1 and mirror 2."
            )
            panel(headless.tab, MirrorsPanel)._travel(app.editor.redo)
            assert mirrors.result.content == report
            # Session › Open of the session being served:
            app.open_session(load_session(tmp_path / "drawn"))
            assert app.source is app.start_source  # not a replay of it
            wait_for(
                lambda: "recording plays" not in headless.tab.header.hint.content, 10, "the hint"
            )
            assert not headless.tab.header.back.visible
    finally:
        app.stop()
