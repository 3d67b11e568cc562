"""The Mirrors panel (mirrorscan.panels.mirrors) on the demo: undo of planes and outlines, the
outline buttons, reports, removal and its undo, greyed-out buttons, one note at a time."""
from dataclasses import replace
from pathlib import Path

import pytest
from mirrorscan.editor import SESSION_SCOPE
from mirrorscan.jobs import planes_key
from mirrorscan.panels.mirrors import MirrorsPanel
from mirrorscan.results import CalibrationReport, FramesUsed
from mirrorscan.wording.greyed import greyed_out
from mirrorscan.wording.mirrors import removal_question, report_markdown

from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.session import Session, SessionMirror
from tests.app.support import refined


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


def test_undoing_a_removal_brings_back_the_markers_fits_report(demo_refined):
    """Fit all planes (applied on confirmation), a mirror removed, then Undo: the mirror is back
    with its plane, and so is the fit's report (per mirror, its markers' residuals)."""
    app_, headless = demo_refined
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


def test_the_mode_line_shows_for_the_modes_whose_clicks_edit_and_the_hint_names_all(demo):
    """Inspect, where a click only reads a pixel, has no line (its words are in the Click to
    buttons' hint); Markers and Boundary name the mirror the clicks go to."""
    _, headless = demo
    mirrors = next(p for p in headless.tab.panels if isinstance(p, MirrorsPanel))
    state = headless.tab.state
    assert state.mode == "inspect"
    mirrors.refresh()
    assert not mirrors.help.visible and "Inspect: a click" in mirrors.mode.hint
    for mode, start in (("markers", "**Markers** mode: click a marker's centre on **mirror 1**"),
                        ("boundary", "**Boundary** mode: the outline of **mirror 1** is closed")):
        state.mode = mode
        mirrors.refresh()
        assert mirrors.help.visible and mirrors.help.content.startswith(start)
    state.mode = "inspect"
    mirrors.refresh()
    assert not mirrors.help.visible
