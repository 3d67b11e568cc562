"""One writer at a time per session folder: an OS lock (flock) on SESSION/session.lock, which the
kernel drops when its holder dies, and the file names who holds it.

The lock is per open file description: a second lock in the same process conflicts with the first
as one in another process does. Readers take no lock.
"""
from __future__ import annotations

import errno
import fcntl
import json
import os
import socket
import time
from dataclasses import dataclass
from pathlib import Path

from mirrorcore.base.errors import MirrorscanError

LOCK_FILE = "session.lock"
_HOLDER_BYTES = 4096          # a holder's line is about 100 bytes; more is not a holder's


@dataclass(frozen=True)
class Holder:
    """Who holds a session's lock.

    Attributes
    ----------
    command : str
        What edits it, e.g. 'mirrorscan serve'.
    pid : int
        Its process id.
    host : str
        The machine it runs on.
    since : float
        When it took the lock, seconds since the epoch.
    """

    command: str
    pid: int
    host: str
    since: float

    def describe(self) -> str:
        """'mirrorscan serve (pid 1234, since 07:12)'; the host is named when it is another."""
        where = "" if self.host == socket.gethostname() else f" on {self.host}"
        since = time.strftime("%H:%M", time.localtime(self.since))
        return f"{self.command} (pid {self.pid}{where}, since {since})"


class SessionLocked(MirrorscanError):
    """The session folder is being edited by another holder of its lock.

    Parameters
    ----------
    folder : Path
        The session folder.
    holder : Holder or None
        Who holds it, when its file says so.

    Attributes
    ----------
    folder, holder
        As given.
    """

    def __init__(self, folder: Path, holder: Holder | None):
        who = holder.describe() if holder else "another program"
        super().__init__(f"{folder} is being edited by {who}; stop it first, or wait until it ends")
        self.folder, self.holder = folder, holder


class SessionUnwritable(MirrorscanError):
    """The session folder cannot be locked for editing: it cannot be written (read-only, no
    permission, full)."""


class SessionLock:
    """The lock on one session folder, held from construction until `release`.

    Parameters
    ----------
    folder : str or Path
        The session folder.
    command : str
        What takes it, as the holder's file names it ('mirrorscan calibrate').

    Attributes
    ----------
    folder : Path
        The session folder.
    holder : Holder
        This process.

    Raises
    ------
    SessionLocked
        Another open lock holds the folder (in this process or another).
    SessionUnwritable
        The lock file cannot be made (a read-only folder, no permission).
    MirrorscanError
        There is no such folder.
    """

    def __init__(self, folder: str | Path, command: str):
        self._fd: int | None = None
        self.folder = Path(folder)
        self.holder = Holder(command, os.getpid(), socket.gethostname(), time.time())
        self._fd = _take(self.folder / LOCK_FILE)
        line = json.dumps({"command": command, "pid": self.holder.pid,
                           "host": self.holder.host, "since": self.holder.since}) + "\n"
        try:
            os.ftruncate(self._fd, 0)
            os.pwrite(self._fd, line.encode("utf-8"), 0)
        except OSError:
            # a full disk: held all the same, its holder unnamed ("another program")
            pass

    @property
    def held(self) -> bool:
        """Whether it is still held."""
        return self._fd is not None

    def release(self) -> None:
        """Remove the lock file and let the lock go; nothing when already released."""
        if self._fd is None:
            return
        fd, self._fd = self._fd, None
        try:
            # removed while still held: a taker checks that the file it locked is the one named
            (self.folder / LOCK_FILE).unlink(missing_ok=True)
        except OSError:
            # a folder gone read-only keeps the file, naming a holder that no longer holds it
            pass
        finally:
            os.close(fd)

    def __enter__(self) -> SessionLock:
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def __del__(self):
        self.release()


def _take(path: Path) -> int:
    """Open and flock `path` without waiting; the file descriptor, or SessionLocked."""
    for _ in range(8):
        fd = _open(path)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise SessionLocked(path.parent, lock_holder(path.parent)) from None
        except OSError as exc:
            os.close(fd)
            raise SessionUnwritable(
                f"{path.parent}: cannot be locked for editing ({exc.strerror})") from None
        # the holder before may have removed the file as this one opened it: lock the one named
        try:
            same = os.stat(path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            return fd
        os.close(fd)
    raise MirrorscanError(f"{path}: kept changing while it was locked; try again")


def _open(path: Path) -> int:
    """The lock file opened for writing, created when missing."""
    if not path.parent.is_dir():
        raise MirrorscanError(f"{path.parent}: no such session folder")
    try:
        return os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    except OSError as exc:
        if exc.errno in (errno.EROFS, errno.EACCES, errno.EPERM, errno.ENOSPC, errno.EDQUOT):
            raise SessionUnwritable(
                f"{path.parent}: cannot be locked for editing ({exc.strerror})") from None
        raise


def lock_holder(folder: str | Path) -> Holder | None:
    """Who its lock file says holds the session folder's lock.

    Only meaningful while the lock is held (a taker was just refused): the file of a killed holder
    still names it.

    Parameters
    ----------
    folder : str or Path
        The session folder.

    Returns
    -------
    Holder or None
        None when there is no lock file or it does not say who.
    """
    path = Path(folder) / LOCK_FILE
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return None
    try:
        data = json.loads(os.pread(fd, _HOLDER_BYTES, 0).decode("utf-8"))
        return Holder(str(data["command"]), int(data["pid"]), str(data["host"]),
                      float(data["since"]))
    except (ValueError, KeyError, TypeError, OSError):
        return None
    finally:
        os.close(fd)
