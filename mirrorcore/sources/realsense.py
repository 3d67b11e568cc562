"""Intel RealSense through pyrealsense2 (optional, imported only when used): live cameras and .bag recordings."""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..errors import FileFormatError, MirrorscanError
from ..geometry.camera import Intrinsics
from .base import DepthSource, Frame, require
from .files import StackSource

REALSENSE_INSTALL = "pip install 'mirrorscan[devices]' (PyPI pyrealsense2)"
BAG_TIMEOUT_S = 600.0           # a bag's playback that has not ended by then is reported as broken
BAG_START_S = 5.0               # a playback still stopped this long after its start delivers nothing


class RealSenseSource(DepthSource):
    """A live RealSense camera (serial '' = the first one): z16 depth times the device's depth units (Frame.units holds
    the z16 values), intrinsics from the depth stream's profile, timestamps from the device in seconds."""

    def __init__(self, serial: str = ""):
        self.name = f"realsense:{serial}"
        rs = require("pyrealsense2", self.name, REALSENSE_INSTALL)
        if not rs.context().query_devices().size():
            raise MirrorscanError(f"{self.name}: no RealSense camera found (plugged in to a USB 3 port?)")
        config = rs.config()
        if serial:
            config.enable_device(serial)
        config.enable_stream(rs.stream.depth)
        self._pipe = rs.pipeline()
        try:
            profile = self._pipe.start(config)
        except RuntimeError as exc:
            raise MirrorscanError(f"{self.name}: {exc}") from None
        self.intrinsics, self.fps = profile_camera(rs, profile)
        self.frame_count = None

    def read(self, i: int) -> Frame:
        depth = self._pipe.wait_for_frames().get_depth_frame()
        units = np.asanyarray(depth.get_data()).copy()
        return Frame(units.astype(np.float32) * np.float32(self.intrinsics.depth_scale), depth.get_timestamp() * 1e-3,
                     units=units)

    def close(self) -> None:
        self._pipe.stop()


def profile_camera(rs, profile) -> tuple[Intrinsics, float]:
    """A started pipeline profile -> the depth camera's Intrinsics (depth_scale = the device's depth units) and fps."""
    stream = profile.get_stream(rs.stream.depth).as_video_stream_profile()
    return _camera(stream, profile.get_device().first_depth_sensor().get_depth_scale()), float(stream.fps())


def _camera(stream, units: float) -> Intrinsics:
    """A depth video stream profile and its depth units (metres) -> Intrinsics."""
    k = stream.get_intrinsics()
    return Intrinsics(k.width, k.height, k.fx, k.fy, k.ppx, k.ppy, units)


def open_bag(path: str | Path) -> StackSource:
    """A RealSense .bag recording (ROS1, as pyrealsense2 up to 2.55 writes), read whole into memory at open so that it
    is seekable: depth frames as z16 units (Frame.units) times the recorded depth units, device timestamps in seconds.
    The depth sensor of the playback device is read through a callback with real-time playback off, so that the
    playback waits for each frame (a pipeline drops frames on a busy machine). Raises FileFormatError for a missing or
    unreadable bag."""
    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"{path}: no such .bag recording")
    rs = require("pyrealsense2", f"bag:{path}", REALSENSE_INSTALL)
    try:
        playback = rs.context().load_device(str(path)).as_playback()
        sensor = next((s for s in playback.query_sensors() if _depth_profile(rs, s) is not None), None)
        if sensor is None:
            raise FileFormatError(f"{path}: the recording has no depth stream")
        profile = _depth_profile(rs, sensor)
        playback.set_real_time(False)
        units, stamps = [], []

        def take(frame) -> None:
            units.append(np.asanyarray(frame.get_data()).copy())
            stamps.append(frame.get_timestamp() * 1e-3)

        sensor.open(profile)
        sensor.start(take)
        try:
            _wait_until_played(rs, playback, path, units)
        finally:
            sensor.stop()
            sensor.close()
        camera = _camera(profile, sensor.as_depth_sensor().get_depth_scale())
    except RuntimeError as exc:
        raise FileFormatError(f"{path}: not a readable RealSense recording ({exc})") from None
    if not units:
        raise FileFormatError(f"{path}: the recording has no depth frames")
    return StackSource(f"bag {path.name}", camera, np.stack(units), camera.depth_scale, np.asarray(stamps),
                       fps=float(profile.fps()))


def _depth_profile(rs, sensor):
    """The sensor's z16 depth stream profile, or None."""
    return next((p.as_video_stream_profile() for p in sensor.get_stream_profiles()
                 if p.stream_type() == rs.stream.depth), None)


def _wait_until_played(rs, playback, path: Path, received: list) -> None:
    """Wait for the playback to stop after delivering frames (it reads 'stopped' before it starts, too)."""
    start = time.monotonic()
    while True:
        stopped = playback.current_status() == rs.playback_status.stopped
        waited = time.monotonic() - start
        if stopped and (received or waited > BAG_START_S):
            return
        if waited > BAG_TIMEOUT_S:
            raise FileFormatError(f"{path}: the playback did not end within {BAG_TIMEOUT_S:g} s")
        time.sleep(0.01)
