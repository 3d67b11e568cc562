"""`mirrorscan serve [SESSION] [--source SPEC] [--host HOST] [--port PORT]`: the browser tool."""

from __future__ import annotations

import argparse
import dataclasses
import logging
import signal
import sys
import time
from pathlib import Path

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.rig.model import check_bounces
from mirrorcore.io.session import Session
from mirrorcore.io.sessionfile import load_session, save_session
from mirrorcore.io.sessionlock import SessionLock, SessionLocked, SessionUnwritable
from mirrorcore.sources import DepthSource, open_source

from ..demo import calibrated_session, demo_source
from ..editing import EditorCore
from ..sessionfile import EDITOR, keep_elsewhere
from ..security import install_log_filter, is_loopback
from ..server import MirrorscanApp
from .numbers import whole
from .reconstruct import add_bounces_option
from .record import STOP_SIGNALS

log = logging.getLogger("mirrorscan")


def register(sub) -> None:
    """Add `mirrorscan serve` to the command line; its parser's `run` default is `run`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The `mirrorscan` parser's subcommands.
    """
    p = sub.add_parser("serve", help="the browser tool (no arguments: the simulated rig)")
    p.add_argument(
        "session",
        nargs="?",
        help="session folder; a new (or empty) folder starts an empty session there (default: the "
        "built-in simulated demo, saved only on 'Save as')",
    )
    p.add_argument(
        "--source",
        help="where frames come from (default: the session's frames, else the simulated rig); see "
        "`mirrorscan sources`",
    )
    p.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to listen on (default 127.0.0.1: this machine only)",
    )
    p.add_argument(
        "--port",
        type=whole(0, 65535),
        default=8080,
        help="port (default 8080; the next free one if taken)",
    )
    p.add_argument(
        "--token",
        help="a secret the browser must give (default: none on 127.0.0.1; beyond it a new one, "
        "printed in the address to open)",
    )
    add_bounces_option(p)
    p.set_defaults(run=run)


def session_and_source(
    folder: str | None, spec: str | None, bounces: int | None = None
) -> tuple[Session, DepthSource, bool]:
    """The session, the depth source and whether to autosave, for the command's arguments.

    Without a folder: the demo (or `spec`'s source) with a calibrated session kept in memory. A
    folder with session.json is loaded; an empty or missing one starts an empty session there.

    Parameters
    ----------
    folder : str or None
        The session folder.
    spec : str or None
        The depth source spec (--source).
    bounces : int, optional
        --bounces: becomes the session's setting (saved with its next change).

    Returns
    -------
    session : Session
    source : DepthSource
    autosave : bool

    Raises
    ------
    MirrorscanError
        When `folder` is neither a session folder nor empty, or `bounces` is out of range.
    """
    if bounces is not None:
        check_bounces(bounces)
    session, source, autosave = _session_and_source(folder, spec)
    return (
        (session if bounces is None else dataclasses.replace(session, bounces=bounces)),
        source,
        autosave,
    )


def _session_and_source(folder: str | None, spec: str | None) -> tuple[Session, DepthSource, bool]:
    """The session, source and autosave of a folder (or the demo without one)."""
    if folder is None:
        source = demo_source() if spec in (None, "sim") else open_source(spec, None)
        return calibrated_session(source, Path("sessions") / "untitled"), source, False
    root = Path(folder)
    if (root / "session.json").is_file():
        session = load_session(root)
        return session, open_source(spec, session), True
    if root.exists() and (not root.is_dir() or any(root.iterdir())):
        raise MirrorscanError(f"{root}: not a session folder (no session.json) and not empty")
    source = open_source(spec or "sim", None)
    session = Session(root, source.intrinsics)
    root.mkdir(parents=True, exist_ok=True)
    # made under its lock: refused while another serve makes it too
    with SessionLock(root, EDITOR):
        save_session(session)
    log.info("started an empty session in %s", root)
    return session, source, True


def run(args: argparse.Namespace) -> int:
    """Serve the browser tool until Ctrl-C, SIGTERM or SIGHUP, then stop the app.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit status: 130 when stopped.
    """
    logging.basicConfig(
        level=logging.INFO, format="%(asctime)s %(name)s %(levelname)s: %(message)s"
    )
    install_log_filter()
    session, source, autosave = session_and_source(args.session, args.source, args.bounces)
    sessions_dir = Path(args.session).resolve().parent if args.session else Path("sessions")
    served = (session, source, args.host, args.port, autosave, sessions_dir, args.token)
    try:
        app = MirrorscanApp(*served)
    except (SessionLocked, SessionUnwritable) as exc:
        # another program edits it, or its folder cannot be written: shown, not changed
        log.warning("opened read-only: %s", exc)
        app = MirrorscanApp(*served, read_only=str(exc))
    if not is_loopback(args.host):
        log.warning(
            "listening on %s: whoever has the address with its token can see and change the "
            "session; prefer 127.0.0.1 and an SSH tunnel (see the README)",
            args.host,
        )
    app.start()
    log.info("mirrorscan is at %s (Ctrl-C to stop)", app.guard.url)
    try:
        wait_for_stop()
        # the session being edited now: another may have been opened or saved as
        print(f"mirrorscan serve: stopped; {stopped(app.editor)}", file=sys.stderr)
        return 130
    finally:
        app.stop()


def stopped(editor: EditorCore) -> str:
    """Where the edits are, as the stop message says it: saved, or kept elsewhere, or lost.

    A session whose saves fail is tried once more, then its session.json is written where it can
    be (mirrorscan.sessionfile.keep_elsewhere).

    Parameters
    ----------
    editor : EditorCore
        The session being edited now (another may have been opened or saved as).

    Returns
    -------
    str
        One line.
    """
    root = editor.session.root
    if editor.read_only is not None:
        return f"{root} was open read-only: nothing was written to it"
    if not editor.autosave:
        return "the demo's session was kept in memory only"
    if editor.retry_save():
        return f"every edit is saved in {root}"
    kept = keep_elsewhere(editor.session)
    where = (f"kept in {kept}: copy it over {root}/session.json once that disk can be written"
             if kept else "lost: no disk could be written")
    return f"the last edits are NOT saved in {root} ({editor.last_save_error}); they are {where}"


def wait_for_stop() -> None:
    """Wait until Ctrl-C, SIGTERM or SIGHUP (the way to stop a server: not a cancelled command),
    then put the signals' handlers back."""
    previous = {s: signal.signal(s, _stop) for s in STOP_SIGNALS}
    try:
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        return
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def _stop(signum, frame) -> None:
    """Stop the server on SIGTERM and SIGHUP as Ctrl-C does.

    The session is saved at every edit; app.stop() ends a recording and the live loop.
    """
    raise KeyboardInterrupt
