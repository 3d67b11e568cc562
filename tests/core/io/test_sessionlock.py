"""The lock of a session folder's one writer (mirrorcore.io.sessionlock): refused in one line naming
its holder, in this process as in another; dropped by the kernel when its holder dies; its file
gone once released and never copied with the session."""
import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.io.session import Session, SessionMirror
from mirrorcore.io.sessionfile import copy_session, save_session
from mirrorcore.io.sessionlock import (LOCK_FILE, SessionLock, SessionLocked, SessionUnwritable,
                                       lock_holder)

ROOT = Path(__file__).resolve().parents[3]
HOLD = """
import sys, time
from mirrorcore.io.sessionlock import SessionLock
lock = SessionLock(sys.argv[1], "mirrorscan calibrate")
print("held", flush=True)
time.sleep(600)  # held until the test kills it
"""


def test_a_second_lock_in_the_same_process_is_refused_naming_the_first(tmp_path):
    with SessionLock(tmp_path, "mirrorscan serve") as first:
        assert lock_holder(tmp_path) == first.holder
        with pytest.raises(SessionLocked) as refused:
            SessionLock(tmp_path, "mirrorscan calibrate")
        since = time.strftime("%H:%M", time.localtime(first.holder.since))
        assert str(refused.value) == (f"{tmp_path} is being edited by mirrorscan serve (pid "
                                      f"{os.getpid()}, since {since}); stop it first, or wait "
                                      "until it ends")
        assert refused.value.holder == first.holder
    assert not first.held and not (tmp_path / LOCK_FILE).exists()
    SessionLock(tmp_path, "mirrorscan calibrate").release()


def test_a_lock_of_another_process_is_refused_until_the_kernel_drops_it_with_its_holder(tmp_path):
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(tmp_path)], stdout=subprocess.PIPE,
                              text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    try:
        assert holder.stdout.readline() == "held\n"
        with pytest.raises(SessionLocked, match=re.escape(
                f"is being edited by mirrorscan calibrate (pid {holder.pid}, since ")):
            SessionLock(tmp_path, "mirrorscan serve")
        holder.kill()
        holder.wait()
        # its file stays, naming the dead holder; the lock does not
        assert lock_holder(tmp_path).pid == holder.pid
        with SessionLock(tmp_path, "mirrorscan serve") as taken:
            assert lock_holder(tmp_path) == taken.holder
    finally:
        holder.kill()


def test_two_threads_racing_for_a_lock_never_both_hold_it(tmp_path):
    """A release removes the file while another opens it: the taker locks only the file named."""
    held, clashes = [], []
    start = threading.Barrier(4)

    def take() -> None:
        start.wait()
        for _ in range(200):
            try:
                lock = SessionLock(tmp_path, "test")
            except SessionLocked:
                continue
            held.append(1)
            if len(held) > 1:
                clashes.append(1)
            held.pop()
            lock.release()
    threads = [threading.Thread(target=take) for _ in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert clashes == []


def test_a_folder_that_is_missing_or_cannot_be_written_is_refused_in_one_line(tmp_path):
    with pytest.raises(MirrorscanError, match=re.escape(f"{tmp_path / 'no'}: no such session "
                                                        "folder")):
        SessionLock(tmp_path / "no", "test")
    disk = tmp_path / "disk"
    disk.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k,ro", "tmpfs", str(disk)],
                             capture_output=True).returncode == 0
    if not mounted:
        pytest.skip("mount is not allowed here (a tmpfs needs root and CAP_SYS_ADMIN)")
    try:
        with pytest.raises(SessionUnwritable, match=re.escape(
                f"{disk}: cannot be locked for editing (Read-only file system)")):
            SessionLock(disk, "test")
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)


def test_a_locked_session_is_copied_without_its_lock(tmp_path):
    session = Session(tmp_path / "scan", Intrinsics.kinect_v1(), (SessionMirror("left"),))
    save_session(session)
    with SessionLock(session.root, "mirrorscan serve"):
        copy_session(session, tmp_path / "copy")
    assert sorted(p.name for p in (tmp_path / "copy").iterdir()) == ["session.json"]
