"""Telling when another program changed session.json (`mirrorscan calibrate SESSION` in a
terminal) while the browser tool edits it, and reading the new file."""
from __future__ import annotations

import os
from pathlib import Path

from mirrorcore.base.errors import FileFormatError
from mirrorcore.io.session import Session
from mirrorcore.io.sessionfile import load_session

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
    """session.json as the editor last read or wrote it.

    Parameters
    ----------
    session : Session
        The session whose file is stamped now.

    Attributes
    ----------
    stamp : tuple of int or None
        The file's stamp (see `stamp`) when the editor last read or wrote it.
    """

    def __init__(self, session: Session):
        self.stamp = stamp(session.path)

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
