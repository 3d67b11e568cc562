"""`mirrorscan reconstruct --frame all`: the manifest.json, what it lists and when it is written."""

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from tests.batch_scene import FRAMES, IN_PROCESS, OPTIONS, ply_files
from tests.batch_scene import recording_fixture, reference_fixture  # noqa: F401

from tests.waiting import wait_for
from mirrorcore.batch import (
    MANIFEST_FILE,
    BatchJob,
    OutputFolder,
    run_batch,
)
from mirrorcore.batch.manifest import MAX_FLUSH_SECONDS, MIN_FLUSH_SECONDS, FrameRecord
from mirrorcore.io.ply import read_ply
from mirrorcore.io.sessionfile import load_session

ROOT = Path(__file__).resolve().parents[2]
TSDF = OPTIONS["tsdf"]
# metres: the killed run's voxels, finer than TSDF's so that each frame takes longer
KILLED_VOXEL = 0.004


def test_the_manifest_lists_every_frame_with_its_counts(recording, reference, tmp_path):
    out = tmp_path / "out"
    run_batch(BatchJob(recording, out), IN_PROCESS, frames_per_task=3)
    assert ply_files(out) == reference["raw"]  # the task size changes nothing
    manifest = json.loads((out / MANIFEST_FILE).read_text())
    assert manifest["session"] == str(recording) and manifest["method"] == "raw"
    assert (
        manifest["options"] == {"temporal": 0, "colour": "scene"}
        and manifest["complete"] and manifest["failed"] == []
    )
    plane = load_session(recording).mirrors[0].plane
    assert manifest["inputs"]["calibration"]["mirrors"][0]["plane"] == plane.to_list()
    assert [f["index"] for f in manifest["frames"]] == list(range(FRAMES))
    for frame in manifest["frames"]:
        points, sources = read_ply(out / frame["file"])
        assert frame["vertices"] == len(points) > 500 and frame["faces"] is None
        assert (
            frame["sources"] == np.bincount(sources, minlength=3).tolist()
            and min(frame["sources"]) > 0
        )
        assert frame["bytes"] == (out / frame["file"]).stat().st_size and 0 < frame["seconds"] < 10


def test_the_manifest_is_written_often_but_not_too_often(recording, tmp_path):
    """At most every MIN_FLUSH_SECONDS, no more than FLUSH_SHARE of the time, and at least every
    MAX_FLUSH_SECONDS even after a write that took long (a busy disk)."""
    names = tuple(f"{i:06d}.ply" for i in range(4))
    folder = OutputFolder(
        tmp_path / "out",
        str(recording),
        BatchJob(recording, tmp_path / "out").settings(),
        {},
        names,
        [recording / f for f in load_session(recording).frames[:4]],
    )

    def listed_after_add(index: int, since_last: float, last_took: float) -> bool:
        (tmp_path / "out" / names[index]).write_bytes(b"ply")
        folder._flushed, folder._flush_seconds = time.monotonic() - since_last, last_took
        folder.add([FrameRecord(index, names[index], 1, None, (1,), 100, 0.1)], {})
        return (
            len(json.loads((tmp_path / "out" / MANIFEST_FILE).read_text())["frames"]) == index + 1
        )

    try:
        assert not listed_after_add(0, MIN_FLUSH_SECONDS / 2, 0.001)
        assert listed_after_add(1, MIN_FLUSH_SECONDS * 1.5, 0.001)
        assert not listed_after_add(2, MIN_FLUSH_SECONDS * 1.5, 0.02)  # 0.02 s / 5 % = 0.4 s
        assert listed_after_add(3, MAX_FLUSH_SECONDS + 0.1, 30.0)
    finally:
        folder.close()


def test_a_killed_command_loses_only_the_frames_after_the_last_manifest(recording, tmp_path):
    """SIGKILL the command while it writes TSDF meshes (of KILLED_VOXEL: ~0.2 s a frame here, a run
    of 4 s or more, so that the manifest, written at least every MAX_FLUSH_SECONDS, lists some
    frames and not all before the end). The command is frozen (SIGSTOP) while its manifest is read,
    so the manifest read is the one the kill leaves. The rerun keeps what the manifest lists, redoes
    the rest, and every file is the one an uninterrupted run writes."""
    out, options = tmp_path / "out", replace(TSDF, voxel=KILLED_VOXEL)
    argv = [
        sys.executable,
        "-m",
        "mirrorscan.cli",
        "reconstruct",
        str(recording),
        "-o",
        str(out),
        "--frame",
        "all",
        "--workers",
        "1",
        "--method",
        "tsdf",
        "--voxel",
        str(KILLED_VOXEL),
    ]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    process = subprocess.Popen(
        argv, env=env, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    listed = {"frames": [], "complete": False}

    def frozen_with_frames() -> bool:
        """Freeze the command and read its manifest; thaw it unless two frames are listed or it
        ended."""
        nonlocal listed
        process.send_signal(signal.SIGSTOP)
        if (out / MANIFEST_FILE).exists():
            listed = json.loads((out / MANIFEST_FILE).read_text())
        if len(listed["frames"]) < 2:
            process.send_signal(signal.SIGCONT)
        return len(listed["frames"]) >= 2 or process.poll() is not None

    try:
        wait_for(frozen_with_frames, 120, "the manifest to list two frames")
        assert process.poll() is None and not listed["complete"], (
            "the run ended before it could be killed"
        )
        process.send_signal(signal.SIGKILL)
    finally:
        process.kill()
        process.wait()
    kept = len(json.loads((out / MANIFEST_FILE).read_text())["frames"])
    assert kept == len(listed["frames"]) and 2 <= kept < FRAMES
    report = run_batch(BatchJob(recording, out, "tsdf", options), IN_PROCESS)
    assert report.kept == kept and report.complete
    assert run_batch(BatchJob(recording, tmp_path / "whole", "tsdf", options), IN_PROCESS).complete
    assert ply_files(out) == ply_files(tmp_path / "whole")


def test_the_manifest_lists_a_frame_only_once_its_file_is_on_the_disk(
    recording, reference, tmp_path, monkeypatch
):
    """The workers write the frames without flushing them (no worker waits for the disk); the
    manifest's writer flushes them (fsync) before it writes the manifest that lists them, and stops
    on a frame it cannot flush."""
    from mirrorcore.base import atomic

    expected, synced, real_fsync = reference["raw"], [], os.fsync

    def fsync(fd):
        synced.append(Path(os.readlink(f"/proc/self/fd/{fd}")).name)
        real_fsync(fd)

    monkeypatch.setattr(atomic.os, "fsync", fsync)
    out = tmp_path / "out"
    run_batch(BatchJob(recording, out), IN_PROCESS, frames_per_task=4)
    assert ply_files(out) == expected
    frames = [n for n in synced if n.endswith(".ply")]
    assert sorted(frames) == sorted(expected)  # each frame once, by name
    manifests = [k for k, n in enumerate(synced) if n.startswith(f".{MANIFEST_FILE}.")]
    for k, name in enumerate(synced):
        if name.endswith(".ply"):  # flushed before the next manifest
            assert any(m > k for m in manifests), name
    monkeypatch.setattr(
        atomic.os, "fsync", lambda fd: (_ for _ in ()).throw(OSError(5, "Input/output error"))
    )
    with pytest.raises(OSError, match="Input/output error"):
        run_batch(BatchJob(recording, out), IN_PROCESS, overwrite=True)
    monkeypatch.setattr(atomic.os, "fsync", real_fsync)
    with pytest.raises(OSError, match="nowhere.ply"):
        atomic.make_durable(tmp_path / "nowhere.ply")


def test_ply_element_counts_read_the_header_alone(tmp_path):
    from mirrorcore.base.errors import FileFormatError
    from mirrorcore.io.ply import ply_element_counts, write_ply

    write_ply(
        tmp_path / "mesh.ply",
        np.zeros((4, 3)),
        np.zeros(4, np.uint8),
        np.array([[0, 1, 2], [1, 2, 3]]),
    )
    assert ply_element_counts(tmp_path / "mesh.ply") == {"vertex": 4, "face": 2}
    write_ply(tmp_path / "cloud.ply", np.zeros((5, 3)), np.ones(5, np.uint8))
    assert ply_element_counts(tmp_path / "cloud.ply") == {"vertex": 5}
    for name, data, message in (
        ("a.ply", b"solid x\n", "not a PLY file"),
        ("b.ply", b"ply\nelement vertex x\n", "not a number"),
        ("c.ply", b"ply\nformat ascii 1.0\n", "no end_header"),
    ):
        (tmp_path / name).write_bytes(data)
        with pytest.raises(FileFormatError, match=message):
            ply_element_counts(tmp_path / name)
    with pytest.raises(FileFormatError, match="no such file"):
        ply_element_counts(tmp_path / "missing.ply")
