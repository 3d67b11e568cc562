"""RealSense .bag recordings through pyrealsense2 (optional, imported only when used): depth and
colour aligned to depth, played one frame at a time."""
from __future__ import annotations

import queue
import threading
import time
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
    queue of BAG_QUEUE. The colour stream plays in a second playback of the same file (one sensor
    each: a playback whose second sensor starts late drops that sensor's first frames).

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
        self._player: _Playback | _AlignedPass | None = None
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
            self._player = (_AlignedPass(self._rs, self.path) if self._colour
                            else _Playback(self._rs, self.path).start())
            self._next = 0
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
    """One pass over one stream of a bag, the depth's or (with `colour`) the colour's: start(),
    then next() until None at the end; close() (or the with block) stops it, even while the
    callback waits for room in the queue.

    next() gives (units (H, W) uint16 or None without keep_data, seconds, None), or with `frames`
    (pyrealsense2 frame, seconds) to align.
    """

    def __init__(self, rs, path: Path, keep_data: bool = True, colour: bool = False,
                 frames: bool = False):
        self.rs, self.path, self.keep_data, self.frames = rs, path, keep_data, frames
        self._queue: queue.Queue = queue.Queue(maxsize=BAG_QUEUE)
        self._stopping = threading.Event()
        self._started, self._delivered = False, 0
        try:
            self.playback = rs.context().load_device(str(path)).as_playback()
            sensors = self.playback.query_sensors()
            self.depth_sensor = next((s for s in sensors if _depth_profile(rs, s) is not None),
                                     None)
            if self.depth_sensor is None:
                raise FileFormatError(f"{path}: the recording has no depth stream")
            self.depth_profile = _depth_profile(rs, self.depth_sensor)
            self.camera = stream_camera(self.depth_profile,
                                        self.depth_sensor.as_depth_sensor().get_depth_scale())
            self.fps = float(self.depth_profile.fps())
            self.colour_sensor, self.colour_profile = next(
                ((s, c) for s in sensors if s != self.depth_sensor
                 and (c := _colour_profile(rs, s)) is not None), (None, None))
            self.sensor, self.profile = ((self.colour_sensor, self.colour_profile) if colour
                                         else (self.depth_sensor, self.depth_profile))
            self.playback.set_real_time(False)
        except RuntimeError as exc:
            raise FileFormatError(f"{path}: not a readable RealSense recording ({exc})") from None

    def __enter__(self) -> "_Playback":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.close()

    def start(self) -> "_Playback":
        """Start the playback; returns self."""
        try:
            self.sensor.open(self.profile)
            self.sensor.start(self._take)
        except RuntimeError as exc:
            raise FileFormatError(
                f"{self.path}: not a readable RealSense recording ({exc})") from None
        self._started, self._start_time = True, time.monotonic()
        return self

    def _take(self, frame) -> None:
        """The sensor's callback (librealsense's thread): wait for room, so that the playback waits
        too."""
        stamp = frame.get_timestamp() * 1e-3
        if self.frames:
            item = (frame, stamp)
        else:
            item = (np.asanyarray(frame.get_data()).copy() if self.keep_data else None, stamp, None)
        while not self._stopping.is_set():
            try:
                self._queue.put(item, timeout=0.05)
                return
            except queue.Full:
                continue

    def next(self) -> tuple | None:
        """Return the next frame, or None once the playback has stopped after delivering its frames.

        It reads 'stopped' before it starts too (BAG_START_S).

        Raises
        ------
        FileFormatError
            The playback has not ended within BAG_TIMEOUT_S.
        """
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
        """Stop the playback, even while the callback waits for room in the queue."""
        self._stopping.set()
        if self._started:
            self._started = False
            try:
                self.sensor.stop()
                self.sensor.close()
            except RuntimeError:
                pass


class _AlignedPass:
    """One pass over a bag's depth frames with its colour, from two playbacks of the file.

    next() -> (units (H, W) uint16, seconds, colour (H, W, 3) uint8 RGB aligned to depth) until
    None at the end. Each depth frame takes the colour frame nearest it in time (the colour
    playback is read until a colour frame at or after the depth frame, or its end); both go
    through `rs.align(rs.stream.depth)` as one frameset, the recorded extrinsics between the two
    streams registered across the two playbacks.
    """

    def __init__(self, rs, path: Path):
        self.rs = rs
        self.depth = _Playback(rs, path, frames=True)
        self.colour = _Playback(rs, path, colour=True, frames=True)
        try:
            extrinsics = self.depth.depth_profile.get_extrinsics_to(self.depth.colour_profile)
            self.depth.depth_profile.register_extrinsics_to(self.colour.colour_profile,
                                                            extrinsics)
        except RuntimeError as exc:
            raise FileFormatError(f"{path}: not a readable RealSense recording ({exc})") from None
        self._pair: list = []
        self._compose = rs.processing_block(
            lambda frame, out: out.frame_ready(out.allocate_composite_frame(self._pair)))
        self._composed = rs.frame_queue(1)
        self._compose.start(self._composed)
        self._align = rs.align(rs.stream.depth)
        self._to_rgb = _to_rgb(rs)
        # the last two colour frames read: one before the depth frame, one at or after it
        self._colours: list = []
        self._colour_ended = False
        self.depth.start()
        self.colour.start()

    def next(self) -> tuple | None:
        """Return the next depth frame with its colour aligned, or None at the end."""
        item = self.depth.next()
        if item is None:
            return None
        depth, stamp = item
        while not self._colour_ended and (not self._colours or self._colours[-1][1] < stamp):
            colour = self.colour.next()
            if colour is None:
                self._colour_ended = True
            else:
                self._colours = self._colours[-1:] + [colour]
        if not self._colours:
            return np.asanyarray(depth.get_data()).copy(), stamp, None
        colour = min(self._colours, key=lambda c: abs(c[1] - stamp))[0]
        self._pair = [depth, colour]
        self._compose.invoke(depth)
        frames = self._align.process(self._composed.wait_for_frame().as_frameset())
        to_rgb = self._to_rgb[frames.get_color_frame().get_profile().format()]
        return (np.asanyarray(frames.get_depth_frame().get_data()).copy(), stamp,
                np.ascontiguousarray(to_rgb(np.asanyarray(frames.get_color_frame().get_data()))))

    def close(self) -> None:
        """Stop both playbacks."""
        self._colours, self._pair = [], []
        self.depth.close()
        self.colour.close()


def _depth_profile(rs, sensor):
    """The sensor's z16 depth stream profile, or None."""
    return next((p.as_video_stream_profile() for p in sensor.get_stream_profiles()
                 if p.stream_type() == rs.stream.depth), None)


def _to_rgb(rs) -> dict:
    """The colour formats read: rs.format -> a function of (H, W, channels) uint8 giving RGB."""
    return {rs.format.rgb8: lambda a: a, rs.format.bgr8: lambda a: a[..., ::-1],
            rs.format.rgba8: lambda a: a[..., :3], rs.format.bgra8: lambda a: a[..., 2::-1]}


def _colour_profile(rs, sensor):
    """The sensor's colour stream profile of a format read, or None."""
    return next((p.as_video_stream_profile() for p in sensor.get_stream_profiles()
                 if p.stream_type() == rs.stream.color and p.format() in _to_rgb(rs)), None)
