"""Recording what the browser tool shows: the live frames, tapped from the app's event bus as a depth source that
mirrorcore's recorder writes into a session folder; the recording ends when the tap is closed (the Stop button)."""
from __future__ import annotations

import queue
from typing import Callable, Iterator

import numpy as np

from mirrorcore.errors import MirrorscanError
from mirrorcore.sources import DepthSource, Frame

from .live import LiveFrame

BACKLOG = 120   # frames waiting to be written before the oldest are dropped (a slow disk must not stall the view)


class LiveTap(DepthSource):
    """The live frames of `source` from now on, in order, as a live source; iteration ends at close().

    subscribe(take) starts calling take(LiveFrame) for every processed frame and returns the function that stops it.
    """

    def __init__(self, source: DepthSource, subscribe: Callable[[Callable[[LiveFrame], None]], Callable[[], None]]):
        self.name = f"recording of {source.name}"
        self.intrinsics, self.fps, self.frame_count = source.intrinsics, source.fps, None
        self._background = source.background()
        self._frames: queue.Queue[Frame | None] = queue.Queue(maxsize=BACKLOG)
        self.dropped = 0
        self._unsubscribe: Callable[[], None] | None = subscribe(self._take)

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
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None
            self._frames.put(None)
