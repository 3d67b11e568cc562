"""Recording what the browser tool shows: the live loop's frames, tapped as a depth source that mirrorcore's recorder
writes into a session folder; the recording ends when the tap is closed (the Stop button)."""
from __future__ import annotations

import queue
from typing import Iterator

import numpy as np

from mirrorcore.errors import MirrorscanError
from mirrorcore.sources import DepthSource, Frame

from .live import LiveFrame, LiveLoop

BACKLOG = 120   # frames waiting to be written before the oldest are dropped (a slow disk must not stall the view)


class LiveTap(DepthSource):
    """The frames the live loop processes from now on, in order, as a live source; iteration ends at close()."""

    def __init__(self, loop: LiveLoop):
        source = loop.source
        self.loop, self.name = loop, f"recording of {source.name}"
        self.intrinsics, self.fps, self.frame_count = source.intrinsics, source.fps, None
        self._background = source.background()
        self._frames: queue.Queue[Frame | None] = queue.Queue(maxsize=BACKLOG)
        self.dropped = 0
        loop.listeners.append(self._take)

    def _take(self, frame: LiveFrame) -> None:
        try:
            self._frames.put_nowait(Frame(frame.depth, frame.timestamp))
        except queue.Full:
            self.dropped += 1

    def read(self, i: int) -> Frame:
        """The next live frame (blocks until the loop delivers it)."""
        frame = self._frames.get()
        if frame is None:
            raise MirrorscanError(f"{self.name}: the recording has ended")
        return frame

    def __iter__(self) -> Iterator[Frame]:
        while (frame := self._frames.get()) is not None:
            yield frame

    def background(self) -> np.ndarray | None:
        return self._background

    def close(self) -> None:
        """Stop tapping; the frames already taken are still delivered, then iteration ends."""
        if self._take in self.loop.listeners:
            self.loop.listeners.remove(self._take)
            self._frames.put(None)
