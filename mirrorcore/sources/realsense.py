"""Intel RealSense through pyrealsense2 (optional, imported only when used): live cameras and .bag
recordings."""
from __future__ import annotations

import queue
import threading
import time
from pathlib import Path

import numpy as np

from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.sources.base import DepthSource, Frame, require

REALSENSE_INSTALL = "pip install 'mirrorscan[devices]' (PyPI pyrealsense2)"
BAG_TIMEOUT_S = 600.0           # a bag's playback that has not ended by then is reported as broken
# a playback still stopped this long after its start delivers nothing
BAG_START_S = 5.0


class RealSenseSource(DepthSource):
    """A live RealSense camera.

    z16 depth times the device's depth units (Frame.units holds the z16 values), intrinsics from
    the depth stream's profile, timestamps from the device in seconds. With `colour`, the colour
    stream (RGB8) is mapped onto the depth image by `rs.align(rs.stream.depth)`, which keeps the
    depth grid and values, and is Frame.colour.

    Parameters
    ----------
    serial : str
        '' = the first one.
    colour : bool
        Read the colour stream too, aligned to depth.

    Raises
    ------
    MirrorscanError
        pyrealsense2 is missing, or no camera can be started.
    """

    def __init__(self, serial: str = "", colour: bool = False):
        self.name = f"realsense:{serial}"
        rs = require("pyrealsense2", self.name, REALSENSE_INSTALL)
        if not rs.context().query_devices().size():
            raise MirrorscanError(
                f"{self.name}: no RealSense camera found (plugged in to a USB 3 port?)")
        config = rs.config()
        if serial:
            config.enable_device(serial)
        config.enable_stream(rs.stream.depth)
        self._align = None
        if colour:
            config.enable_stream(rs.stream.color, rs.format.rgb8)
            self._align = rs.align(rs.stream.depth)
        self._pipe = rs.pipeline()
        try:
            profile = self._pipe.start(config)
        except RuntimeError as exc:
            raise MirrorscanError(f"{self.name}: {exc}") from None
        self.intrinsics, self.fps = profile_camera(rs, profile)
        self.frame_count = None

    def read(self, i: int) -> Frame:
        """Return frame i (see `DepthSource.read`).

        Parameters
        ----------
        i : int
            The frame's index.

        Returns
        -------
        Frame
        """
        frames = self._pipe.wait_for_frames()
        if self._align is not None:
            frames = self._align.process(frames)
        depth = frames.get_depth_frame()
        units = np.asanyarray(depth.get_data()).copy()
        colour = None
        if self._align is not None:
            colour = np.asanyarray(frames.get_color_frame().get_data()).copy()
            if colour.shape != (*self.intrinsics.shape, 3):
                raise MirrorscanError(f"{self.name}: aligned colour is {colour.shape}, not the "
                                      f"depth's {self.intrinsics.shape} x 3")
        return Frame(units.astype(np.float32) * np.float32(self.intrinsics.depth_scale),
                     depth.get_timestamp() * 1e-3, colour, units)

    @property
    def has_colour(self) -> bool:
        """True when opened with `colour` (aligned to depth)."""
        return self._align is not None

    def close(self) -> None:
        """Stop the pipeline."""
        self._pipe.stop()


def profile_camera(rs, profile) -> tuple[Intrinsics, float]:
    """Read the depth camera of a started pipeline profile.

    Parameters
    ----------
    rs : module
        pyrealsense2.
    profile : pyrealsense2.pipeline_profile

    Returns
    -------
    intrinsics : Intrinsics
        depth_scale = the device's depth units.
    fps : float
    """
    stream = profile.get_stream(rs.stream.depth).as_video_stream_profile()
    return _camera(stream,
                   profile.get_device().first_depth_sensor().get_depth_scale()), float(stream.fps())


def _camera(stream, units: float) -> Intrinsics:
    """A depth video stream profile and its depth units (metres) -> Intrinsics."""
    k = stream.get_intrinsics()
    return Intrinsics(k.width, k.height, k.fx, k.fy, k.ppx, k.ppy, units)


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
    depth units, device timestamps in seconds. Opening plays the bag once to count its frames
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
                units, stamp = item
                return Frame(units.astype(np.float32) * np.float32(self.intrinsics.depth_scale),
                             stamp, units=units)

    def close(self) -> None:
        """Stop the playback."""
        if self._player is not None:
            self._player.close()
            self._player = None


BAG_QUEUE = 2           # frames decoded ahead of the reader


class _Playback:
    """One pass over a bag's depth frames: start(), then next() -> (units (H, W) uint16 or None,
    seconds) until None at the end; close() (or the with block) stops it, even while the callback
    waits for room in the queue."""

    def __init__(self, rs, path: Path, keep_data: bool = True):
        self.rs, self.path, self.keep_data = rs, path, keep_data
        self._queue: queue.Queue = queue.Queue(maxsize=BAG_QUEUE)
        self._stopping = threading.Event()
        self._started, self._delivered = False, 0
        try:
            self.playback = rs.context().load_device(str(path)).as_playback()
            self.sensor = next((s for s in self.playback.query_sensors()
                                if _depth_profile(rs, s) is not None), None)
            if self.sensor is None:
                raise FileFormatError(f"{path}: the recording has no depth stream")
            self.profile = _depth_profile(rs, self.sensor)
            self.camera = _camera(self.profile, self.sensor.as_depth_sensor().get_depth_scale())
            self.fps = float(self.profile.fps())
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
        item = (np.asanyarray(frame.get_data()).copy() if self.keep_data else None,
                frame.get_timestamp() * 1e-3)
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


def _depth_profile(rs, sensor):
    """The sensor's z16 depth stream profile, or None."""
    return next((p.as_video_stream_profile() for p in sensor.get_stream_profiles()
                 if p.stream_type() == rs.stream.depth), None)
