"""RealSense .bag recordings through pyrealsense2 (optional, imported only when used): depth and
colour aligned to depth, played one frame at a time."""
from __future__ import annotations

import queue
import threading
import time
from collections import deque
from pathlib import Path

import numpy as np

from mirrorcore.base.errors import FileFormatError
from mirrorcore.sources.base import DepthSource, Frame, require
from mirrorcore.sources.realsense import REALSENSE_INSTALL, stream_camera

BAG_TIMEOUT_S = 600.0           # a bag's playback that has not ended by then is reported as broken
# a playback still stopped this long after its start delivers nothing
BAG_START_S = 5.0


def open_bag(path: str | Path) -> "BagSource":
    """Open a RealSense .bag recording to read one frame at a time (see BagSource).

    ROS1 bags, as pyrealsense2 up to 2.55 writes them.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    BagSource

    Raises
    ------
    FileFormatError
        A missing or unreadable bag.
    """
    return BagSource(path)


class BagSource(DepthSource):
    """A .bag played from its file one frame at a time.

    Memory does not grow with its length. Depth frames as z16 units (Frame.units) times the recorded
    depth units, device timestamps in seconds. A bag with a colour stream (rgb8, bgr8, rgba8 or
    bgra8) delivers it as Frame.colour, RGB mapped onto the depth image by
    `rs.align(rs.stream.depth)` (as RealSenseSource with `colour`): each depth frame takes the
    colour frame nearest it in time. Opening plays the bag once to count its frames
    (keeping only their timestamps). read(i) for the next frame takes it from the playback; any
    other i restarts the playback from the start and skips to it (seeking costs a replay). The depth
    sensor is read through a callback with real-time playback off, so the playback waits for each
    frame (a pipeline drops frames on a busy machine); the callback hands frames over through a
    queue of BAG_QUEUE.

    Parameters
    ----------
    path : str or Path

    Raises
    ------
    FileFormatError
        A missing bag, one without depth frames, or one that cannot be read.
    MirrorscanError
        pyrealsense2 is missing.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        if not self.path.is_file():
            raise FileFormatError(f"{self.path}: no such .bag recording")
        self.name = f"bag {self.path.name}"
        self._rs = require("pyrealsense2", f"bag:{self.path}", REALSENSE_INSTALL)
        self._player: _Playback | None = None
        self._next = 0
        with _Playback(self._rs, self.path, keep_data=False) as index:
            self.intrinsics, self.fps = index.camera, index.fps
            self._colour = index.colour_sensor is not None
            self.timestamps = []
            while (item := index.next()) is not None:
                self.timestamps.append(item[1])
        self.frame_count = len(self.timestamps)
        if not self.frame_count:
            raise FileFormatError(f"{self.path}: the recording has no depth frames")

    def read(self, i: int) -> Frame:
        """Return frame i (see `DepthSource.read`).

        Parameters
        ----------
        i : int
            The frame's index.

        Returns
        -------
        Frame

        Raises
        ------
        MirrorscanError, FileFormatError
            With a one-line message.
        """
        i = self._wrap(i)
        if self._player is None or i < self._next:
            self.close()
            self._player, self._next = _Playback(self._rs, self.path).start(), 0
        while True:
            item = self._player.next()
            if item is None:
                raise FileFormatError(f"{self.path}: the playback ended after {self._next} frames, "
                                      f"{self.frame_count} were counted")
            self._next += 1
            if self._next > i:
                units, stamp, colour = item
                return Frame(units.astype(np.float32) * np.float32(self.intrinsics.depth_scale),
                             stamp, colour, units)

    @property
    def has_colour(self) -> bool:
        """True when the bag has a colour stream of a format read (aligned to depth)."""
        return self._colour

    def close(self) -> None:
        """Stop the playback."""
        if self._player is not None:
            self._player.close()
            self._player = None


BAG_QUEUE = 2           # frames decoded ahead of the reader


class _Playback:
    """One pass over a bag's frames: start(), then next() -> (units (H, W) uint16 or None, seconds,
    colour (H, W, 3) uint8 RGB aligned to depth or None) until None at the end; close() (or the
    with block) stops it, even while a callback waits for room in the queue.

    Without keep_data (counting frames) or without a colour stream, only the depth sensor plays.
    With both, each sensor's callback queues its frames in the order the playback hands them
    out; a depth frame is paired with the colour frame nearest it in time once a colour frame at or
    after it has come (or the playback has ended), then both go through `rs.align(rs.stream.depth)`.
    """

    def __init__(self, rs, path: Path, keep_data: bool = True):
        self.rs, self.path, self.keep_data = rs, path, keep_data
        self._queue: queue.Queue = queue.Queue(maxsize=BAG_QUEUE)
        self._stopping = threading.Event()
        self._started, self._delivered = False, 0
        try:
            self.playback = rs.context().load_device(str(path)).as_playback()
            sensors = self.playback.query_sensors()
            self.sensor = next((s for s in sensors if _depth_profile(rs, s) is not None), None)
            if self.sensor is None:
                raise FileFormatError(f"{path}: the recording has no depth stream")
            self.profile = _depth_profile(rs, self.sensor)
            self.camera = stream_camera(self.profile,
                                        self.sensor.as_depth_sensor().get_depth_scale())
            self.fps = float(self.profile.fps())
            self._to_rgb = _colour_formats(rs)
            self.colour_sensor, self.colour_profile = next(
                ((s, c) for s in sensors if s != self.sensor
                 and (c := _colour_profile(rs, s, self._to_rgb)) is not None), (None, None))
            self.playback.set_real_time(False)
        except RuntimeError as exc:
            raise FileFormatError(f"{path}: not a readable RealSense recording ({exc})") from None
        self._aligning = keep_data and self.colour_sensor is not None
        self._depths: deque = deque()
        self._colours: list = []
        self._ended = False

    def __enter__(self) -> "_Playback":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.close()

    def start(self) -> "_Playback":
        """Start the playback; returns self."""
        try:
            if self._aligning:
                # both sensors started before the first frame is played
                self.playback.pause()
                self._pair: list = []
                self._compose = self.rs.processing_block(
                    lambda frame, out: out.frame_ready(out.allocate_composite_frame(self._pair)))
                self._composed = self.rs.frame_queue(1)
                self._compose.start(self._composed)
                self._align = self.rs.align(self.rs.stream.depth)
                self.colour_sensor.open(self.colour_profile)
                self.colour_sensor.start(lambda frame: self._put((False, frame)))
            self.sensor.open(self.profile)
            self.sensor.start(self._take)
            if self._aligning:
                self.playback.resume()
        except RuntimeError as exc:
            raise FileFormatError(
                f"{self.path}: not a readable RealSense recording ({exc})") from None
        self._started, self._start_time = True, time.monotonic()
        return self

    def _take(self, frame) -> None:
        """The depth sensor's callback (librealsense's thread)."""
        if self._aligning:
            self._put((True, frame))
        else:
            self._put((np.asanyarray(frame.get_data()).copy() if self.keep_data else None,
                       frame.get_timestamp() * 1e-3, None))

    def _put(self, item) -> None:
        """Queue an item; wait for room, so that the playback waits too."""
        while not self._stopping.is_set():
            try:
                self._queue.put(item, timeout=0.05)
                return
            except queue.Full:
                continue

    def next(self) -> tuple | None:
        """Return the next depth frame, or None once the playback has stopped after delivering its
        frames.

        Raises
        ------
        FileFormatError
            The playback has not ended within BAG_TIMEOUT_S.
        """
        if not self._aligning:
            return self._next_item()
        while True:
            if self._depths:
                depth, t = self._depths[0], self._depths[0].get_timestamp()
                if self._ended or any(c.get_timestamp() >= t for c in self._colours):
                    self._depths.popleft()
                    if self._colours:
                        gaps = [abs(c.get_timestamp() - t) for c in self._colours]
                        del self._colours[:int(np.argmin(gaps))]
                    return self._aligned(depth, self._colours[0] if self._colours else None)
            elif self._ended:
                return None
            item = self._next_item()
            if item is None:
                self._ended = True
                continue
            is_depth, frame = item
            if is_depth:
                self._depths.append(frame)
            else:
                # the older ones can no longer be the nearest to a later depth frame
                self._colours = self._colours[-BAG_QUEUE:] + [frame]

    def _aligned(self, depth, colour) -> tuple:
        """A depth frame and its colour frame (or None) -> (units, seconds, RGB aligned or None)."""
        stamp = depth.get_timestamp() * 1e-3
        if colour is None:
            return np.asanyarray(depth.get_data()).copy(), stamp, None
        self._pair = [depth, colour]
        self._compose.invoke(depth)
        frames = self._align.process(self._composed.wait_for_frame().as_frameset())
        to_rgb = self._to_rgb[frames.get_color_frame().get_profile().format()]
        return (np.asanyarray(frames.get_depth_frame().get_data()).copy(), stamp,
                np.ascontiguousarray(to_rgb(np.asanyarray(frames.get_color_frame().get_data()))))

    def _next_item(self) -> tuple | None:
        """The next item of the queue, or None once the playback has stopped after delivering its
        frames. It reads 'stopped' before it starts too (BAG_START_S)."""
        while True:
            try:
                item = self._queue.get(timeout=0.02)
                self._delivered += 1
                return item
            except queue.Empty:
                pass
            stopped = self.playback.current_status() == self.rs.playback_status.stopped
            waited = time.monotonic() - self._start_time
            if stopped and self._queue.empty() and (self._delivered or waited > BAG_START_S):
                return None
            if waited > BAG_TIMEOUT_S:
                raise FileFormatError(
                    f"{self.path}: the playback did not end within {BAG_TIMEOUT_S:g} s")

    def close(self) -> None:
        """Stop the playback, even while a callback waits for room in the queue."""
        self._stopping.set()
        if self._started:
            self._started = False
            sensors = (self.sensor, self.colour_sensor) if self._aligning else (self.sensor,)
            for sensor in sensors:
                try:
                    sensor.stop()
                    sensor.close()
                except RuntimeError:
                    pass
            self._depths.clear()
            self._colours.clear()


def _depth_profile(rs, sensor):
    """The sensor's z16 depth stream profile, or None."""
    return next((p.as_video_stream_profile() for p in sensor.get_stream_profiles()
                 if p.stream_type() == rs.stream.depth), None)


def _colour_formats(rs) -> dict:
    """The colour formats read: rs.format -> a function of (H, W, channels) uint8 giving RGB."""
    return {rs.format.rgb8: lambda a: a, rs.format.bgr8: lambda a: a[..., ::-1],
            rs.format.rgba8: lambda a: a[..., :3], rs.format.bgra8: lambda a: a[..., 2::-1]}


def _colour_profile(rs, sensor, formats: dict):
    """The sensor's colour stream profile of a format read, or None."""
    return next((p.as_video_stream_profile() for p in sensor.get_stream_profiles()
                 if p.stream_type() == rs.stream.color and p.format() in formats), None)
