"""`mirrorscan record SOURCE SESSION [--seconds N] [--frames N]`: record any depth source into a session folder."""
from __future__ import annotations

import argparse
import sys

from tqdm import tqdm

from mirrorcore.errors import MirrorscanError
from mirrorcore.session import check_output
from mirrorcore.sources import open_source, record


def register(sub) -> None:
    p = sub.add_parser("record", help="record a depth source (camera, recording, simulator) into a session folder",
                       description="Frames are written as 16-bit PNG with their timestamps in session.json. Ctrl-C "
                                   "stops and keeps a valid session of what was recorded. `mirrorscan sources` "
                                   "lists the source specs.")
    p.add_argument("source", metavar="SOURCE", help="a source spec: sim, tum:FOLDER, freenect:0, bag:FILE...")
    p.add_argument("session", metavar="SESSION", help="the session folder to create (must not exist, or be empty)")
    p.add_argument("--seconds", type=float, help="stop after this many seconds of frames")
    p.add_argument("--frames", type=int, help="stop after this many frames")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    for name in ("seconds", "frames"):
        if getattr(args, name) is not None and not getattr(args, name) > 0:
            raise MirrorscanError(f"--{name}: must be positive, got {getattr(args, name):g}")
    check_output(args.session)
    with open_source(args.source) as source:
        if source.live and args.seconds is None and args.frames is None:
            print(f"recording {source.name} until Ctrl-C", file=sys.stderr)
        total = min(n for n in (args.frames, source.frame_count, float("inf")) if n is not None)
        with tqdm(total=None if total == float("inf") else total, unit="frame", disable=args.quiet,
                  desc=source.name) as bar:
            try:
                session = record(source, args.session, args.seconds, args.frames, lambda n, frame: bar.update(1))
            except KeyboardInterrupt:
                bar.close()
                print(f"stopped: kept {bar.n} frames in {args.session}", file=sys.stderr)
                return 130
    print(f"recorded {len(session.frames)} frames of {source.name} into {session.root}")
    return 0
