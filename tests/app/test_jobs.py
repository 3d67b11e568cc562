"""The jobs (mirrorscan.jobs) as the tool runs them: agreement of the views, refinement, finding
mirrors from the object, a job's last word, the heat map's pool of recent frames."""
import threading
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from mirrorscan.demo import calibrated_session, demo_source
from mirrorscan.events import EventBus, JobProgress
from mirrorscan.jobs import HEAT_POOL, Jobs, planes_key
from mirrorscan.wording.legend import heat_legend_html
from mirrorscan.panels.mirrors import MirrorsPanel
from mirrorscan.results import AgreementReport, BackgroundCaptured, MirrorAgreement, NotFound
from mirrorscan.server import MirrorscanApp
from mirrorscan.wording import joined
from mirrorscan.wording import agreement as agreement_words
from mirrorscan.wording import refinement as calibration_words

from mirrorcore.base.errors import CalibrationError, Cancelled, MirrorscanError
from mirrorcore.calibration.residuals import ViewAgreement
from tests.app.support import refined
from tests.waiting import wait_for


def test_a_session_opened_with_its_planes_tells_how_its_views_agree():
    """No fit needed: once the frames of the session as opened are in, the views' agreement is
    reported."""
    source = demo_source()
    app = MirrorscanApp(calibrated_session(source, Path("unused")), source, port=0, autosave=False)
    app.start()
    try:
        report = wait_for(lambda: app.jobs.agreement, 60, "the agreement")
        assert [m.name for m in report.mirrors] == ["mirror 1", "mirror 2"]
        said = joined(agreement_words.agreement(report))
        assert said.startswith("mirror 1: agrees") and "\n\nmirror 2: agrees" in said
    finally:
        app.stop()


def test_the_agreement_reported_is_that_of_the_current_planes(demo, monkeypatch):
    """A change of the mirrors while the agreement is computed (an undo, a fit: here a rename) is
    not left out: the check asked for meanwhile is not started beside the running one, which checks
    again before it reports."""
    import mirrorscan.jobs.agreement as jobs_module

    app_, _ = demo
    frame, calls = app_.loop.run_once(), []
    wait_for(lambda: not app_.jobs.running("agreement"), 60, "the start-up agreement")
    real = jobs_module.view_agreement

    def renamed_meanwhile(rig, depths, masks):
        calls.append(rig)
        if len(calls) == 1:
            app_.editor.rename_mirror(1, "left")
            # asked again while it runs: not started
            app_.jobs.start_agreement(frame.depth)
        return real(rig, depths, masks)

    monkeypatch.setattr(jobs_module, "view_agreement", renamed_meanwhile)
    done = []
    unsubscribe = app_.bus.subscribe(
        JobProgress, lambda e: e.job == "agreement" and e.fraction is None and done.append(e.result)
    )
    try:
        app_.jobs.start_agreement(frame.depth)
        report = wait_for(lambda: done, 60, "the agreement")[0]
        assert (
            report.mirrors[0].name == "left" and len(calls) == 2 and app_.jobs.agreement is report
        )
    finally:
        unsubscribe()
        app_.editor.rename_mirror(1, "mirror 1")


def test_while_the_views_are_checked_again_the_start_line_drops_the_old_advice(demo, monkeypatch):
    """New planes (a refinement, a fit) are checked again: meanwhile the Start here line does not
    repeat the warning about the planes before them."""
    import mirrorscan.jobs.agreement as jobs_module

    app_, headless = demo
    frame = app_.loop.run_once()
    wait_for(lambda: not app_.jobs.running("agreement"), 60, "the start-up agreement")
    # as the check of the planes before left it
    app_.jobs.disagreeing = ("mirror 1", "mirror 2")
    hint = headless.tab.header.hint
    headless.tab.header.refresh_hint()
    assert "their views disagree" in hint.content
    release, real = threading.Event(), jobs_module.view_agreement

    def held(rig, depths, masks):
        release.wait(60)
        return real(rig, depths, masks)

    monkeypatch.setattr(jobs_module, "view_agreement", held)
    app_.jobs.start_agreement(frame.depth)
    try:
        assert app_.jobs.running("agreement")
        headless.tab.header.refresh_hint()
        assert "disagree" not in hint.content
    finally:
        release.set()
    wait_for(lambda: not app_.jobs.running("agreement"), 60, "the agreement")
    # the demo's planes agree
    assert app_.jobs.disagreeing == ()


def test_without_planes_the_agreement_says_what_to_do(demo, monkeypatch):
    """No mirror has a plane: the agreement says so and what to do (it read "no view sees what
    another sees")."""
    import mirrorscan.jobs.agreement as jobs_module

    app_, _ = demo
    frame = app_.loop.run_once()
    wait_for(lambda: not app_.jobs.running("agreement"), 60, "the start-up agreement")
    monkeypatch.setattr(jobs_module, "view_agreement", lambda rig, depths, masks: {})
    app_.jobs.start_agreement(frame.depth)
    wait_for(lambda: not app_.jobs.running("agreement"), 60, "the agreement")
    assert app_.jobs.agreement == AgreementReport(())
    assert agreement_words.agreement(app_.jobs.agreement) == [agreement_words.NO_AGREEMENT]
    monkeypatch.undo()
    app_.jobs.start_agreement(frame.depth)
    wait_for(lambda: not app_.jobs.running("agreement"), 60, "the agreement")


def test_a_refused_refinement_is_not_offered_again_for_the_glass(demo, monkeypatch):
    """After a refinement was refused, the next step does not send the technician back to it for
    the glass, but to typing the glass in,
    also after the next fit, until a refinement
    succeeds."""
    import mirrorscan.jobs.refinement as jobs_module

    app_, headless = demo
    app_.loop.run_once()
    real = jobs_module.refine_session

    def refused(*args, **kwargs):
        raise CalibrationError(
            "mirror 1: the camera and the mirror see too little of the same surface", ("mirror 1",)
        )

    monkeypatch.setattr(jobs_module, "refine_session", refused)
    hint = headless.tab.header.hint
    headless.tab.header.refresh_hint()
    assert (
        "No glass set on mirror 1 and mirror 2: **Mirrors › Refine from the object** measures it."
        in hint.content
    )
    app_.jobs.start_refine(app_.editor).join(60)
    ids = [m.id for m in app_.editor.session.mirrors]
    # the mirror it names
    assert app_.jobs.refused == {ids[0]: "refine"}
    headless.tab.header.refresh_hint()
    assert "this object could not measure it" in hint.content
    assert app_.jobs.refusals(app_.editor.session) == {ids[0]: "refine"}
    # its outline drawn again: refused no more
    corner = app_.editor.mirror(ids[0]).boundary[0]
    # (a search refused for an outline too narrow is not offered again until it changes)
    app_.editor.move_vertex(ids[0], 0, (corner[0] + 3.0, corner[1]))
    assert app_.jobs.refusals(app_.editor.session) == {}
    app_.editor.undo(ids[0])
    assert app_.jobs.refusals(app_.editor.session) == {ids[0]: "refine"}
    # a fit moves a plane: still so
    mirror = app_.editor.mirror(ids[0])
    app_.editor.set_planes({ids[0]: (replace(mirror.plane, d=mirror.plane.d + 0.001), mirror)})
    headless.tab.header.refresh_hint()
    assert "this object could not measure it" in hint.content
    # one that succeeds clears it
    monkeypatch.setattr(jobs_module, "refine_session", real)
    app_.jobs.start_refine(app_.editor).join(120)
    assert app_.jobs.refused == {}
    assert app_.editor.undo(ids[0]).startswith("refined planes") and app_.editor.undo(
        ids[0]
    ).startswith("plane")


def test_a_mirror_held_while_the_others_are_found_keeps_its_plane_from_its_markers(
    demo, monkeypatch
):
    """Find the planes from the object with mirror 1 fitted from its markers and held: only mirror
    2's plane comes from the object, and mirror 1 is still asked for its glass."""
    import mirrorscan.jobs.refinement as jobs_module

    app_, headless = demo
    app_.loop.run_once()
    held, found = app_.editor.session.mirrors
    app_.editor.set_planes({found.id: (None, found)})
    truth = found.plane

    def search(session, depths, masks, rng, indices, progress=None, cancel=None, with_="auto"):
        assert list(indices) == [1]
        report = refined(found.name, 1, after=truth)
        return session.with_mirror(1, replace(session.mirrors[1], plane=truth)), SimpleNamespace(
            mirrors=[report], compared="surfaces", refused=()
        )

    monkeypatch.setattr(jobs_module, "calibrate_scene", search)
    app_.jobs.start_scene(app_.editor).join(60)
    assert app_.editor.mirror(found.id).plane == truth
    assert app_.jobs.from_object(found.id, truth) and not app_.jobs.from_object(held.id, held.plane)
    headless.tab.header.refresh_hint()
    assert f"No glass set on {held.name}:" in headless.tab.header.hint.content


def test_find_applies_the_planes_it_found_and_names_the_mirror_it_did_not(demo, monkeypatch):
    """Find the planes from the object where one mirror cannot be found: the others' planes are
    applied and the one not found is named with why, in the headline and its details, and its Find
    is not offered again until its outline or markers change."""
    import mirrorscan.jobs.refinement as jobs_module

    app_, headless = demo
    app_.loop.run_once()
    first, second = app_.editor.session.mirrors
    app_.editor.set_planes({first.id: (None, first), second.id: (None, second)})
    why = f"{first.name}: 300 readings just outside its outline lie beyond the object seen directly"

    def search(session, depths, masks, rng, indices, progress=None, cancel=None, with_="auto"):
        assert list(indices) == [0, 1]
        report = refined(second.name, 1, after=second.plane)
        return session.with_mirror(
            1, replace(session.mirrors[1], plane=second.plane)
        ), SimpleNamespace(mirrors=[report], compared="surfaces", refused=((0, why),))

    monkeypatch.setattr(jobs_module, "calibrate_scene", search)
    app_.jobs.start_scene(app_.editor).join(60)
    assert (
        app_.editor.mirror(second.id).plane == second.plane
        and app_.editor.mirror(first.id).plane is None
    )
    report = app_.jobs.refinements[planes_key(app_.editor.session)]
    assert report.not_found == (NotFound(first.name, why.removeprefix(first.name + ": ")),)
    said = calibration_words.report(report)
    assert f"⚠ {first.name} not found (why below)." in said[0].headline
    assert (
        f"Undo goes by mirror: select {second.name} to take the planes found back."
        in said[0].details
    )
    # named once; the colour gain of the mirror found follows
    missing = [m for m in said if m.headline.startswith(f"**{first.name}** ⚠ not found")]
    assert [m.details for m in missing] == [(why.removeprefix(first.name + ": "),)]
    assert said[-1].headline == f"Colour gain measured for {second.name}: their points show the " \
        "scene's own colour."
    assert app_.jobs.refusals(app_.editor.session) == {first.id: "scene"}
    mirrors = next(p for p in headless.tab.panels if isinstance(p, MirrorsPanel))
    # the one not found: Find greyed out, saying
    headless.tab.state.mirror_id = first.id
    # why (viser shows no hint on a button)
    mirrors.refresh()
    assert mirrors.scene.disabled and mirrors.greyed.visible
    assert (
        f"<b>Find</b>: {first.name} not found as it is (why: in the report below); offered "
        "again once an "
        "outline or a marker changes"
    ) in mirrors.greyed.content
    # nothing to undo on it (steps of other tests aside): the found plane is on the other
    label = app_.editor.undo_label
    monkeypatch.setattr(
        app_.editor,
        "undo_label",
        lambda scope: None if scope in (first.id, 0) else label(scope),
    )
    mirrors.refresh()
    assert mirrors.undo.disabled
    assert mirrors.greyed.content.endswith(
        f"<b>Undo</b>: nothing to take back on {first.name}; "
        "select "
        f"{second.name} for its changes</div>"
    )
    headless.tab.state.mirror_id = second.id
    mirrors.refresh()
    assert not mirrors.undo.disabled and "<b>Undo</b>" not in mirrors.greyed.content


def test_a_mirror_the_agreement_flags_is_told_in_a_notification_once(demo, notes):
    """The agreement lines may be out of view (at 1024x600 two screens down): a mirror they flag is
    also named in a notification, not again for the same lines."""
    app_, headless = demo
    kinds: list = []
    said = notes(app_, kinds)
    mirrors = next(p for p in headless.tab.panels if isinstance(p, MirrorsPanel))
    good = ViewAgreement(10.0, 0.5, 900, 11.7, 5.0, 0.5, 9.0, 800, frames=5)
    # tilted against the camera
    bad = ViewAgreement(12.0, 3.0, 900, 11.7, 8.0, -4.2, 9.0, 800, frames=5)

    def ended(*views):
        report = AgreementReport(
            tuple(MirrorAgreement(f"mirror {k}", v, True) for k, v in enumerate(views, 1))
        )
        return JobProgress("agreement", None, joined(agreement_words.agreement(report)), report)

    mirrors._on_job(ended(good))
    assert said == []
    mirrors._on_job(ended(good, bad))
    assert said == [
        "mirror 2: ⚠ its view disagrees with the others beyond the depth noise; why "
        "and what to do "
        "are under Mirrors."
    ] and kinds == [("warning", False)]
    # the same lines again: once
    mirrors._on_job(ended(good, bad))
    mirrors._on_job(ended(bad, bad))
    assert len(said) == 2 and said[-1].startswith("mirror 1 and mirror 2: ⚠ their views disagree")


def test_a_job_says_its_last_word_once_it_is_over():
    """The last status of a job (done, cancelled, refused) arrives once the job is not
    running: the button it enables starts the next one at once, never 'already running'."""
    bus = EventBus()
    jobs = Jobs(None, lambda: None, bus)
    ended: list[tuple[str, bool]] = []
    bus.subscribe(
        JobProgress, lambda e: e.fraction is None and ended.append((e.status, jobs.running("x")))
    )

    def cancelled(cancel):
        raise Cancelled("x")

    def refused(cancel):
        raise MirrorscanError("no frame yet")

    for work in (lambda cancel: BackgroundCaptured(3), cancelled, refused):
        jobs._start("x", work, "busy").join(10)
    assert ended == [
        ("captured from 3 frames", False),
        ("cancelled", False),
        ("not done: no frame yet", False),
    ]


def test_the_heat_maps_figures_pool_the_recent_frames_of_the_same_planes():
    """One frame's median jumped by 1 to 2 mm: the legend pools the last HEAT_POOL maps,
    and a new calibration starts afresh."""
    jobs, first, second = Jobs(None, lambda: None, EventBus()), object(), object()
    for k in range(HEAT_POOL + 3):
        pooled = jobs._pool_heat(first, k, np.full(2, float(k)), np.ones(2, int))
    assert len(pooled) == HEAT_POOL and pooled[-1][0][0] == HEAT_POOL + 2 and pooled[0][0][0] == 3
    # a replay's frame 5 again: in its place anew, not twice
    pooled = jobs._pool_heat(first, 5, np.full(2, 50.0), np.ones(2, int))
    assert len(pooled) == HEAT_POOL and pooled[-1][0][0] == 50.0
    assert sum(p[0][0] in (5.0, 50.0) for p in pooled) == 1
    # other planes: a new pool
    assert len(jobs._pool_heat(second, 0, np.zeros(2), np.ones(2, int))) == 1
    text = heat_legend_html({1: (-0.44, 0.07)}, HEAT_POOL, {1: "left"}.get)
    replay = Jobs(SimpleNamespace(source=SimpleNamespace(frame_count=12)), lambda: None, EventBus())

    def frame(index, rig=first):
        return SimpleNamespace(index=index, snapshot=SimpleNamespace(rig=rig))

    assert replay.heat_wanted(frame(3))  # nothing pooled yet
    replay._pool_heat(first, 3, np.zeros(2), np.ones(2, int))
    # frame 3 again (the loop's 2nd round), not other planes
    assert not replay.heat_wanted(frame(3)) and not replay.heat_wanted(frame(15))
    assert replay.heat_wanted(frame(4)) and replay.heat_wanted(frame(3, second))
    for k in range(HEAT_POOL):
        replay._pool_heat(first, k, np.zeros(2), np.ones(2, int))
    # the pool full: any frame refreshes it
    assert replay.heat_wanted(frame(3))
    live = Jobs(SimpleNamespace(source=SimpleNamespace(frame_count=0)), lambda: None, EventBus())
    live._pool_heat(first, 3, np.zeros(2), np.ones(2, int))
    assert live.heat_wanted(frame(3))  # a camera's frames are all new
    assert (
        f"the last {HEAT_POOL} frames, against the camera's surface (> 0: outside it):<br>left: "
        "median -0.4 mm, "
        "7% of its points compared" in text
    )
    assert "this frame, against" in heat_legend_html({1: (-0.44, 0.07)}, 1, {1: "left"}.get)
    assert (
        "left: median -1.4 mm, under 1% of its points compared (it sees little of what the camera "
        "sees: its "
        "agreement under Mirrors compares it with every view)"
        in heat_legend_html({1: (-1.44, 0.004)}, 1, {1: "left"}.get)
    )
    # 7% compared: the camera checks it
    assert "compares it with every view" not in text
    # no line of its own
    multi = heat_legend_html({33: (float("nan"), 0.0)}, 1, {33: "left then right"}.get)
    assert (
        "left then right: none of its points seen by the camera (seen through several mirrors: "
        "the agreement "
        "lines of those mirrors under Mirrors check it)"
    ) in multi
    # no plane: what to do, not "computing"
    bare = heat_legend_html({}, 0, {1: "left"}.get, planes=False)
    assert "No mirror has a plane yet" in bare and "computing" not in bare
    assert text.endswith(
        "<i>A tilted plane or a wrong boundary colours a mirror's points; a glass "
        "hardly does (3 mm "
        "read 0.2 mm on the sphere): <b>Refine from the object</b> measures "
        "it.</i></div>"
    )
    # every glass set
    typed = heat_legend_html({1: (-0.44, 0.07)}, HEAT_POOL, {1: "left"}.get, no_glass=False)
    assert typed.endswith("a glass hardly does (3 mm read 0.2 mm on the sphere).</i></div>")
    refined = heat_legend_html({1: (-0.44, 0.07)}, HEAT_POOL, {1: "left"}.get, refined=True)
    assert (
        "Refine from the object" not in refined and "these planes come from the object" in refined
    )
