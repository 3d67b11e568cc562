"""`mirrorscan record SOURCE SESSION`: record any depth source into a session folder."""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from contextlib import contextmanager
from typing import Iterator

from tqdm import tqdm

from mirrorcore.io.limits import MAX_FRAMES
from mirrorcore.io.outputs import check_output
from mirrorcore.sources import open_source, record

from .numbers import real, whole

# a clean stop, like Ctrl-C: the session keeps every frame
STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)


def register(sub) -> None:
    """Add `mirrorscan record` to the command line; its parser's `run` default is `run`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The `mirrorscan` parser's subcommands.
    """
    p = sub.add_parser(
        "record",
        help="record a depth source (camera, recording, simulator) into a session folder",
        description="Frames are written as 16-bit PNG with their timestamps in session.json, "
        "which is valid from the start and rewritten every second. Ctrl-C, SIGTERM and SIGHUP "
        "stop and keep a valid session of what was recorded (exit 130, 143, 129); a killed "
        "recording opens with all but its last second. `mirrorscan sources` lists the source "
        "specs.",
    )
    p.add_argument(
        "source", metavar="SOURCE", help="a source spec: sim, tum:FOLDER, freenect:0, bag:FILE..."
    )
    p.add_argument(
        "session",
        metavar="SESSION",
        help="the session folder to create (must not exist, or be empty)",
    )
    p.add_argument("--seconds", type=real(0, unit="seconds", above=True),
                   help="stop after this many seconds of frames")
    p.add_argument("--frames", type=whole(1, MAX_FRAMES), help="stop after this many frames")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


@contextmanager
def stop_signals() -> Iterator[list[int]]:
    """While in the block, SIGTERM and SIGHUP ask for a clean stop.

    The signal numbers received are appended to the list yielded (the recorder polls it between
    frames). A second signal raises KeyboardInterrupt (the recorder still saves what it has).
    Outside the main thread (tests), nothing is installed.
    """
    received: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield received
        return

    def handler(signum, frame) -> None:
        received.append(signum)
        if len(received) > 1:
            raise KeyboardInterrupt

    previous = {s: signal.signal(s, handler) for s in STOP_SIGNALS}
    try:
        yield received
    finally:
        for s, old in previous.items():
            signal.signal(s, old)


def run(args: argparse.Namespace) -> int:
    """Record the source into the session folder until Ctrl-C, --seconds or --frames.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit status: 0; 130 after Ctrl-C, 128 + the signal after SIGTERM or SIGHUP (the frames
        recorded are kept).

    Raises
    ------
    MirrorscanError
        When the session folder exists and is not empty, or the source cannot be opened.
    """
    check_output(args.session)
    with open_source(args.source) as source, stop_signals() as signals:
        if source.live and args.seconds is None and args.frames is None:
            print(f"recording {source.name} until Ctrl-C", file=sys.stderr)
        total = min(n for n in (args.frames, source.frame_count, float("inf")) if n is not None)
        with tqdm(
            total=None if total == float("inf") else total,
            unit="frame",
            disable=args.quiet,
            desc=source.name,
        ) as bar:
            try:
                session = record(
                    source,
                    args.session,
                    args.seconds,
                    args.frames,
                    lambda n, frame: bar.update(1),
                    cancel=lambda: bool(signals),
                )
            except KeyboardInterrupt:
                bar.close()
                print(f"stopped: kept {bar.n} frames in {args.session}", file=sys.stderr)
                return 130
    if signals:
        name = signal.Signals(signals[0]).name
        print(
            f"stopped by {name}: kept {len(session.frames)} frames in {session.root}",
            file=sys.stderr,
        )
        return 128 + signals[0]
    print(f"recorded {len(session.frames)} frames of {source.name} into {session.root}")
    return 0
