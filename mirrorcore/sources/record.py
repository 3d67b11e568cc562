"""Recording any depth source into a session folder (docs/DESIGN.md's format: uint16 PNG frames, session.json with
'timestamps' and, when the source has colour, 'colour_frames'): record() and the threaded Recorder.

For the browser tool: Recorder(source, folder).start(); .frames counts what is written; .stop() returns the Session.
"""
from __future__ import annotations

import shutil
import threading
from pathlib import Path
from typing import Callable

import cv2

from ..atomic import write_atomic
from ..depthio import write_depth_png
from ..errors import FileFormatError, MirrorscanError
from ..session import BACKGROUND_FILE, Session, save_session
from .base import DepthSource, Frame

FRAME_NAME = "frames/{:06d}.png"
COLOUR_NAME = "frames/{:06d}_colour.png"


def record(source: DepthSource, folder: str | Path, seconds: float | None = None, frames: int | None = None,
           progress: Callable[[int, Frame], None] = lambda n, frame: None,
           cancel: Callable[[], bool] = lambda: False) -> Session:
    """Record `source` into a new session folder and return its Session.

    Stops at the first of: `frames` frames; a frame whose timestamp is `seconds` or more after the first one; the end
    of the source's iteration (one pass of a recording); cancel() returning True; Ctrl-C. A cancelled or interrupted recording keeps what
    was recorded as a valid session (session.json is written last, atomically); then KeyboardInterrupt is raised
    again. On any other error the folder is removed. progress(n, frame) is called after frame n (1-based) is written.
    folder : must not exist, or be empty. Raises MirrorscanError, FileFormatError, OSError.
    """
    folder = Path(folder)
    if folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
        raise MirrorscanError(f"{folder}: exists and is not an empty folder; record into a new one")
    scale = source.intrinsics.depth_scale
    limit = min(n for n in (frames, source.frame_count, float("inf")) if n is not None)
    names, colours, stamps = [], [], []
    created = not folder.exists()
    (folder / "frames").mkdir(parents=True, exist_ok=True)
    try:
        try:
            frames_in = iter(source)      # a recording's frames once, a live source's until it ends
            while len(names) < limit and not cancel():
                frame = next(frames_in, None)
                if frame is None or seconds is not None and stamps and frame.timestamp - stamps[0] >= seconds:
                    break
                write_depth_png(folder / FRAME_NAME.format(len(names)), frame.depth, scale)
                if frame.colour is not None:
                    write_colour_png(folder / COLOUR_NAME.format(len(names)), frame.colour)
                    colours.append(COLOUR_NAME.format(len(names)))
                names.append(FRAME_NAME.format(len(names)))
                stamps.append(frame.timestamp)
                progress(len(names), frame)
        except KeyboardInterrupt:
            _save(source, folder, names, colours, stamps)
            raise
        return _save(source, folder, names, colours, stamps)
    except BaseException as exc:
        if created and not isinstance(exc, KeyboardInterrupt):
            shutil.rmtree(folder, ignore_errors=True)
        raise


def _save(source: DepthSource, folder: Path, names: list[str], colours: list[str], stamps: list[float]) -> Session:
    background = source.background()
    if background is not None:
        write_depth_png(folder / BACKGROUND_FILE, background, source.intrinsics.depth_scale)
    session = Session(folder, source.intrinsics, (), None if background is None else BACKGROUND_FILE, tuple(names),
                      timestamps=tuple(stamps),
                      colour_frames=tuple(colours) if colours and len(colours) == len(names) else None)
    save_session(session)
    return session


def write_colour_png(path: Path, colour) -> None:
    """(H, W, 3) uint8 RGB -> an 8-bit colour PNG, written atomically."""
    ok, buf = cv2.imencode(".png", cv2.cvtColor(colour, cv2.COLOR_RGB2BGR))
    if not ok:
        raise FileFormatError(f"{path}: PNG encoding failed")
    write_atomic(path, buf.tobytes())


class Recorder:
    """record() on a background thread, for a UI: start(), then stop() (or wait for the limit) to get the Session.

    frames : int, frames written so far; done : bool; error : the exception that ended it, or None.
    """

    def __init__(self, source: DepthSource, folder: str | Path, seconds: float | None = None,
                 frames: int | None = None):
        self.source, self.folder, self.seconds, self.limit = source, Path(folder), seconds, frames
        self.frames, self.error, self.session = 0, None, None
        self._cancel = threading.Event()
        self._thread = threading.Thread(target=self._run, name="mirrorscan-record", daemon=True)

    @property
    def done(self) -> bool:
        return self._thread.ident is not None and not self._thread.is_alive()

    def start(self) -> "Recorder":
        self._thread.start()
        return self

    def stop(self, timeout: float = 30.0) -> Session:
        """Stop recording, wait for the session to be written and return it; raises the error that ended it."""
        self._cancel.set()
        self._thread.join(timeout)
        if self.error is not None:
            raise self.error
        if self.session is None:
            raise MirrorscanError(f"{self.folder}: the recording did not finish within {timeout:g} s")
        return self.session

    def _run(self) -> None:
        try:
            self.session = record(self.source, self.folder, self.seconds, self.limit, self._count, self._cancel.is_set)
        except Exception as exc:  # handed to the caller of stop()
            self.error = exc

    def _count(self, n: int, frame: Frame) -> None:
        self.frames = n
