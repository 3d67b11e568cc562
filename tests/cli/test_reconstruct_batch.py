"""Batch reconstruction in this process (mirrorcore.batch, `reconstruct --frame all --workers 1`):
one PLY per frame, the same bytes as the single-frame command, a manifest that says what was done; a
rerun does only what is missing or damaged; a cancel keeps every finished frame; changed calibration
or options are refused unless --overwrite; a bad frame fails alone (the manifest itself:
test_reconstruct_manifest.py)."""

import json
import subprocess
import threading
from dataclasses import replace

import numpy as np
import pytest
from tests.batch_scene import FRAMES, IN_PROCESS, OPTIONS, ply_files
from tests.batch_scene import recording_fixture, reference_fixture  # noqa: F401

from mirrorscan.cli import main
from tests.cli.output import details, headlines
from mirrorcore.batch import (
    MANIFEST_FILE,
    BatchJob,
    BatchRun,
    OutputFolder,
    exports_folder,
    run_batch,
)
from mirrorcore.batch.engine import task_chunks
from mirrorcore.batch.manifest import LOCK_FILE
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.sessionfile import load_session, save_session

TSDF = OPTIONS["tsdf"]


def test_each_frame_is_the_single_frame_commands_file(recording, reference, tmp_path):
    assert sorted(reference["raw"]) == [f"{i:06d}.ply" for i in range(FRAMES)]
    for i in (0, 7, FRAMES - 1):
        assert (
            main(
                ["reconstruct", str(recording), "-o", str(tmp_path / "one.ply"), "--frame", str(i)]
            )
            == 0
        )
        assert (tmp_path / "one.ply").read_bytes() == reference["raw"][f"{i:06d}.ply"]


def test_a_rerun_does_only_the_frames_missing_or_damaged(recording, reference, tmp_path):
    out = tmp_path / "out"
    run_batch(BatchJob(recording, out), IN_PROCESS)
    (out / "000003.ply").unlink()
    (out / "000011.ply").write_bytes(reference["raw"]["000011.ply"][:-16])  # one point short
    (out / "000012.ply").write_bytes(reference["raw"]["000013.ply"])  # another frame's file
    (out / ".000004.ply.a1b2c3.tmp").write_bytes(b"left by a killed run")
    report = run_batch(BatchJob(recording, out), IN_PROCESS)
    assert (report.kept, report.written, report.complete) == (FRAMES - 3, 3, True)
    assert ply_files(out) == reference["raw"] and not list(out.glob("*.tmp"))
    assert run_batch(BatchJob(recording, out), IN_PROCESS).written == 0


def test_a_cancelled_run_keeps_its_frames_and_a_valid_manifest(recording, reference, tmp_path):
    out = tmp_path / "out"
    cancel = threading.Event()
    report = run_batch(
        BatchJob(recording, out),
        IN_PROCESS,
        frames_per_task=4,
        progress=lambda p: p.done >= 8 and cancel.set(),
        cancel=cancel,
    )
    assert report.cancelled and report.written == 8 and not report.complete
    manifest = json.loads((out / MANIFEST_FILE).read_text())
    assert [f["index"] for f in manifest["frames"]] == list(range(8)) and not manifest["complete"]
    assert set(ply_files(out)) == {f"{i:06d}.ply" for i in range(8)}
    report = run_batch(BatchJob(recording, out), IN_PROCESS)
    assert (report.kept, report.written) == (8, FRAMES - 8) and ply_files(out) == reference["raw"]


def test_changed_calibration_or_options_are_refused_unless_overwrite(
    recording, reference, tmp_path
):
    session_copy = tmp_path / "walk"
    subprocess.run(["cp", "-r", str(recording), str(session_copy)], check=True)
    out = tmp_path / "out"
    run_batch(BatchJob(session_copy, out), IN_PROCESS)
    with pytest.raises(
        MirrorscanError, match=r"made with other settings \(temporal \(0 -> 1\)\); use --overwrite"
    ):
        run_batch(BatchJob(session_copy, out, temporal=1), IN_PROCESS)
    with pytest.raises(
        MirrorscanError, match=r"other settings \(method \(raw -> tsdf\), margin \(none -> 0"
    ):
        run_batch(BatchJob(session_copy, out, "tsdf"), IN_PROCESS)
    session = load_session(session_copy)
    plane = session.mirrors[1].plane
    moved = Plane.from_abcd([*plane.n, plane.d + 0.002])
    save_session(session.with_mirror(1, replace(session.mirrors[1], plane=moved)))
    before = ply_files(out)
    with pytest.raises(
        MirrorscanError,
        match=r"manifest.json: its frames were made with other settings "
        r"\(calibration.mirrors\);",
    ):
        run_batch(BatchJob(session_copy, out), IN_PROCESS)
    assert ply_files(out) == before  # nothing touched
    report = run_batch(BatchJob(session_copy, out), IN_PROCESS, overwrite=True)
    assert (report.kept, report.written) == (0, FRAMES)
    changed = ply_files(out)
    assert (
        changed.keys() == reference["raw"].keys()
        and changed["000005.ply"] != reference["raw"]["000005.ply"]
    )


def test_a_bad_frame_fails_alone_and_is_done_on_the_next_run(
    recording, reference, tmp_path, capsys
):
    session_copy = tmp_path / "walk"
    subprocess.run(["cp", "-r", str(recording), str(session_copy)], check=True)
    good = (session_copy / "frames" / "000006.png").read_bytes()
    (session_copy / "frames" / "000006.png").write_bytes(b"not a png")
    out = tmp_path / "out"
    capsys.readouterr()
    assert (
        main(["reconstruct", str(session_copy), "-o", str(out), "--frame", "all", "--workers", "1"])
        == 2
    )
    err = capsys.readouterr().err  # the progress bar, then one line
    assert err.count("error:") == 1 and err.endswith("\n")
    error = err.splitlines()[-1]
    assert "1 frame(s) failed (6;" in error and "000006.png: not a readable image" in error
    manifest = json.loads((out / MANIFEST_FILE).read_text())
    assert len(manifest["frames"]) == FRAMES - 1 and manifest["failed"][0]["index"] == 6
    (session_copy / "frames" / "000006.png").write_bytes(good)
    report = run_batch(BatchJob(session_copy, out), IN_PROCESS)
    assert (report.kept, report.written, report.failed) == (FRAMES - 1, 1, {})
    assert ply_files(out) == reference["raw"]
    assert json.loads((out / MANIFEST_FILE).read_text())["failed"] == []


def test_dense_frames_are_the_single_frame_commands_files(recording, tmp_path):
    out = tmp_path / "out"
    session = load_session(recording)
    # three frames are enough here
    short = replace(session, frames=session.frames[:3],
                    colour_frames=session.colour_frames and session.colour_frames[:3])
    short_root = tmp_path / "short"
    subprocess.run(["cp", "-r", str(recording), str(short_root)], check=True)
    save_session(replace(short, root=short_root))
    report = run_batch(BatchJob(short_root, out, "tsdf", TSDF), IN_PROCESS)
    assert report.complete
    manifest = json.loads((out / MANIFEST_FILE).read_text())
    assert manifest["options"] == {
        "voxel": 0.015,
        "margin": 0.02,
        "threshold": None,
        "bounds": None,
        "truncation": None,
        "temporal": 0,
    }
    assert all(f["faces"] > 1000 for f in manifest["frames"])
    assert (
        main(
            [
                "reconstruct",
                str(short_root),
                "-o",
                str(tmp_path / "one.ply"),
                "--frame",
                "2",
                "--method",
                "tsdf",
                "--voxel",
                "0.015",
            ]
        )
        == 0
    )
    assert (tmp_path / "one.ply").read_bytes() == (out / "000002.ply").read_bytes()


def test_temporal_smoothing_in_a_batch_is_the_single_frame_commands(recording, tmp_path):
    out = tmp_path / "out"
    run_batch(BatchJob(recording, out, temporal=2), IN_PROCESS, frames_per_task=3)
    for i in (0, 10, FRAMES - 1):  # the ends of the recording and a chunk's edge (frame 9 | 10 ...)
        assert (
            main(
                [
                    "reconstruct",
                    str(recording),
                    "-o",
                    str(tmp_path / "one.ply"),
                    "--frame",
                    str(i),
                    "--temporal",
                    "2",
                ]
            )
            == 0
        )
        assert (tmp_path / "one.ply").read_bytes() == (out / f"{i:06d}.ply").read_bytes()


def test_the_output_folder_is_refused_when_it_is_not_a_batchs(recording, tmp_path):
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("mine")
    with pytest.raises(
        MirrorscanError, match=r"other: already holds files \(notes.txt...\) and no manifest.json"
    ):
        run_batch(BatchJob(recording, tmp_path / "other"), IN_PROCESS)
    (tmp_path / "file").write_text("x")
    with pytest.raises(MirrorscanError, match="file: exists and is not a folder"):
        run_batch(BatchJob(recording, tmp_path / "file"), IN_PROCESS)
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / MANIFEST_FILE).write_text('{"kind": "something else"}')
    with pytest.raises(MirrorscanError, match="not the manifest of a batch reconstruction"):
        run_batch(BatchJob(recording, tmp_path / "bad"), IN_PROCESS)


def test_one_run_at_a_time_writes_into_a_folder(recording, tmp_path):
    job = BatchJob(recording, tmp_path / "out")
    first = recording / load_session(recording).frames[0]
    held = OutputFolder(
        tmp_path / "out", str(recording), job.settings(), {}, ("000000.ply",), [first]
    )
    try:
        with pytest.raises(
            MirrorscanError, match="another mirrorscan run is writing into this folder"
        ):
            run_batch(job, IN_PROCESS)
    finally:
        held.close()
    assert (tmp_path / "out" / LOCK_FILE).exists()


def test_tasks_shrink_towards_the_end_so_that_the_workers_finish_together():
    todo = list(range(3, 123))
    assert task_chunks(todo, 8, 1) == [tuple(todo[i : i + 8]) for i in range(0, 120, 8)]
    chunks = task_chunks(todo, 8, 2)
    sizes = [len(c) for c in chunks]
    assert [i for c in chunks for i in c] == todo  # every frame once, in order
    assert sizes[0] == 8 and sizes == sorted(sizes, reverse=True) and sizes[-4:] == [1, 1, 1, 1]
    assert sum(s for s in sizes if s < 8) <= 2 * 2 * 8  # only the last few tasks are smaller
    assert task_chunks([7], 8, 4) == [(7,)] and task_chunks([], 8, 2) == []


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--frames", "3"], "--frames: with --frame all each frame is reconstructed alone"),
        (["--workers", "0"], "--workers: at least 1"),
        (["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "has its own workers"),
        (["--frames-per-task", "0", "--workers", "1"], "--frames-per-task: expected a whole"),
        (["--temporal", "-1"], "--temporal: expected a whole number"),
    ],
)
def test_bad_batch_requests_exit_2(recording, tmp_path, capsys, argv, message):
    capsys.readouterr()
    assert (
        main(["reconstruct", str(recording), "-o", str(tmp_path / "out"), "--frame", "all", *argv])
        == 2
    )
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_a_scheduler_that_does_not_answer_is_named(recording, tmp_path, capsys, monkeypatch):
    from mirrorcore.batch import cluster

    monkeypatch.setattr(cluster, "CONNECT_SECONDS", 1.0)
    capsys.readouterr()
    assert (
        main(
            [
                "reconstruct",
                str(recording),
                "-o",
                str(tmp_path / "out"),
                "--frame",
                "all",
                "--scheduler",
                "tcp://127.0.0.1:9",
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert (
        "--scheduler tcp://127.0.0.1:9: no Dask scheduler answered" in err and err.count("\n") == 1
    )


def test_a_batch_run_in_a_thread_reports_progress_and_can_be_cancelled(
    recording, reference, tmp_path
):
    seen = []
    run = BatchRun(
        BatchJob(recording, tmp_path / "out"),
        IN_PROCESS,
        frames_per_task=2,
        on_progress=seen.append,
    )
    report = run.start().wait(timeout=60)
    assert report.complete and ply_files(tmp_path / "out") == reference["raw"]
    assert [p.done for p in seen] == list(range(0, FRAMES + 1, 2))
    assert seen[-1].fraction == 1.0 and seen[-1].fps > 0 and seen[-1].seconds_left == 0
    assert run.progress == seen[-1] and not run.running
    slow = BatchRun(BatchJob(recording, tmp_path / "tsdf", "tsdf", TSDF), IN_PROCESS)
    slow.start()
    slow.cancel()
    report = slow.wait(timeout=60)
    assert report.cancelled and report.written < FRAMES
    failing = BatchRun(BatchJob(tmp_path / "nowhere", tmp_path / "x"), IN_PROCESS).start()
    with pytest.raises(MirrorscanError, match="session.json"):
        failing.wait(timeout=60)
    assert isinstance(failing.error, MirrorscanError)


def test_an_unexpected_error_fails_its_task_and_the_others_go_on(
    recording, reference, tmp_path, monkeypatch
):
    from mirrorcore.batch import frames

    real = frames._frame_ply

    def broken_on_frame_9(context, depth, *args, **kwargs):
        if np.array_equal(depth, frames.read_depth(context.session, 9)):
            raise RuntimeError("a bug\non two lines")
        return real(context, depth, *args, **kwargs)

    monkeypatch.setattr(frames, "_frame_ply", broken_on_frame_9)
    report = run_batch(BatchJob(recording, tmp_path / "out"), IN_PROCESS, frames_per_task=4)
    # frame 9's task
    assert report.failed == {i: "RuntimeError: a bug on two lines" for i in (8, 9, 10, 11)}
    assert report.written == FRAMES - 4
    monkeypatch.setattr(frames, "_frame_ply", real)
    assert run_batch(BatchJob(recording, tmp_path / "out"), IN_PROCESS).written == 4
    assert ply_files(tmp_path / "out") == reference["raw"]


def test_the_browser_tools_folder_is_in_the_sessions_exports(tmp_path):
    assert exports_folder(tmp_path) == tmp_path / "exports" / "frames-raw"
    assert exports_folder(tmp_path, "tsdf", 2) == tmp_path / "exports" / "frames-tsdf-temporal2"


def test_the_commands_summary_names_retried_and_failed_frames(tmp_path, capsys):
    from mirrorscan.commands.reconstruct_batch import _summary
    from mirrorcore.batch import BatchReport

    report = BatchReport(
        tmp_path,
        40,
        kept=10,
        written=27,
        failed={3: "frames/000003.png: no such depth image", 5: "x", 6: "y"},
        retried={20: "tcp://10.0.0.2:4000", 21: "tcp://10.0.0.2:4000"},
        seconds=2.7,
        startup_seconds=12.34,
    )
    with pytest.raises(
        MirrorscanError,
        match=r"^3 frame\(s\) failed \(3, 5, 6; see .*manifest.json\), frame 3: "
        r"frames/000003.png: no such depth image$",
    ):
        _summary(report, verbose=True)
    out = capsys.readouterr().out
    assert headlines(out) == [
        f"wrote 27 PLY files into {tmp_path}; 37 of 40 frames done: run it again to go on.",
        "worker tcp://10.0.0.2:4000 left the cluster: its 2 frame(s) were run again.",
    ]
    assert details(out) == [
        "10.0 frames/s over 2.70 s, after 12.3 s starting the workers",
        "10 frames kept from an earlier run",
        f"manifest {tmp_path / MANIFEST_FILE}",
        "frames run again: 20, 21",
    ]
    with pytest.raises(MirrorscanError):
        _summary(report, verbose=False)
    assert details(capsys.readouterr().out) == []
    with pytest.raises(KeyboardInterrupt):
        _summary(BatchReport(tmp_path, 40, 0, 5, cancelled=True), verbose=False)
