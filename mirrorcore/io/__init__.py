"""Floor 3, files of a scan: the session folder and its session.json (session, read and saved by
sessionfile, with its typed fields and limits), the lock of its one writer (sessionlock), PLY clouds
(ply) and the guard that keeps outputs off a session's files (outputs)."""
from mirrorcore.io.limits import check_name
from mirrorcore.io.outputs import check_output
from mirrorcore.io.ply import read_ply, write_ply
from mirrorcore.io.session import SESSION_FILE, Session, SessionMirror
from mirrorcore.io.sessionfile import (check_session, copy_session, load_session, save_session,
                                      session_folder)
from mirrorcore.io.sessionlock import (LOCK_FILE, SessionLock, SessionLocked, SessionUnwritable,
                                       lock_holder)

__all__ = ["LOCK_FILE", "SESSION_FILE", "Session", "SessionLock", "SessionLocked", "SessionMirror",
           "SessionUnwritable", "check_name", "check_output", "check_session", "copy_session",
           "load_session", "lock_holder", "read_ply", "save_session", "session_folder",
           "write_ply"]
