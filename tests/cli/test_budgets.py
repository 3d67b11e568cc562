"""Every command's work sized before it starts: worker processes capped by the machine, frames by
the session limit, and what an option makes a command hold estimated against the memory budget,
each refused in one line naming the option before anything is allocated or spawned."""
from __future__ import annotations

import time

import psutil
import pytest
from mirrorscan.cli import main

from mirrorcore.base.budget import MemoryBudgetError, set_memory_budget
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.batch import BatchJob, Where, run_batch
from mirrorcore.batch.executor import WORKERS_PER_CORE, cores, max_workers
from mirrorcore.io.limits import MAX_FRAMES
from mirrorcore.io.sessionfile import load_session
from mirrorscan.experiments.temporal import run_temporal_experiment
from tests.batch_scene import recording_fixture  # noqa: F401


@pytest.fixture
def budget():
    yield set_memory_budget
    set_memory_budget(None)


def refused(capsys, argv, message, seconds: float = 10.0) -> str:
    """Run argv: exit 2 within `seconds` with `message` on one stderr line, no process started."""
    capsys.readouterr()
    children = {p.pid for p in psutil.Process().children(recursive=True)}
    start = time.monotonic()
    assert main([str(a) for a in argv]) == 2
    assert time.monotonic() - start < seconds
    out, err = capsys.readouterr()
    assert len(err.strip().splitlines()) == 1 and message in err, err
    started = {p.pid for p in psutil.Process().children(recursive=True)} - children
    assert "starting" not in out + err and not started
    return err


def test_workers_past_the_machine_are_refused_before_any_process_starts(recording, tmp_path,
                                                                        capsys):
    assert max_workers() == WORKERS_PER_CORE * cores()
    refused(capsys, ["reconstruct", recording, "-o", tmp_path / "out", "--frame", "all",
                     "--workers", 10000],
            f"--workers: at most {max_workers()} on this machine ({WORKERS_PER_CORE} per core), "
            "got 10000")
    assert not (tmp_path / "out").exists()
    assert Where(workers=max_workers()).local_workers == max_workers()
    with pytest.raises(MirrorscanError, match="--workers: at most"):
        Where(workers=max_workers() + 1)


def test_simulate_and_record_refuse_more_frames_than_a_session_holds(tmp_path, capsys):
    refused(capsys, ["simulate", tmp_path / "sim", "--frames", 2_000_000, "--quiet"],
            f"--frames: expected a whole number from 1 to {MAX_FRAMES:,}, got 2000000")
    refused(capsys, ["record", "sim", tmp_path / "rec", "--frames", MAX_FRAMES + 1,
                     "--quiet"], f"--frames: expected a whole number from 1 to {MAX_FRAMES:,}")
    assert not (tmp_path / "sim").exists() and not (tmp_path / "rec").exists()


def test_experiment_temporal_is_estimated_before_any_frame_is_rendered(tmp_path, capsys):
    """--neighbours 3000 holds 6,030 frames (7.4 GB at 640x480) and smooths 6,001 at once."""
    err = refused(capsys, ["--memory", "1G", "experiment", "temporal", "--neighbours", 3000,
                           "-o", tmp_path / "t", "--quiet"],
                  "--neighbours 3000, --frames 30: 6,030 frames of 640x480 held: needs")
    assert "more than the memory budget of 1.0 GiB" in err
    assert not list(tmp_path.iterdir())


def test_a_small_temporal_experiment_fits(budget):
    budget("64M")
    with pytest.raises(MemoryBudgetError, match="--neighbours 100, --frames 30"):
        run_temporal_experiment(100, 30, scale=0.25, progress=False)
    # 34 frames of 160x120 (2.6 MB) and a window of 5
    rows = run_temporal_experiment(2, 1, scale=0.25, progress=False)
    assert [r["part"] for r in rows] == ["still", "moving"]


def test_temporal_and_fused_frames_are_estimated_before_they_are_read(recording, tmp_path,
                                                                      capsys, budget):
    """A window of --temporal N frames (single frame and batch) and --frames N fused by tsdf are
    held at once: refused under a budget they do not fit, in one line naming the option."""
    frames = len(load_session(recording).frames)
    refused(capsys, ["--memory", "3M", "reconstruct", recording, "-o", tmp_path / "one.ply",
                     "--temporal", 3000],
            f"--temporal 3000: {frames} frames of 160x120 at once: needs")
    budget("3M")
    with pytest.raises(MemoryBudgetError, match=f"--temporal 3000: {frames} frames of 160x120"):
        run_batch(BatchJob(recording, tmp_path / "batch", temporal=3000), Where(workers=1))
    assert not (tmp_path / "batch" / "manifest.json").exists()
    refused(capsys, ["--memory", "3M", "reconstruct", recording, "-o", tmp_path / "fused.ply",
                     "--method", "tsdf", "--frames", frames],
            f"--frames {frames}: {frames} frames of 160x120 at once: needs")
