"""`mirrorscan serve [SESSION] [--source SPEC] [--host 127.0.0.1] [--port 8080]`: the browser tool."""
from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

from mirrorcore.session import load_session
from mirrorcore.sources import open_source

from ..demo import calibrated_session, demo_source
from ..server import MirrorscanApp

log = logging.getLogger("mirrorscan")


def register(sub) -> None:
    p = sub.add_parser("serve", help="the browser tool (no arguments: the simulated rig)")
    p.add_argument("session", nargs="?", help="session folder (default: the built-in simulated demo)")
    p.add_argument("--source", help="sim, sim:SCENE.json or session (default: the session's frames, else sim)")
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=int, default=8080, help="port (default 8080; the next free one if taken)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(levelname)s: %(message)s")
    if args.host not in ("127.0.0.1", "localhost", "::1"):
        log.warning("listening on %s: anyone who can reach this address can see and change the session", args.host)
    if args.session is None:
        # without a session the source is simulated: its markers and boundaries are known, its planes calibrated
        source = demo_source() if args.source in (None, "sim") else open_source(args.source, None)
        session = calibrated_session(source, Path("sessions") / "live")
    else:
        session = load_session(args.session)
        source = open_source(args.source, session)
    app = MirrorscanApp(session, source, args.host, args.port)
    app.start()
    log.info("mirrorscan is at http://%s:%d (Ctrl-C to stop)", args.host, app.port)
    try:
        while True:
            time.sleep(3600)
    finally:
        app.stop()
