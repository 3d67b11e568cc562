"""Recording what the browser tool shows: the live frames, tapped from the app's event bus as a
depth source that mirrorcore's recorder writes into a session folder; the recording ends when the
tap is closed (the Stop button). One tap per source at a time, and nothing here ever blocks: a slow
disk drops the newest frames, close() returns at once."""
from __future__ import annotations

import queue
import threading
from typing import Callable, Iterator

import numpy as np

from mirrorcore.base.budget import memory_budget
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.sources import DepthSource, Frame

from .liveframe import LiveFrame

# frames waiting to be written before new ones are dropped (a slow disk must not stall the view)
BACKLOG = 120
POLL_S = 0.1           # how often a reader waiting for a frame looks whether the tap was closed
_taps_lock = threading.Lock()
_tapped: set[int] = set()    # id() of the sources with an open tap


def backlog_frames(shape: tuple[int, int]) -> int:
    """BACKLOG, or fewer when a quarter of the memory budget cannot hold that many frames.

    Parameters
    ----------
    shape : tuple of int
        (H, W) of a float32 frame.

    Returns
    -------
    int
        At least 1.
    """
    return int(max(1, min(BACKLOG, memory_budget() // 4 // (4 * shape[0] * shape[1]))))


class LiveTap(DepthSource):
    """The live frames of `source` from now on, in order, as a live source.

    Iteration ends at close(). A recording that plays (a finite source, which loops) is taken up to
    its last frame: from the first frame that starts it over (or goes back, after a seek) the tap
    takes nothing more and `replay_ended` is True, so that no frame is recorded twice and the
    recording's time never runs backwards. The same frame again (processed again while paused) is
    taken once.

    Parameters
    ----------
    source : DepthSource
        The live loop's source.
    subscribe : callable
        subscribe(take) starts calling take(LiveFrame) for every processed frame and returns the
        function that stops it.

    Attributes
    ----------
    taken : int
        Frames taken for the recording (the recorder writes them behind: Recorder.frames).
    dropped : int
        Frames dropped because the backlog was full.
    replay_ended : bool

    Raises
    ------
    MirrorscanError
        When the source already has an open tap (one recording at a time).
    """

    def __init__(self, source: DepthSource,
                 subscribe: Callable[[Callable[[LiveFrame], None]], Callable[[], None]]):
        self.name = f"recording of {source.name}"
        self.intrinsics, self.fps, self.frame_count = source.intrinsics, source.fps, None
        self._background = source.background()
        self._truth = source.truth()
        backlog = backlog_frames(source.intrinsics.shape)
        self._frames: queue.Queue[Frame | None] = queue.Queue(maxsize=backlog)
        self._closed = threading.Event()
        self.dropped = 0
        # frames taken for the recording (the recorder writes them behind: Recorder.frames)
        self.taken = 0
        self.replay_ended = False
        self._loop_length, self._last_number = source.frame_count, -1
        self._key = id(source)
        with _taps_lock:
            if self._key in _tapped:
                raise MirrorscanError("already recording: stop the current recording first")
            _tapped.add(self._key)
        self._unsubscribe: Callable[[], None] | None = subscribe(self._take)

    def _take(self, frame: LiveFrame) -> None:
        """Queue a processed frame when it is the next in order; count it dropped when full."""
        if self._closed.is_set() or self.replay_ended or not self._in_order(frame.index):
            return
        try:
            self._frames.put_nowait(Frame(frame.depth, frame.timestamp))
            self.taken += 1
        except queue.Full:
            self.dropped += 1

    def _in_order(self, index: int) -> bool:
        """Whether the frame of live index `index` is a replay's next (always for a live source).

        A replay that starts over ends the tap's intake (replay_ended).
        """
        if not self._loop_length:
            return True
        number = index % self._loop_length
        if number < self._last_number:
            self.replay_ended = True
        elif number > self._last_number:
            self._last_number = number
            return True
        return False

    def _next(self) -> Frame | None:
        """The next frame, waiting for it.

        None once the tap is closed and every frame taken before was delivered.
        """
        while True:
            try:
                frame = self._frames.get(timeout=POLL_S)
            except queue.Empty:
                if self._closed.is_set():
                    return None
                continue
            if frame is not None:
                return frame
            if self._closed.is_set() and self._frames.empty():
                return None

    def read(self, i: int) -> Frame:
        """The next live frame (blocks until the loop delivers it).

        Parameters
        ----------
        i : int
            Not used: the frames come in order.

        Returns
        -------
        Frame

        Raises
        ------
        MirrorscanError
            Once the recording has ended.
        """
        frame = self._next()
        if frame is None:
            raise MirrorscanError(f"{self.name}: the recording has ended")
        return frame

    def __iter__(self) -> Iterator[Frame]:
        while (frame := self._next()) is not None:
            yield frame

    def background(self) -> np.ndarray | None:
        """The source's background when the tap opened."""
        return self._background

    def truth(self) -> dict | None:
        """The source's truth when the tap opened (DepthSource.truth)."""
        return self._truth

    def close(self) -> None:
        """Stop tapping; the frames already taken are still delivered, then iteration ends.

        Never blocks; closing twice does nothing.
        """
        with _taps_lock:
            unsubscribe, self._unsubscribe = self._unsubscribe, None
            if unsubscribe is None:
                return
            _tapped.discard(self._key)
        unsubscribe()
        self._closed.set()
        try:
            # wakes a waiting reader at once; a full queue is drained first
            self._frames.put_nowait(None)
        except queue.Full:
            pass
