"""Benchmark of batch reconstruction (`reconstruct --frame all`, mirrorcore.batch).

A 640x480 recording of the walking figure with two mirrors (Kinect v1 noise), Algorithm 1 on every
frame, each frame's PLY written to disk, on local Dask clusters of 1 and of 2 worker processes (one
thread each) and in this process (`--workers 1`), measured in alternation; cluster start-up
excluded.

batch_fps_per_core : frames per second with 2 workers, per worker (one core each)
batch_scaling : the throughput of 2 workers over that of 1 worker (2.0 is perfect)
batch_fps_in_process : `--workers 1`, without Dask (OpenCV may use several threads there)
batch_cpu_ms_per_frame : CPU time of every process (this one, with the scheduler, and the 2 workers)
    per frame: what a frame costs whatever else the machine runs (the wall-clock figures need the
    cores to themselves)
"""

from __future__ import annotations

import shutil
import statistics
import tempfile
from pathlib import Path

import psutil

from mirrorcore.batch import BatchJob, Where, run_batch
from mirrorcore.batch.cluster import dask_client
from mirrorcore.sim.export import write_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator

FRAMES = 120
ROUNDS = 3


def recording(folder: Path, frames: int = FRAMES) -> Path:
    """The benchmark's recording, calibrated with the true planes.

    Parameters
    ----------
    folder : Path
        The session folder to write.
    frames : int, optional

    Returns
    -------
    Path
        The session folder.
    """
    sim = Simulator(paper_scene(object="figure", distance=3.0), seed=0)
    return write_session(sim, folder, frames, progress=False, true_planes=True)


def cpu_seconds() -> float:
    """User and system CPU seconds of this process and its living children."""
    me = psutil.Process()
    total = 0.0
    for process in (me, *me.children(recursive=True)):
        try:
            times = process.cpu_times()
        except psutil.NoSuchProcess:
            continue
        total += times.user + times.system
    return total


def throughput(session: Path, out: Path, workers: int) -> tuple[float, float]:
    """Frames written per second and CPU milliseconds per frame of a fresh run.

    On a new local cluster of `workers` processes (0: in this process), from the first task on
    (cluster start-up and shipping the rig excluded).

    Parameters
    ----------
    session : Path
        The recording.
    out : Path
        The output folder (removed first).
    workers : int

    Returns
    -------
    fps : float
    cpu_ms : float
    """
    shutil.rmtree(out, ignore_errors=True)
    started: list[float] = []

    def first_progress(_progress) -> None:  # called once the tasks are submitted, then after each
        if not started:
            started.append(cpu_seconds())

    if workers == 0:
        report = run_batch(BatchJob(session, out), Where(workers=1), progress=first_progress)
        cpu = cpu_seconds() - started[0]
    else:
        with dask_client(workers, None, dashboard=False) as client:
            report = run_batch(
                BatchJob(session, out),
                Where(scheduler=client.scheduler.address),
                progress=first_progress,
            )
            cpu = cpu_seconds() - started[0]
    assert report.complete and not report.failed, report
    return report.fps, 1e3 * cpu / report.written


def run() -> dict[str, float]:
    """The batch's frame rate in this process and on 1 and 2 local workers (median of ROUNDS runs).

    Returns
    -------
    dict of str to float
        {figure name: value}; names ending in _ms are median milliseconds.
    """
    with tempfile.TemporaryDirectory(prefix="mirrorscan-bench-batch-") as tmp:
        session = recording(Path(tmp) / "walk")
        runs: dict[int, list[tuple[float, float]]] = {0: [], 1: [], 2: []}
        for _ in range(ROUNDS):
            for workers, results in runs.items():
                results.append(throughput(session, Path(tmp) / "out", workers))
    fps = {w: statistics.median(r[0] for r in results) for w, results in runs.items()}
    return {
        "batch_fps_per_core": fps[2] / 2,
        "batch_scaling": fps[2] / fps[1],
        "batch_fps_1_worker": fps[1],
        "batch_fps_2_workers": fps[2],
        "batch_fps_in_process": fps[0],
        "batch_cpu_ms_per_frame": statistics.median(r[1] for r in runs[2]),
    }
