"""Batch reconstruction on real Dask clusters started inside the tests (two worker processes on
127.0.0.1): the same files, byte for byte, as in this process; a worker killed mid-run and every
frame still done, the frames it held reported and run again; an interrupted run resumed; the
command's own cluster leaves nothing behind (processes, ports, scratch folders)."""

import os
import re
import signal
import socket
import tempfile
import threading

import pytest

from tests.batch_scene import FRAMES, OPTIONS, child_processes, ply_files
from tests.batch_scene import recording_fixture, reference_fixture  # noqa: F401

from mirrorscan.cli import main
from tests.cli.output import headlines
from tests.waiting import wait_for
from mirrorcore.batch import BatchJob, BatchRun, Where, run_batch
from mirrorcore.batch.cluster import dask_client

TSDF = OPTIONS["tsdf"]


@pytest.fixture(scope="module")
def cluster():
    """A local cluster of two worker processes (as the command starts it) and their process ids;
    afterwards, every process it started is gone."""
    before = set(child_processes())
    with dask_client(2, None, dashboard=False) as client:
        yield client.scheduler.address, list(client.run(os.getpid).values())
    assert _gone(set(child_processes()) - before)


def _gone(pids: set[int], seconds: float = 10.0) -> bool:
    """Whether the processes `pids` end within `seconds` (else AssertionError)."""
    return wait_for(
        lambda: not pids & set(child_processes()), seconds, f"processes {sorted(pids)} to end"
    )


def test_a_cluster_writes_the_same_files_as_this_process(recording, reference, cluster, tmp_path):
    address, _ = cluster
    seen = []
    report = run_batch(
        BatchJob(recording, tmp_path / "out"),
        Where(scheduler=address),
        frames_per_task=2,
        progress=seen.append,
    )
    assert report.complete and report.written == FRAMES and not report.failed and not report.retried
    assert ply_files(tmp_path / "out") == reference["raw"]
    assert seen[-1].done == FRAMES and seen[-1].dashboard == report.dashboard


def test_a_worker_killed_mid_run_has_its_frames_run_again(recording, reference, cluster, tmp_path):
    address, pids = cluster
    killed = []

    def kill_once(progress):
        if progress.done >= 2 and not killed:  # both workers are busy with the tasks still to do
            os.kill(pids[0], signal.SIGKILL)
            killed.append(progress.done)

    report = run_batch(
        BatchJob(recording, tmp_path / "out", "tsdf", TSDF),
        Where(scheduler=address),
        frames_per_task=2,
        progress=kill_once,
    )
    assert killed and killed[0] < FRAMES
    said = f"written {report.written}, failed {report.failed}, retried {report.retried}"
    assert report.complete and not report.failed, said
    assert report.retried and set(report.retried) <= set(range(FRAMES)), said
    assert len(set(report.retried.values())) == 1, said  # one worker died
    assert ply_files(tmp_path / "out") == reference["tsdf"]


def test_an_interrupted_run_resumes(recording, reference, cluster, tmp_path):
    address, _ = cluster
    cancel = threading.Event()
    job = BatchJob(recording, tmp_path / "out")
    first = run_batch(
        job,
        Where(scheduler=address),
        frames_per_task=2,
        progress=lambda p: p.done >= 2 and cancel.set(),
        cancel=cancel,
    )
    assert first.cancelled and 2 <= first.written < FRAMES
    second = run_batch(job, Where(scheduler=address), frames_per_task=2)
    assert second.kept == first.written and second.complete
    assert ply_files(tmp_path / "out") == reference["raw"]


def test_the_command_on_two_local_workers_leaves_nothing_behind(
    recording, reference, tmp_path, capsys, monkeypatch
):
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    before = set(child_processes())
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
                "--workers",
                "2",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "starting 2 local Dask workers" in out and "; every frame is done." in out
    headlines(out)
    assert ply_files(tmp_path / "out") == reference["raw"]
    port = int(re.search(r"Dask dashboard: http://127\.0\.0\.1:(\d+)/status", out).group(1))
    assert _gone(set(child_processes()) - before)
    assert list((tmp_path / "tmp").iterdir()) == []  # the scratch folder is gone
    with socket.socket() as s:
        assert s.connect_ex(("127.0.0.1", port)) != 0  # and so is the scheduler


def test_a_batch_run_in_a_thread_starts_its_own_cluster(recording, reference, tmp_path):
    """As the browser tool starts one: a BatchRun (a thread of this process) with a local cluster of
    two workers."""
    before = set(child_processes())
    seen = []
    run = BatchRun(
        BatchJob(recording, tmp_path / "out"),
        Where(workers=2, dashboard=False),
        frames_per_task=2,
        on_progress=seen.append,
    ).start()
    report = run.wait(timeout=300)
    assert report.complete and ply_files(tmp_path / "out") == reference["raw"]
    assert seen[0].done == 0 and seen[-1].done == FRAMES and seen[-1].dashboard is None
    assert _gone(set(child_processes()) - before)
