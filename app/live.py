"""The live loop: read a frame from the source, select the object, run Algorithm 1, hand the result
to one callback (the app publishes it to the tabs); on its own thread, with pause, single steps,
seeking and a measured frame rate."""
from __future__ import annotations

import math
import threading
import time
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Callable

import numpy as np

from mirrorcore.base.errors import Cancelled, MirrorscanError
from mirrorcore.sources import DepthSource, Frame

from .liveframe import LiveFrame, frame_number, process_frame
from .state import Snapshot
from .stream import Anchors

RECENT_FRAMES = 5   # the last depth frames kept for calibrating on (markers.marker_points)
# seconds: while the loop waits for its next frame it looks at its pace this often, so that the
# frame after a job comes at once
PACE_CHECK_S = 0.1
# frames per second of a source whose own rate is not a positive number
FALLBACK_FPS = 2.0


class RateMeter:
    """Frames per second over the frame times of the last `seconds` (at least the last two).

    The time bound makes the rate follow a loop that slows down for a job (1 fps) within
    `seconds`, where a window of frames alone would still hold the faster ones.

    Parameters
    ----------
    window : int, optional
        At most this many frame times are kept.
    seconds : float, optional
    """

    def __init__(self, window: int = 30, seconds: float = 2.0):
        self._times: deque[float] = deque(maxlen=window)
        self.seconds = seconds

    def tick(self, now: float) -> None:
        """Count a frame.

        Parameters
        ----------
        now : float
            Its time (time.perf_counter(), seconds).
        """
        self._times.append(now)

    @property
    def fps(self) -> float:
        """The rate, frames per second; 0.0 before two frames."""
        times = list(self._times)
        recent = [t for t in times if t >= times[-1] - self.seconds] if times else []
        recent = recent if len(recent) >= 2 else times[-2:]
        if len(recent) < 2:
            return 0.0
        return (len(recent) - 1) / max(recent[-1] - recent[0], 1e-9)


class LiveLoop:
    """Runs source -> process_frame -> on_frame on a daemon thread, at most at the source's rate.

    The snapshot that snapshot() gives is used at each frame. The thread runs at the source's frame
    rate, or at fps_wanted() frames per second when that is given and lower (the app asks for fewer
    while no tab shows the cloud: see MirrorscanApp.fps_wanted). on_frame(LiveFrame) is called on
    the loop's thread; an exception there or in the source is passed to on_error and the loop goes
    on with the next frame after a short pause (a camera may come back; a recording's frame that
    fails to read is skipped). A source without a positive rate plays at FALLBACK_FPS, told once.

    Parameters
    ----------
    source : DepthSource
    snapshot : callable
        Returns the Snapshot to process a frame with.
    on_frame : callable
        Called with each LiveFrame.
    on_error : callable, optional
        Called with an exception of the source or of on_frame.
    fps_wanted : callable, optional
        Returns the rate asked for, or None.
    """

    def __init__(self, source: DepthSource, snapshot: Callable[[], Snapshot],
                 on_frame: Callable[[LiveFrame], None],
                 on_error: Callable[[Exception], None] = lambda exc: None,
                 fps_wanted: Callable[[], float | None] = lambda: None):
        self.source, self.snapshot = source, snapshot
        self.on_frame, self.on_error = on_frame, on_error
        self.fps_wanted = fps_wanted
        self.rate = RateMeter()
        self.anchors = Anchors()          # the stream's centres, kept from frame to frame
        self.index = 0
        # frame_number -> depth and colour (None: the source has none), oldest first
        # (RECENT_FRAMES at most)
        self._recent: dict[int, tuple[np.ndarray, np.ndarray | None]] = {}
        # appended on the loop's thread, copied on the browser's
        self._recent_lock = threading.Lock()
        self._collectors: list[Callable[[LiveFrame], None]] = []
        self._reader = ThreadPoolExecutor(max_workers=1, thread_name_prefix="mirrorscan-read")
        # one frame at a time; switching source or seeking waits for it
        self._turn = threading.Lock()
        self._ahead: tuple[int, Future] | None = None
        self._paused = threading.Event()
        # set on pause, step and stop: the paused loop looks at its state again
        self._wake = threading.Event()
        self._stop = threading.Event()
        # single steps asked for while paused (guarded by _step_lock)
        self._steps = 0
        self._step_lock = threading.Lock()
        self._thread = threading.Thread(target=self._run, name="mirrorscan-live", daemon=True)
        # the source whose rate was found wrong and told (_source_fps)
        self._told_rate: DepthSource | None = None

    def start(self) -> None:
        """Start the loop's thread."""
        self._thread.start()

    def stop(self) -> None:
        """Stop the thread (waiting up to 5 s) and the reader."""
        self._stop.set()
        self._wake.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5)
        self._reader.shutdown(wait=True, cancel_futures=True)

    @property
    def paused(self) -> bool:
        """Whether the loop is paused."""
        return self._paused.is_set()

    def pause(self, paused: bool) -> None:
        """Pause or resume the loop.

        Parameters
        ----------
        paused : bool
        """
        (self._paused.set if paused else self._paused.clear)()
        self._wake.set()

    def step(self) -> None:
        """Process exactly one more frame while paused."""
        with self._step_lock:
            self._steps += 1
        self._wake.set()

    def _take_step(self) -> bool:
        """Take one step asked for while paused, if any."""
        with self._step_lock:
            if self._steps:
                self._steps -= 1
                return True
            return False

    def run_once(self) -> LiveFrame:
        """Read and process the next frame on the calling thread (what the thread does each turn).

        The frame after it is read meanwhile on a reader thread, so reading (ray casting, file or
        device I/O) and processing share two cores.

        Returns
        -------
        LiveFrame
        """
        with self._turn:
            try:
                source_frame = self._read(self.index)
            except Exception:
                # a recording's frame that fails to read is skipped: playing goes on
                self.index += 1
                raise
            self._ahead = (self.index + 1, self._reader.submit(self.source.read, self.index + 1))
            frame = process_frame(self.snapshot(), self.index, source_frame, self.anchors)
            self.index += 1
        # A frame of a recording that loops replaces itself: the same frame again is no new data.
        with self._recent_lock:
            number = frame_number(frame.index, self.source.frame_count)
            self._recent.pop(number, None)
            self._recent[number] = (frame.depth, source_frame.colour)
            while len(self._recent) > RECENT_FRAMES:
                del self._recent[next(iter(self._recent))]
            collectors = list(self._collectors)
        for collect in collectors:
            collect(frame)
        self.on_frame(frame)
        self.rate.tick(time.perf_counter())
        return frame

    def use_source(self, source: DepthSource) -> None:
        """Play another source of the same camera from its first frame.

        The recent frames are dropped: they were the other's.

        Parameters
        ----------
        source : DepthSource
        """
        with self._turn:
            self.source, self.index, self._ahead = source, 0, None
            with self._recent_lock:
                self._recent.clear()

    def seek(self, index: int) -> None:
        """Play on from frame `index` (a seekable source).

        While paused, that frame is processed at once (shown).

        Parameters
        ----------
        index : int
        """
        with self._turn:
            self.index, self._ahead = int(index), None
        if self.paused:
            with self._step_lock:
                # the frame sought, once: a slider dragged over many frames ends on its own
                self._steps = 1
            self._wake.set()

    def _read(self, index: int) -> Frame:
        """Frame `index`: the one read ahead when it is that one, else read now."""
        ahead, self._ahead = self._ahead, None
        if ahead is not None and ahead[0] == index:
            return ahead[1].result()
        return self.source.read(index)

    def recent_depths(self) -> np.ndarray | None:
        """The last RECENT_FRAMES distinct depth frames, oldest first.

        For calibration over their median.

        Returns
        -------
        np.ndarray, shape (k, H, W), or None
            Metres; None before the first frame.
        """
        with self._recent_lock:
            frames = [depth for depth, _ in self._recent.values()]
        return np.stack(frames) if frames else None

    def recent_frames(self) -> tuple[np.ndarray, np.ndarray | None] | None:
        """The frames `recent_depths` gives, with their colour images, taken together.

        Returns
        -------
        depths : np.ndarray, shape (k, H, W)
            Metres.
        colours : np.ndarray, shape (k, H, W, 3), uint8, or None
            RGB registered to the depth; None when a frame has no colour.
        None
            Before the first frame.
        """
        with self._recent_lock:
            frames = list(self._recent.values())
        if not frames:
            return None
        colours = [colour for _, colour in frames]
        return (np.stack([depth for depth, _ in frames]),
                None if any(c is None for c in colours) else np.stack(colours))

    def collect(self, n: int, progress: Callable[[int], None] = lambda k: None,
                timeout: float = 60.0, cancel: threading.Event | None = None) -> list[np.ndarray]:
        """The depth of `n` frames read after this call; blocks, calling progress(k) after each.

        The frame already read ahead is skipped, so a scene changed just before the call (the object
        taken out) is what is collected. While paused, frames are stepped one by one.

        Parameters
        ----------
        n : int
            Frames to collect.
        progress : callable, optional
            Called with the count collected so far.
        timeout : float, optional
            Seconds the source may go without delivering.
        cancel : threading.Event, optional

        Returns
        -------
        list of (H, W) ndarray
            Metres.

        Raises
        ------
        MirrorscanError
            When the source stops delivering for `timeout` seconds.
        mirrorcore.base.errors.Cancelled
            When `cancel` is set.
        """
        frames: list[np.ndarray] = []
        done = threading.Event()
        # the frame in hand and the one read ahead may predate the call
        first = self.index + 2

        def take(frame: LiveFrame) -> None:
            if frame.index >= first and len(frames) < n:
                frames.append(frame.depth)
                progress(len(frames))
            if len(frames) >= n:
                done.set()

        with self._recent_lock:
            self._collectors.append(take)
        try:
            deadline = time.monotonic() + timeout
            while not done.wait(0.1):
                if cancel is not None and cancel.is_set():
                    raise Cancelled(f"stopped after {len(frames)} of {n} frames")
                # one frame at a time while paused
                if self.paused and not self._steps:
                    self.step()
                if time.monotonic() > deadline:
                    raise MirrorscanError(f"the source delivered {len(frames)} of {n} frames in "
                                          f"{timeout:.0f} s; check the camera and try again")
        finally:
            with self._recent_lock:
                self._collectors.remove(take)
        return frames

    def _run(self) -> None:
        """The thread: process frames at the pace, or wait while paused."""
        while not self._stop.is_set():
            if self._paused.is_set() and not self._take_step():
                self._wake.wait()
                # the state is looked at again before waiting again: no wake is lost
                self._wake.clear()
                continue
            started = time.perf_counter()
            try:
                self.run_once()
                self._rest(started)
            # a bad frame, a lost camera or a source's bad rate must not end the loop
            except Exception as exc:  # noqa: BLE001
                self.on_error(exc)
                self._stop.wait(0.5)

    def _rest(self, started: float) -> None:
        """Wait until the next frame is due at the pace, the last one `started` at perf_counter().

        The pace is looked at every PACE_CHECK_S: a job that ends brings the next frame at once.
        """
        while not self._stop.is_set():
            left = 1.0 / self.pace() - (time.perf_counter() - started)
            if left <= 0:
                return
            self._stop.wait(min(left, PACE_CHECK_S))

    def pace(self) -> float:
        """The frames per second the thread runs at.

        The source's, or fewer when fps_wanted() asks for fewer and no collect() is waiting for
        frames.
        """
        with self._recent_lock:
            collecting = bool(self._collectors)
        wanted = None if collecting else self.fps_wanted()
        fps = self._source_fps()
        return min(fps, wanted) if wanted else fps

    def _source_fps(self) -> float:
        """The source's frames per second; FALLBACK_FPS, told once (on_error), when it has no
        positive rate."""
        source, fps = self.source, self.source.fps
        if math.isfinite(fps) and fps > 0:
            return fps
        if self._told_rate is not source:
            self._told_rate = source
            self.on_error(MirrorscanError(f"{source.name}: plays at {fps:g} frames a second; "
                                          f"played at {FALLBACK_FPS:g} instead"))
        return FALLBACK_FPS
