"""Recording any depth source into a session folder (docs/DESIGN.md's format: uint16 PNG frames,
session.json with 'timestamps' and, when the source has colour, 'colour_frames'; truth.json when the
source is the simulator): record() and the threaded Recorder.

A recording is a valid session at every moment: session.json is written (atomically) before the
first frame and rewritten every SAVE_EVERY_S seconds with the frames that have landed, so a process
killed mid-recording (SIGKILL, a crash, the power) leaves a session that opens with all its frames
but the last second's.

For the browser tool: Recorder(source, new_recording_folder(sessions_dir)).start(); .frames counts
what is written; .stop() returns the Session and never waits longer than its timeout.
"""
from __future__ import annotations

import json
import os
import shutil
import threading
import time
from pathlib import Path
from typing import Callable


from mirrorcore.base.atomic import write_atomic
from mirrorcore.depth.files import write_colour_png, write_depth_png
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.session import BACKGROUND_FILE, TRUTH_FILE, Session
from mirrorcore.io.sessionfile import save_session
from mirrorcore.io.sessionlock import SessionLock
from mirrorcore.sources.base import DepthSource, Frame

FRAME_NAME = "frames/{:06d}.png"
COLOUR_NAME = "frames/{:06d}_colour.png"
RECORDER = "mirrorscan record"     # who holds a recording's lock
SAVE_EVERY_S = 1.0          # session.json is rewritten this often while recording (and at the end)


def record(source: DepthSource, folder: str | Path, seconds: float | None = None,
           frames: int | None = None,
           progress: Callable[[int, Frame], None] = lambda n, frame: None,
           cancel: Callable[[], bool] = lambda: False) -> Session:
    """Record a source into a new session folder.

    Stops at the first of: `frames` frames; a frame whose timestamp is `seconds` or more after the
    first one; the end of the source's iteration (one pass of a recording); cancel() returning True;
    Ctrl-C. session.json is valid from the start and rewritten every SAVE_EVERY_S seconds and at the
    end (see the module docstring). Ctrl-C, or an error after the first frame (a camera unplugged),
    keeps what was recorded as a valid session and is raised again; an error before any frame
    removes the folder.

    Parameters
    ----------
    source : DepthSource
    folder : str or Path
        Must not exist, or be empty.
    seconds : float, optional
    frames : int, optional
    progress : callable
        progress(n, frame) is called after frame n (1-based) is written.
    cancel : callable
        Returns True to stop.

    Returns
    -------
    Session

    Raises
    ------
    MirrorscanError, FileFormatError, OSError
    """
    folder = Path(folder)
    if folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
        raise MirrorscanError(f"{folder}: exists and is not an empty folder; record into a new one")
    limit = min(n for n in (frames, source.frame_count, float("inf")) if n is not None)
    created = not folder.exists()
    (folder / "frames").mkdir(parents=True, exist_ok=True)
    # one writer at a time: no editor opens it while it records
    with SessionLock(folder, RECORDER):
        return _record(source, folder, seconds, progress, cancel, created, limit)


def _record(source: DepthSource, folder: Path, seconds: float | None,
            progress: Callable[[int, Frame], None], cancel: Callable[[], bool], created: bool,
            limit: float) -> Session:
    """`record` under the folder's lock."""
    take = _Take(source, folder)
    try:
        take.save()
        frames_in = iter(source)      # a recording's frames once, a live source's until it ends
        while len(take.names) < limit and not cancel():
            frame = next(frames_in, None)
            if frame is None or (seconds is not None and take.stamps
                                 and frame.timestamp - take.stamps[0] >= seconds):
                break
            take.add(frame)
            progress(len(take.names), frame)
        return take.save()
    except BaseException as exc:
        if take.names or isinstance(exc, KeyboardInterrupt):
            take.save()
        elif created:
            shutil.rmtree(folder, ignore_errors=True)
        raise


class _Take:
    """The frames of one recording as they land, and its session.json saved at most every
    SAVE_EVERY_S seconds."""

    def __init__(self, source: DepthSource, folder: Path):
        self.source, self.folder = source, folder
        self.names: list[str] = []
        self.colours: list[str] = []
        self.stamps: list[float] = []
        self.background = None
        background = source.background()
        if background is not None:
            write_depth_png(folder / BACKGROUND_FILE, background, source.intrinsics.depth_scale)
            self.background = BACKGROUND_FILE
        truth = source.truth()
        if truth is not None:
            write_atomic(folder / TRUTH_FILE, (json.dumps(truth, indent=2) + "\n").encode())
        self._saved_at = time.monotonic()

    def add(self, frame: Frame) -> None:
        """Write one frame (atomically), then list it.

        session.json follows when it is SAVE_EVERY_S old.
        """
        n = len(self.names)
        write_depth_png(self.folder / FRAME_NAME.format(n), frame.depth,
                        self.source.intrinsics.depth_scale)
        if frame.colour is not None:
            write_colour_png(self.folder / COLOUR_NAME.format(n), frame.colour)
            self.colours.append(COLOUR_NAME.format(n))
        self.names.append(FRAME_NAME.format(n))
        self.stamps.append(frame.timestamp)
        if time.monotonic() - self._saved_at >= SAVE_EVERY_S:
            self.save()

    def save(self) -> Session:
        """Write session.json now and return the session."""
        session = Session(self.folder, self.source.intrinsics, (), self.background,
                          tuple(self.names),
                          timestamps=tuple(self.stamps),
                          colour_frames=tuple(self.colours) if self.colours and len(
                              self.colours) == len(self.names)
                          else None)
        save_session(session)
        self._saved_at = time.monotonic()
        return session


def new_recording_folder(parent: str | Path, prefix: str = "recording") -> Path:
    """Create a new empty folder `parent`/PREFIX-YYYYmmdd-HHMMSS.

    With -2, -3... when that name is taken: made with an exclusive mkdir, so two recordings started
    in the same second never share a folder.

    Parameters
    ----------
    parent : str or Path
    prefix : str

    Returns
    -------
    Path
    """
    parent = Path(parent)
    parent.mkdir(parents=True, exist_ok=True)
    stem = f"{prefix}-{time.strftime('%Y%m%d-%H%M%S')}"
    for n in range(1, 10_000):
        folder = parent / (stem if n == 1 else f"{stem}-{n}")
        try:
            os.mkdir(folder)
        except FileExistsError:
            continue
        return folder
    raise MirrorscanError(f"{parent}: no free name for a recording {stem}-N")


class Recorder:
    """record() on a background thread, for a UI: start(), then stop() (or wait for the limit).

    stop() returns within its timeout whatever the source does (a source blocked in a read is left
    to end on its own; the recording's session.json is valid all along).

    Parameters
    ----------
    source : DepthSource
    folder : str or Path
    seconds : float, optional
    frames : int, optional
        As for `record`.

    Attributes
    ----------
    frames : int
        Frames written so far.
    done : bool
        The recording has ended.
    error : Exception or None
        The exception that ended it.
    session : Session or None
        The recorded session, once written.
    """

    def __init__(self, source: DepthSource, folder: str | Path, seconds: float | None = None,
                 frames: int | None = None):
        self.source, self.folder, self.seconds, self.limit = source, Path(folder), seconds, frames
        self.frames, self.error, self.session = 0, None, None
        self._cancel = threading.Event()
        self._thread = threading.Thread(target=self._run, name="mirrorscan-record", daemon=True)

    @property
    def done(self) -> bool:
        """True once the recording thread has started and ended."""
        return self._thread.ident is not None and not self._thread.is_alive()

    def start(self) -> "Recorder":
        """Start recording on the background thread; returns self."""
        self._thread.start()
        return self

    def stop(self, timeout: float = 10.0) -> Session:
        """Stop recording and wait for the session to be written.

        Parameters
        ----------
        timeout : float
            Seconds to wait at most.

        Returns
        -------
        Session

        Raises
        ------
        Exception
            The error that ended it.
        MirrorscanError
            The recording has not ended in time.
        """
        self._cancel.set()
        if self._thread.ident is not None:
            self._thread.join(timeout)
        if self.error is not None:
            raise self.error
        if self.session is None:
            raise MirrorscanError(
                f"{self.folder}: the recording did not end within {timeout:g} s (its source is "
                                  f"not delivering frames); {self.frames} frames are saved there")
        return self.session

    def _run(self) -> None:
        """Record; keep the session, or the exception that ended it."""
        try:
            self.session = record(self.source, self.folder, self.seconds, self.limit, self._count,
                                  self._cancel.is_set)
        except Exception as exc:  # handed to the caller of stop()
            self.error = exc

    def _count(self, n: int, frame: Frame) -> None:
        """Keep the number of frames written."""
        self.frames = n
