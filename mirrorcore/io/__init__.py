"""Floor 3, files of a scan: the session folder and its session.json (session, read and saved by
sessionfile, with its typed fields and limits), PLY clouds (ply) and the guard that keeps outputs
off a session's files (outputs)."""
from mirrorcore.io.limits import check_name
from mirrorcore.io.outputs import check_output
from mirrorcore.io.ply import read_ply, write_ply
from mirrorcore.io.session import SESSION_FILE, Session, SessionMirror
from mirrorcore.io.sessionfile import (check_session, copy_session, load_session, save_session,
                                      session_folder)

__all__ = ["SESSION_FILE", "Session", "SessionMirror", "check_name", "check_session",
           "check_output", "copy_session", "load_session", "read_ply", "save_session",
           "session_folder", "write_ply"]
