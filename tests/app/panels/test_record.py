"""The Record panel (mirrorscan.panels.record) on the simulated sphere rig, its mirrors calibrated
and a dense result shown: record and replay, batches, recording a recording, mirrors calibrated
from a recording."""
import re
import time
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from mirrorscan.bench.tabs import HeadlessTab
from mirrorscan.events import JobProgress
from mirrorscan.panels.dense import DensePanel
from mirrorscan.panels.mirrors import MirrorsPanel
from mirrorscan.panels.record import BATCH_IDLE, RecordPanel
from mirrorscan.panels.session import SessionPanel
from mirrorscan.server import MirrorscanApp
from mirrorscan.wording.jobs import dense as dense_message

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.calibration.fit import calibration_depth
from mirrorcore.calibration.markers import marker_residuals
from mirrorcore.io.ply import read_ply
from mirrorcore.io.sessionfile import load_session, save_session
from mirrorcore.sim.export import write_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import SessionSource
from tests.app.panels.support import panel
from tests.waiting import wait_for

pytestmark = pytest.mark.steps("dense_shown")


def test_record_then_replay_with_the_calibration(dense_shown):
    app, headless = dense_shown
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
    # a fit from the markers reads what `mirrorscan calibrate` reads, whenever it is clicked
    np.testing.assert_array_equal(app.jobs.marker_frames(), calibration_depth(recorded))
    # and each marker's grade reads them too
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
    # the edits still go to the recording's session
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
    dense.show.value = True  # shown by hand over the replay
    assert headless.tab.scene._dense[0].visible


def test_a_batch_reconstructs_every_frame_of_the_recording(dense_shown):
    """After the replay, the session being edited is the recording: the Record step's batch writes
    one PLY per frame and a manifest into its exports/ folder, with progress on the bus, in this
    process (1 worker)."""
    app, headless = dense_shown
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


def test_a_batch_being_cancelled_says_so(dense_shown):
    """Cancel says at once that the batch is stopping (the frame under way finishes) and is not
    offered twice; the batch's last word replaces it, and Cancel is offered again to the next batch.
    """
    app, headless = dense_shown
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


def test_a_tab_opened_while_a_batch_runs_shows_it(dense_shown, monkeypatch):
    """A tab opened during a TSDF batch shows the batch's settings and that it runs, and the next
    step says where."""
    app, _ = dense_shown
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


def test_recording_a_recording_that_plays_ends_at_its_last_frame(dense_shown):
    app, headless = dense_shown
    # the recording of the test above plays
    assert app.source.frame_count
    record = panel(headless.tab, RecordPanel)
    count = app.source.frame_count
    app.pause(True)
    time.sleep(0.3)  # a frame in progress finishes
    # near its end: the Record step says how to take all of it
    app.seek(count - 2)
    wait_for(lambda: app.last_frame.index == count - 2 and app.loop.index == count - 1)
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
    # one count of the take everywhere: the header, the Record step and the session
    taken = app.jobs._tap.taken
    assert headless.tab.header.rate.content.startswith(f"● **recording ended** at {taken} frames")
    assert f"came to its last frame: {taken} frames taken into " in record.status.content
    again = record.stop()
    assert len(again.frames) == taken and 1 <= taken <= app.source.frame_count
    assert list(again.timestamps) == sorted(again.timestamps)  # its time never runs back


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
            # Undo still takes back the planes found
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
