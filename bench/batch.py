"""Benchmark of batch reconstruction (`reconstruct --frame all`, mirrorcore.batch): a 640x480 recording of the walking
figure with two mirrors (Kinect v1 noise), Algorithm 1 on every frame, each frame's PLY written to disk, on local Dask
clusters of 1 and of 2 worker processes (one thread each) and in this process (`--workers 1`), measured in
alternation; cluster start-up excluded.

batch_fps_per_core : frames per second with 2 workers, per worker (one core each)
batch_scaling : the throughput of 2 workers over that of 1 worker (2.0 is perfect)
batch_fps_in_process : `--workers 1`, without Dask (OpenCV may use several threads there)
"""
from __future__ import annotations

import shutil
import statistics
import tempfile
from pathlib import Path

from mirrorcore.batch import BatchJob, Where, run_batch
from mirrorcore.batch.cluster import dask_client
from mirrorcore.sim.export import write_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator

FRAMES = 120
ROUNDS = 3


def recording(folder: Path, frames: int = FRAMES) -> Path:
    """The benchmark's recording, calibrated with the true planes."""
    sim = Simulator(paper_scene(object="figure", distance=3.0), seed=0)
    return write_session(sim, folder, frames, progress=False, true_planes=True)


def throughput(session: Path, out: Path, workers: int) -> float:
    """Frames written per second by a fresh run on a new local cluster of `workers` processes (0: in this process),
    start-up excluded."""
    shutil.rmtree(out, ignore_errors=True)
    if workers == 0:
        report = run_batch(BatchJob(session, out), Where(workers=1))
    else:
        with dask_client(workers, None, dashboard=False) as client:
            report = run_batch(BatchJob(session, out), Where(scheduler=client.scheduler.address))
    assert report.complete and not report.failed, report
    return report.fps


def run() -> dict[str, float]:
    with tempfile.TemporaryDirectory(prefix="mirrorscan-bench-batch-") as tmp:
        session = recording(Path(tmp) / "walk")
        fps: dict[int, list[float]] = {0: [], 1: [], 2: []}
        for _ in range(ROUNDS):
            for workers in fps:
                fps[workers].append(throughput(session, Path(tmp) / "out", workers))
    in_process, one, two = (statistics.median(fps[w]) for w in (0, 1, 2))
    return {"batch_fps_per_core": two / 2, "batch_scaling": two / one, "batch_fps_1_worker": one,
            "batch_fps_2_workers": two, "batch_fps_in_process": in_process}
