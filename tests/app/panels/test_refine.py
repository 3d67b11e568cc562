"""Refine from the object and the heat map (mirrorscan.panels.mirrors, panels.live) on the
simulated sphere rig, its mirrors calibrated by clicking."""
import logging
import re
import time

import numpy as np
import pytest
from mirrorscan.bench.tabs import HeadlessTab
from mirrorscan.events import JobProgress
from mirrorscan.jobs import HEAT, planes_key
from mirrorscan.panels.mirrors import MirrorsPanel
from mirrorscan.results import AgreementReport, MirrorAgreement
from mirrorscan.view import HEAT_DIRECT_SIZE
from mirrorscan.wording import Message, joined
from mirrorscan.wording import mirrors as mirror_words
from mirrorscan.wording import agreement as agreement_words
from mirrorscan.wording.mirrors import fit_report

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.base.palette import HEAT_UNCOMPARED, SOURCE_COLOURS
from mirrorcore.calibration.residuals import view_agreement
from mirrorcore.rig.pipeline import prepare_frame
from tests.app.panels.support import panel
from tests.waiting import wait_for

pytestmark = pytest.mark.steps("calibrated")


def test_refine_from_the_object_and_the_heat_map(calibrated, notes, caplog):
    """After the markers fit: the views' agreement is reported, 'Refine from the object' refines
    both planes on a worker and reports each mirror (agreement before and after, the change, how
    well determined), the glass in front of the silver can be set per mirror, and a tab's heat map
    shows a frame's points one colour each."""
    app, headless = calibrated
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
        agreement_words.agreement(
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
    line, fold = mirrors.status.content.split("</summary>", 1)
    assert line == (
        "<details><summary>plane from the object · glass 3.0 mm typed in: the next "
        "markers fit uses it, "
        f"this plane does not depend on it · {markers} markers"
    )
    # the refinement measured the colour gain on the live frames: in the fold the line opens
    gain = " / ".join(f"{100 * g:.0f}" for g in app.editor.mirror(1).colour_gain)
    assert f"colour {gain} %" in fold
    with pytest.raises(MirrorscanError, match="must be 0 to 50 mm, got 80 mm"):
        app.editor.set_marker_offset(1, 0.08)
    # typed in the page: refused, and the field shows
    mirrors.glass.value = -5.0
    with pytest.raises(MirrorscanError, match="must be 0 to 50 mm, got -5 mm"):
        mirrors._set_glass()
    assert mirrors.glass.value == 3.0 and app.editor.mirror(1).marker_offset == 0.003
    # the glass typed in is said as typed
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
    # paused, no frame comes: the map of the frame shown, at once
    app.pause(True)
    time.sleep(0.3)  # a frame in progress finishes
    tab.show_heat(True)
    wait_for(
        lambda: "/heat" in tab.client.scene._handle_from_node_name, 10, "the heat map while paused"
    )
    wait_for(lambda: not app.jobs.running(HEAT) and tab._heat_event, 10, "the paused frame's map")
    # one mirror's points alone
    header = tab.header
    header.colours.heat_choices()
    assert header.colours.heat_of.visible and header.colours.heat_of.options == (
        "every mirror",
        "mirror 1",
        "mirror 2",
    )
    sources = tab._heat_event.sources
    # points with nothing to compare with are drawn small and grey, as the camera's
    compared = ~np.all(tab._heat_event.colours == HEAT_UNCOMPARED, axis=1)
    header.colours.heat_of.value = "mirror 2"
    tab.heat_only(header.colours.heat_mirror())
    nodes = tab.client.scene._handle_from_node_name
    assert len(nodes["/heat"].points) == np.count_nonzero((sources == 2) & compared) > 0
    assert np.all(nodes["/heat/direct"].colors == grey) and len(
        nodes["/heat/direct"].points
    ) == np.count_nonzero((sources != 2) | ~compared)
    header.colours.heat_of.value = "every mirror"
    tab.heat_only(header.colours.heat_mirror())
    assert len(tab.client.scene._handle_from_node_name["/heat"].points) == np.count_nonzero(
        (sources != 0) & compared
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
    header.colours.choose("heat map", ticked=True)
    assert tab.state.view == "3d" and tab.heat and header.colours.choice.value == "heat map"
    header.colours.choose("source", ticked=True)
    assert tab.state.view == "3d" and not tab.heat and header.colours.choice.value == "source"
