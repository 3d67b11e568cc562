"""Intel RealSense through pyrealsense2 (optional, imported only when used): live cameras and .bag recordings."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..camera import Intrinsics
from ..errors import FileFormatError, MirrorscanError
from .base import DepthSource, Frame, require
from .files import StackSource

REALSENSE_INSTALL = "pip install 'mirrorscan[devices]' (PyPI pyrealsense2)"
BAG_END_WAIT_MS = 1000          # wait this long for a bag's next frame, then ask whether its playback stopped
BAG_MAX_WAITS = 10              # ... at most this many times in a row


class RealSenseSource(DepthSource):
    """A live RealSense camera (serial '' = the first one): z16 depth times the device's depth units (Frame.raw holds
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
        raw = np.asanyarray(depth.get_data()).copy()
        return Frame(raw.astype(np.float32) * np.float32(self.intrinsics.depth_scale), depth.get_timestamp() * 1e-3,
                     raw=raw)

    def close(self) -> None:
        self._pipe.stop()


def profile_camera(rs, profile) -> tuple[Intrinsics, float]:
    """A started pipeline profile -> the depth camera's Intrinsics (depth_scale = the device's depth units) and fps."""
    stream = profile.get_stream(rs.stream.depth).as_video_stream_profile()
    k = stream.get_intrinsics()
    units = profile.get_device().first_depth_sensor().get_depth_scale()
    return Intrinsics(k.width, k.height, k.fx, k.fy, k.ppx, k.ppy, units), float(stream.fps())


def open_bag(path: str | Path) -> StackSource:
    """A RealSense .bag recording (ROS1, as pyrealsense2 up to 2.55 writes), read whole into memory at open so that it
    is seekable: depth frames as z16 units (Frame.raw) times the recorded depth units, device timestamps in seconds.
    Raises FileFormatError for a missing or unreadable bag."""
    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"{path}: no such .bag recording")
    rs = require("pyrealsense2", f"bag:{path}", REALSENSE_INSTALL)
    config, pipe = rs.config(), rs.pipeline()
    config.enable_device_from_file(str(path), repeat_playback=False)
    try:
        profile = pipe.start(config)
    except RuntimeError as exc:
        raise FileFormatError(f"{path}: not a readable RealSense recording ({exc})") from None
    try:
        playback = profile.get_device().as_playback()
        playback.set_real_time(False)
        camera, fps = profile_camera(rs, profile)
        units, stamps, waits = [], [], 0
        while waits < BAG_MAX_WAITS:
            ok, frames = pipe.try_wait_for_frames(BAG_END_WAIT_MS)
            if not ok:                      # the end, or a slow machine: only a stopped playback is the end
                waits = BAG_MAX_WAITS if playback.current_status() == rs.playback_status.stopped else waits + 1
                continue
            waits = 0
            depth = frames.get_depth_frame()
            units.append(np.asanyarray(depth.get_data()).copy())
            stamps.append(depth.get_timestamp() * 1e-3)
    except RuntimeError as exc:
        raise FileFormatError(f"{path}: {exc}") from None
    finally:
        pipe.stop()
    if not units:
        raise FileFormatError(f"{path}: the recording has no depth frames")
    return StackSource(f"bag {path.name}", camera, np.stack(units), camera.depth_scale, np.asarray(stamps), fps=fps)
