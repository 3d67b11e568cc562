"""`mirrorscan serve` in real processes (tests.cli.serving drives its editor as the browser does):
one writer per session (a second serve opens it read-only, calibrate is refused, a killed server
frees it) and saves on a full or read-only disk (told, kept in memory, saved when the disk comes
back, and the stop message saying where the edits are)."""
import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.io.session import Session
from mirrorcore.io.sessionfile import load_session, save_session
from mirrorcore.io.sessionlock import LOCK_FILE, SessionLock
from mirrorscan.cli import main
from tests.waiting import wait_for

ROOT = Path(__file__).resolve().parents[2]
EDITS = 20


class Served:
    """A `mirrorscan serve SESSION` process taking edits on stdin (tests.cli.serving)."""

    def __init__(self, folder: Path, home: Path):
        self.process = subprocess.Popen(
            [sys.executable, "-m", "tests.cli.serving", str(folder)], cwd=ROOT,
            env={**os.environ, "PYTHONPATH": str(ROOT), "HOME": str(home)},
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        assert self.process.stdout.readline().strip() == "ready", self.stop()

    def say(self, line: str) -> str:
        """Send a command; its answer."""
        self.process.stdin.write(line + "\n")
        self.process.stdin.flush()
        return self.process.stdout.readline().strip()

    def state(self) -> dict:
        """The save error, the read-only reason and the lasting notification."""
        return json.loads(self.say("state"))

    def stop(self) -> str:
        """SIGTERM, as `mirrorscan serve` meets it; its stderr."""
        self.process.send_signal(signal.SIGTERM)
        try:
            return self.process.communicate(timeout=60)[1]
        finally:
            self.kill()

    def kill(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()


@pytest.fixture
def session(tmp_path) -> Path:
    folder = tmp_path / "scan"
    save_session(Session(folder, Intrinsics.kinect_v1()))
    return folder


def names(folder: Path) -> list[str]:
    return [m.name for m in load_session(folder).mirrors]


def test_a_second_serve_opens_the_session_read_only_and_no_edit_is_lost(session, tmp_path):
    """Two servers of one session, their edits interleaved: the second refuses each edit naming the
    first, and every edit the first made is in the file (without the lock, 15 of 40 were lost)."""
    first = Served(session, tmp_path)
    second = Served(session, tmp_path)
    try:
        answers = {first: [], second: []}
        for i in range(EDITS):
            for served, who in ((first, "a"), (second, "b")):
                answers[served].append(served.say(f"add {who}{i}"))
        assert all(a.startswith("ok") for a in answers[first]), answers[first]
        refused = f"refused not changed: the session is open read-only ({session} is being " \
                  f"edited by mirrorscan serve (pid {first.process.pid}, since "
        assert all(a.startswith(refused) for a in answers[second]), answers[second][0]
        assert second.state()["note"][0] == "Session open read-only"
        made = [f"a{i}" for i in range(EDITS)]
        assert names(session) == made
        log = second.stop()
        assert "opened read-only" in log and f"{session} was open read-only" in log
        assert first.stop().count("every edit is saved in") == 1
        assert names(session) == made and not (session / LOCK_FILE).exists()
    finally:
        first.kill()
        second.kill()


def test_calibrate_is_refused_while_serve_edits_and_a_killed_server_frees_the_session(
        session, tmp_path, capsys):
    served = Served(session, tmp_path)
    try:
        assert served.say("add left").startswith("ok")
        for method in ("scene", "markers"):
            assert main(["calibrate", str(session), "--method", method]) == 2
            error = capsys.readouterr().err
            assert re.fullmatch(
                rf"mirrorscan calibrate: error: {re.escape(str(session))} is being edited by "
                rf"mirrorscan serve \(pid {served.process.pid}, since \d\d:\d\d\); stop it first, "
                r"or wait until it ends\n", error), error
        assert served.say("rename 1 right") == "ok"
        assert names(session) == ["right"]
        served.process.kill()
        served.process.wait()
        # the kernel dropped the dead server's lock: the next writer takes it
        with SessionLock(session, "test"):
            pass
        assert main(["calibrate", str(session), "--method", "markers"]) == 2
        assert "is being edited" not in capsys.readouterr().err
    finally:
        served.kill()


def test_a_full_disk_is_told_kept_in_memory_and_saved_when_the_disk_comes_back(session,
                                                                                tmp_path):
    served = Served(session, tmp_path)
    try:
        assert served.say("add left") == "ok 1"
        assert served.say("full") == "ok"
        assert served.say("rename 1 right") == "ok"
        state = served.state()
        assert state["error"] == f"{session / 'session.json'}: No space left on device"
        assert state["note"][0] == "Session not saved" and state["note"][2] == "error"
        assert names(session) == ["left"]
        # no edit meanwhile: the server tries again by itself
        assert served.say("back") == "ok"
        wait_for(lambda: names(session) == ["right"], 20, "the kept edit to land")
        wait_for(lambda: served.state() == {"error": None, "read_only": None, "note": None}, 10,
                 "the notification to go")
        log = served.stop()
        assert "ERROR: session not saved (kept in memory, tried again): " in log
        assert f"session saved again in {session}" in log
        assert f"mirrorscan serve: stopped; every edit is saved in {session}\n" in log
    finally:
        served.kill()


def test_the_stop_message_says_where_edits_the_disk_refused_are_kept(session, tmp_path):
    served = Served(session, tmp_path)
    try:
        served.say("add left")
        served.say("full")
        served.say("rename 1 right")
        log = served.stop()
    finally:
        served.kill()
    assert "every edit is saved" not in log
    kept = re.search(rf"mirrorscan serve: stopped; the last edits are NOT saved in "
                     rf"{re.escape(str(session))} \(.*No space left on device\); they are kept in "
                     rf"(\S+): copy it over {re.escape(str(session))}/session.json once that disk "
                     r"can be written\n", log)
    assert kept, log
    assert Path(kept.group(1)).parent.parent == tmp_path / "mirrorscan-unsaved"
    assert [m.name for m in load_session(Path(kept.group(1)).parent).mirrors] == ["right"]
    assert names(session) == ["left"]


def mount(*args) -> bool:
    return subprocess.run(["mount", *args], capture_output=True).returncode == 0


@pytest.fixture
def small_disk(tmp_path):
    """A 512 kB tmpfs (skipped where mounting is not allowed)."""
    disk = tmp_path / "disk"
    disk.mkdir()
    if not mount("-t", "tmpfs", "-o", "size=512k", "tmpfs", str(disk)):
        pytest.skip("mount is not allowed here (a tmpfs needs root and CAP_SYS_ADMIN)")
    yield disk
    subprocess.run(["umount", "-l", str(disk)], capture_output=True)


def fill(disk: Path) -> Path:
    """Fill the disk up; the file that fills it."""
    filler = disk / "filler"
    fd = os.open(filler, os.O_WRONLY | os.O_CREAT)
    try:
        while os.write(fd, b"\0" * 4096):
            pass
    except OSError:
        pass
    finally:
        os.close(fd)
    return filler


def test_a_really_full_disk_is_told_and_the_edit_lands_once_space_is_freed(small_disk,
                                                                           tmp_path):
    folder = small_disk / "scan"
    save_session(Session(folder, Intrinsics.kinect_v1()))
    served = Served(folder, tmp_path)
    try:
        served.say("add left")
        filler = fill(small_disk)
        assert served.say("rename 1 right") == "ok"
        assert served.state()["error"].endswith("No space left on device")
        assert names(folder) == ["left"]
        filler.unlink()
        wait_for(lambda: names(folder) == ["right"], 20, "the kept edit to land")
        wait_for(lambda: served.state()["note"] is None, 10, "the notification to go")
        assert f"every edit is saved in {folder}" in served.stop()
    finally:
        served.kill()


def test_a_session_on_a_read_only_disk_is_served_read_only_and_says_so(session, tmp_path):
    disk = tmp_path / "disk"
    disk.mkdir()
    if not (mount("--bind", str(session), str(disk))
            and mount("-o", "remount,ro,bind", str(disk))):
        subprocess.run(["umount", str(disk)], capture_output=True)
        pytest.skip("mount is not allowed here (a bind mount needs root and CAP_SYS_ADMIN)")
    try:
        served = Served(disk, tmp_path)
        try:
            why = served.state()["read_only"]
            assert why == f"{disk}: cannot be locked for editing (Read-only file system)"
            assert served.say("add left") == f"refused not changed: the session is open " \
                                             f"read-only ({why})"
            assert f"mirrorscan serve: stopped; {disk} was open read-only: nothing was written " \
                   "to it" in served.stop()
        finally:
            served.kill()
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)
