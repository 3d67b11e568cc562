"""session.json as the browser tool edits it: its folder locked, every save known to have worked
or kept in memory and tried again, a copy kept elsewhere when it cannot be saved, and a change made
by another program (`mirrorscan calibrate SESSION` in a terminal) told and read."""
from __future__ import annotations

import logging
import os
import tempfile
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import Callable

from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.io.session import SESSION_FILE, Session
from mirrorcore.io.sessionfile import load_session, save_session
from mirrorcore.io.sessionlock import SessionLock

log = logging.getLogger("mirrorscan")
EDITOR = "mirrorscan serve"     # who holds the lock of the session under edit

Stamp = tuple[int, int, int]


def stamp(path: str | Path) -> Stamp | None:
    """What tells a file's versions apart.

    An atomic write replaces the inode, so two versions written within one tick of the clock still
    differ.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    tuple of int or None
        (inode, modification time in ns, size in bytes); None when the file does not exist.
    """
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return None
    return st.st_ino, st.st_mtime_ns, st.st_size


class SessionFile:
    """session.json as the editor last read or wrote it, and the lock on its folder.

    Parameters
    ----------
    session : Session
        The session whose file is stamped now.
    lock : bool, optional
        Lock its folder (SessionLock) until `close`.

    Attributes
    ----------
    stamp : tuple of int or None
        The file's stamp (see `stamp`) when the editor last read or wrote it.
    error : str or None
        Why saving fails, until a save works, else None.

    Raises
    ------
    SessionLocked
        Another editor (in this process or another) holds the folder.
    MirrorscanError
        The folder cannot be locked (read-only).
    """

    def __init__(self, session: Session, lock: bool = False):
        self.stamp = stamp(session.path)
        self.error: str | None = None
        self._tried = 0.0           # time.monotonic() of the last save that failed
        if lock and not Path(session.root).exists():
            # a new session, saved at its first change
            Path(session.root).mkdir(parents=True)
        self._held = SessionLock(session.root, EDITOR) if lock else None
        self._claimed: SessionLock | None = None

    def claim(self, root: str | Path) -> None:
        """Lock another session's folder for `take`.

        Parameters
        ----------
        root : str or Path
            Its folder.

        Raises
        ------
        SessionLocked, MirrorscanError
            As the constructor.
        """
        held = self._held
        if held is not None and Path(held.folder).resolve() == Path(root).resolve():
            return
        if self._claimed is not None:
            self._claimed.release()
            self._claimed = None
        self._claimed = SessionLock(root, EDITOR)

    def take(self, session: Session) -> None:
        """Edit another session from now on: its folder locked (`claim`), the previous let go.

        Parameters
        ----------
        session : Session

        Raises
        ------
        SessionLocked, MirrorscanError
            As the constructor; nothing changed.
        """
        self.claim(session.root)
        if self._claimed is not None:
            if self._held is not None:
                self._held.release()
            self._held, self._claimed = self._claimed, None
        self.error = None
        self.written(session)

    def close(self) -> None:
        """Let the folder go."""
        for lock in (self._held, self._claimed):
            if lock is not None:
                lock.release()

    def save(self, session: Session) -> bool:
        """Save the session; on failure say why (`error`, the server's log, once per reason).

        Parameters
        ----------
        session : Session

        Returns
        -------
        bool
            Whether it was saved. The previous file is intact either way (atomic write).
        """
        try:
            save_session(session)
        except OSError as exc:
            error = f"{exc.filename}: {exc.strerror or exc}"
            if error != self.error:
                log.error("session not saved (kept in memory, tried again): %s", error)
            self.error, self._tried = error, time.monotonic()
            return False
        self.written(session)
        if self.error is not None:
            log.info("session saved again in %s", session.root)
        self.error = None
        return True

    def due(self, every_s: float) -> bool:
        """Whether a failed save is to be tried again: `every_s` seconds after the last try."""
        return self.error is not None and time.monotonic() - self._tried >= every_s

    def written(self, session: Session) -> None:
        """Take the file as it is now as the editor's own (after it read or wrote it).

        Parameters
        ----------
        session : Session
        """
        self.stamp = stamp(session.path)

    def external_change(self, session: Session) -> tuple[str, Session | None]:
        """Read session.json again when it is not as the editor left it.

        An unreadable or removed file is not read: the editor keeps its own session and writes it at
        the next change (save_session keeps what was there as session.json.bak).

        Parameters
        ----------
        session : Session
            The session under edit.

        Returns
        -------
        message : str
            What happened, one line; '' when the file is unchanged.
        reloaded : Session or None
            The session read from the changed file; None when none was read.
        """
        now = stamp(session.path)
        if now == self.stamp:
            return "", None
        self.stamp = now
        where = session.path
        if now is None:
            return (f"{where} was removed by another program; "
                    "the tool writes it again at the next change"), None
        try:
            reloaded = load_session(session.root)
        except FileFormatError as exc:
            return (f"{where} was changed by another program and cannot be read; the tool keeps "
                    "its own session and writes it at the next change. The unreadable file "
                    f"becomes session.json.bak. {exc}"), None
        return (f"{where} was changed by another program (mirrorscan calibrate?): reloaded, "
                "undo history cleared"), reloaded


class SavedEdits:
    """What the session editor (mirrorscan.editing.EditorCore) tells of its saves and its lock.

    Uses the editor's `_lock`, `_file`, `_session`, `autosave`, `read_only` and `_tell`.
    """

    _lock: threading.RLock
    _file: SessionFile
    _session: Session
    autosave: bool
    read_only: str | None
    _tell: Callable[[Session], None]

    @property
    def last_save_error(self) -> str | None:
        """Why saving fails, until a save works, else None.

        The file holds the session as last saved; the edits since are kept in memory and saved at
        the next edit or `retry_save`.
        """
        return self._file.error

    def claim(self, root: str | Path) -> None:
        """Lock the folder of the session to open next, before anything else changes.

        Parameters
        ----------
        root : str or Path

        Raises
        ------
        SessionLocked
            Another editor holds it.
        MirrorscanError
            It cannot be locked (a read-only folder).
        """
        with self._lock:
            self._file.claim(root)

    def close(self) -> None:
        """Let the session's folder go (the editor is done)."""
        with self._lock:
            self._file.close()

    def retry_save(self, every_s: float = 0.0) -> bool:
        """Save again a session whose last save failed, `every_s` seconds after that try.

        The listeners are told when it works, or fails for another reason.

        Parameters
        ----------
        every_s : float, optional
            Seconds.

        Returns
        -------
        bool
            Whether every edit is saved now.
        """
        with self._lock:
            before = self._file.error
            if self.autosave and self._file.due(every_s):
                self._file.save(self._session)
            session, error = self._session, self._file.error
        if error != before:
            self._tell(session)
        return error is None

    def _writable(self) -> None:
        """Refuse an edit of a session open read-only, naming why."""
        if self.read_only is not None:
            raise MirrorscanError(f"not changed: the session is open read-only ({self.read_only})")


def keep_elsewhere(session: Session) -> Path | None:
    """Write session.json where it can be when its folder cannot: the home, else the temporary
    folder, under mirrorscan-unsaved/NAME-TIME/.

    Its paths stay relative to the session's folder: copied over SESSION/session.json it is the
    session as edited.

    Parameters
    ----------
    session : Session

    Returns
    -------
    Path or None
        The file written; None when none could be.
    """
    name = f"{Path(session.root).name}-{time.strftime('%Y%m%d-%H%M%S')}"
    for base in (Path.home(), Path(tempfile.gettempdir())):
        folder = base / "mirrorscan-unsaved" / name
        try:
            folder.mkdir(parents=True, exist_ok=True)
            save_session(replace(session, root=folder))
        except OSError:
            continue
        return folder / SESSION_FILE
    return None
