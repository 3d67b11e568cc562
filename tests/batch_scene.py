"""A short recording for the batch tests: the simulator's walking figure (two mirrors at 120 deg,
Kinect v1 noise) at a quarter of 640x480, written as a session folder with the true planes (a
perfect calibration); the fixtures `recording` and `reference` (the files a run in this process
writes, per method), imported by the test modules."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from mirrorcore.batch import BatchJob, Where, run_batch
from mirrorcore.dense import DenseOptions
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.sim.export import write_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator

FRAMES = 20
IN_PROCESS = Where(workers=1)
OPTIONS = {"raw": DenseOptions(), "tsdf": DenseOptions(voxel=0.015)}   # TSDF: ~0.06 s a frame here


def walking_recording(folder: Path, frames: int = FRAMES, scale: float = 0.25) -> Path:
    """Write the session folder `folder` and return it."""
    sim = Simulator(
        paper_scene(object="figure", distance=3.0, camera=Intrinsics.kinect_v1().scaled(scale)),
        seed=0,
    )
    return write_session(sim, folder, frames, progress=False, true_planes=True)


@pytest.fixture(scope="module", name="recording")
def recording_fixture(tmp_path_factory):
    return walking_recording(tmp_path_factory.mktemp("batch") / "walk")


class References:
    """{method: {file name: bytes}} of every frame of `recording` written in this process, made on
    first use."""

    def __init__(self, recording: Path, folder: Path):
        self.recording, self.folder, self.files = recording, folder, {}

    def __getitem__(self, method: str) -> dict[str, bytes]:
        if method not in self.files:
            report = run_batch(
                BatchJob(self.recording, self.folder / method, method, OPTIONS[method]), IN_PROCESS
            )
            assert report.complete and report.written == FRAMES
            self.files[method] = ply_files(self.folder / method)
        return self.files[method]


@pytest.fixture(scope="module", name="reference")
def reference_fixture(recording, tmp_path_factory):
    return References(recording, tmp_path_factory.mktemp("reference"))


def ply_files(folder: Path) -> dict[str, bytes]:
    """{file name: bytes} of the PLY files in a folder."""
    return {p.name: p.read_bytes() for p in sorted(Path(folder).glob("*.ply"))}


def child_processes() -> list[int]:
    """The process ids of this process's living children, but multiprocessing's resource tracker
    (one per Python process once it has spawned a child, ending with it) and zombies."""
    import psutil

    found = []
    for p in psutil.Process(os.getpid()).children(recursive=True):
        try:
            if (
                p.status() != psutil.STATUS_ZOMBIE
                and "multiprocessing.resource_tracker" not in " ".join(p.cmdline())
            ):
                found.append(p.pid)
        except psutil.NoSuchProcess:
            continue
    return found
