"""Recordings are never lost and never stuck: a recording is a valid session at every moment (real
processes killed with SIGKILL, stopped with SIGTERM and SIGHUP), Stop always returns, one recording
at a time per live loop, and recordings started in the same second get folders of their own."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import mirrorscan.jobs.recording as recording_job
from mirrorscan.recording import LiveTap

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.io.sessionfile import load_session, save_session
from mirrorcore.io.sessionlock import SessionLock, SessionLocked
from mirrorcore.sources import DepthSource, Frame, Recorder, new_recording_folder
from tests.waiting import wait_for

ROOT = Path(__file__).resolve().parents[2]
CAMERA = Intrinsics(64, 48, 60.0, 60.0, 31.5, 23.5)

RECORDER_SCRIPT = """
import sys, time
from mirrorcore.sources import Recorder, open_source
Recorder(open_source("sim"), sys.argv[1]).start()
time.sleep(600)  # deliberate: the recorder runs until the test kills it
"""


def depth_files(folder: Path) -> list[str]:
    """The depth frames' file names in the session's frames/ folder, in order."""
    return sorted(p.name for p in (folder / "frames").glob("[0-9]*.png")
                  if not p.stem.endswith("_colour"))


def colour_files(folder: Path) -> list[str]:
    """The colour frames' file names in the session's frames/ folder, in order."""
    return sorted(p.name for p in (folder / "frames").glob("[0-9]*_colour.png"))


def _env() -> dict:
    return {**os.environ, "PYTHONPATH": str(ROOT)}


def _listed(folder: Path) -> int:
    """Frames that session.json lists now (0 while it is missing or being replaced)."""
    try:
        return len(load_session(folder).frames)
    except MirrorscanError:
        return 0


def _wait_for_frames(process: subprocess.Popen, folder: Path, count: int,
                     timeout: float = 90.0) -> None:
    """Wait until the recording's session.json lists `count` frames; fails when the process
    exits first."""
    def listed() -> bool:
        assert process.poll() is None, process.stderr.read()[-2000:] if process.stderr else "exited"
        return _listed(folder) >= count

    wait_for(listed, timeout, f"{count} frames listed")


def _check_opens_with_its_frames(folder: Path) -> int:
    """The session opens, lists only whole frames, each readable, and no more than one second's
    worth are unlisted."""
    session = load_session(folder)
    for i in range(len(session.frames)):
        assert session.read_frame(i).shape == session.camera.shape
    on_disk = depth_files(folder)
    assert [Path(f).name for f in session.frames] == on_disk[:len(session.frames)]
    # at most ~1 s of frames after the last save
    assert len(on_disk) - len(session.frames) <= 60
    assert len(session.timestamps) == len(session.frames)
    return len(session.frames)


@pytest.mark.parametrize("how", ["command", "recorder"])
def test_a_recording_killed_with_sigkill_opens_with_its_frames(tmp_path, how):
    folder = tmp_path / "take"
    command = [sys.executable, "-m", "mirrorscan.cli", "record", "sim", str(folder), "--quiet"]
    argv = command if how == "command" else [sys.executable, "-c", RECORDER_SCRIPT, str(folder)]
    process = subprocess.Popen(argv, cwd=ROOT, env=_env(), stderr=subprocess.PIPE, text=True)
    try:
        _wait_for_frames(process, folder, 8)
        time.sleep(0.3)  # deliberate: the kill lands between two saves, not right after one
        process.kill()
        process.wait(10)
    finally:
        if process.poll() is None:
            process.kill()
    assert _check_opens_with_its_frames(folder) >= 8


@pytest.mark.parametrize("signum, status", [(signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_record_stops_cleanly_on_sigterm_and_sighup(tmp_path, signum, status):
    folder = tmp_path / "take"
    command = [sys.executable, "-m", "mirrorscan.cli", "record", "sim", str(folder), "--quiet"]
    process = subprocess.Popen(command, cwd=ROOT, env=_env(), stderr=subprocess.PIPE, text=True)
    try:
        _wait_for_frames(process, folder, 5)
        process.send_signal(signum)
        _, err = process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == status, err
    assert f"stopped by {signal.Signals(signum).name}" in err
    session = load_session(folder)
    # every frame written is listed, and its colour image (the simulated source has colour)
    assert [Path(f).name for f in session.frames] == depth_files(folder)
    assert [Path(f).name for f in session.colour_frames or ()] == colour_files(folder)
    assert not list(folder.rglob(".*.tmp"))


class _Stalled(DepthSource):
    """A live source whose camera stops delivering after `good` frames (a read then blocks until
    released)."""

    def __init__(self, good: int):
        self.name, self.intrinsics = "stalled", CAMERA
        self.fps, self.frame_count = 30.0, None
        self.good, self.release = good, threading.Event()

    def read(self, i: int) -> Frame:
        if i >= self.good:
            self.release.wait(30)
        return Frame(np.full(CAMERA.shape, 1.5, np.float32), i / 30)


def test_stop_returns_even_when_the_source_is_stuck(tmp_path):
    source = _Stalled(good=3)
    recorder = Recorder(source, tmp_path / "r").start()
    wait_for(lambda: recorder.frames >= 3, what="3 frames recorded")
    t0 = time.monotonic()
    with pytest.raises(MirrorscanError,
                       match="did not end within 0.5 s .* 3 frames are saved there"):
        recorder.stop(timeout=0.5)
    # the point: Stop returns long before the stuck read's 30 s
    assert time.monotonic() - t0 < 10
    source.release.set()
    recorder._thread.join(5)
    # it stopped after the stalled read: no more frames
    assert not recorder._thread.is_alive()
    assert len(load_session(tmp_path / "r").frames) == 4


def _loop() -> SimpleNamespace:
    """What LiveTap uses of the app: the source and a way to subscribe to its frames (here, a list
    of listeners)."""
    listeners: list = []

    def subscribe(take):
        listeners.append(take)
        return lambda: listeners.remove(take)
    source = SimpleNamespace(name="sim", intrinsics=CAMERA, fps=30.0, background=lambda: None,
                             truth=lambda: None,
                             frame_count=None)
    return SimpleNamespace(source=source, listeners=listeners,
                           tap=lambda: LiveTap(source, subscribe))


def _live_frame(i: int) -> SimpleNamespace:
    return SimpleNamespace(depth=np.full(CAMERA.shape, 1.0 + i, np.float32), timestamp=i / 30,
                           index=i)


def test_a_recording_that_plays_is_recorded_up_to_its_last_frame_and_none_twice():
    """Recording a session as it plays: the tap ends where the replay starts over (no frame
    recorded twice, no time running back), and a frame processed again (paused) is taken once."""
    loop = _loop()
    loop.source.frame_count = 5
    tap = loop.tap()
    # live indices: frames 3, 4, 4, then 0, 1, 2
    for i in (3, 4, 4, 5, 6, 7):
        for listener in list(loop.listeners):
            listener(_live_frame(i))
    assert tap.replay_ended
    tap.close()
    assert [frame.timestamp for frame in tap] == [3 / 30, 4 / 30]


def test_closing_a_full_tap_never_blocks_and_delivers_what_it_took():
    loop = _loop()
    tap = loop.tap()
    # nobody reads: the queue fills, then drops
    for i in range(500):
        for listener in list(loop.listeners):
            listener(_live_frame(i))
    assert tap.dropped > 0
    done = threading.Event()
    threading.Thread(target=lambda: (tap.close(), done.set()), daemon=True).start()
    assert done.wait(2), "close() blocked on the full queue"
    # the frames taken before close, then the end
    taken = list(tap)
    assert len(taken) == 500 - tap.dropped and taken[0].timestamp == 0
    assert not loop.listeners


def test_one_recording_at_a_time_on_a_live_loop_and_stop_after_stop():
    loop = _loop()
    first = loop.tap()
    with pytest.raises(MirrorscanError, match="already recording"):
        loop.tap()
    first.close()
    # twice: nothing
    first.close()
    # Record again after Stop
    second = loop.tap()
    second.close()


def test_record_stop_record_within_a_second_records_both(tmp_path):
    loop = _loop()
    sessions = []
    for take in range(2):
        tap = loop.tap()
        recorder = Recorder(tap, new_recording_folder(tmp_path)).start()
        for i in range(5):
            for listener in list(loop.listeners):
                listener(_live_frame(i))
        wait_for(lambda: recorder.frames >= 5, what="5 frames recorded")
        tap.close()
        sessions.append(recorder.stop(timeout=5))
    assert sessions[0].root != sessions[1].root
    assert [len(load_session(s.root).frames) for s in sessions] == [5, 5]


def test_recordings_started_in_the_same_second_get_their_own_folders(tmp_path):
    folders, barrier = [], threading.Barrier(8)

    def start() -> None:
        barrier.wait()
        folders.append(new_recording_folder(tmp_path))

    threads = [threading.Thread(target=start) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(set(folders)) == 8 and all(f.is_dir() and not any(f.iterdir()) for f in folders)


def test_the_browser_recording_is_saved_under_its_folder_lock(demo, tmp_path, monkeypatch):
    """Stop saves the recording with the session's mirrors while it holds the folder's lock: no
    other writer can take the folder between the recorder's end and that save."""
    app, _ = demo
    saved = []

    def save_while_locked(session) -> None:
        with pytest.raises(SessionLocked):
            SessionLock(session.root, "another writer")
        saved.append(session)
        save_session(session)

    monkeypatch.setattr(recording_job, "save_session", save_while_locked)
    folder = app.jobs.start_recording(tmp_path)
    wait_for(lambda: app.loop.run_once() is not None and app.jobs.recorder.frames >= 2, 30,
             "2 frames recorded")
    recorded = app.jobs.stop_recording(app.editor.session)
    assert [s.root for s in saved] == [recorded.root] and recorded.root == folder
    assert load_session(folder).mirrors == app.editor.session.mirrors
    # and released after it
    SessionLock(folder, "another writer").release()
