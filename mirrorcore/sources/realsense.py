"""Intel RealSense cameras through pyrealsense2 (optional, imported only when used); their .bag
recordings are in mirrorcore.sources.bag."""
from __future__ import annotations

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.sources.base import DepthSource, Frame, require

REALSENSE_INSTALL = "pip install 'mirrorscan[devices]' (PyPI pyrealsense2)"


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
        self.intrinsics, self.fps = profilestream_camera(rs, profile)
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


def profilestream_camera(rs, profile) -> tuple[Intrinsics, float]:
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
    return stream_camera(stream,
                   profile.get_device().first_depth_sensor().get_depth_scale()), float(stream.fps())


def stream_camera(stream, units: float) -> Intrinsics:
    """A depth video stream profile and its depth units -> Intrinsics.

    Parameters
    ----------
    stream : pyrealsense2.video_stream_profile
    units : float
        Metres per z16 unit.

    Returns
    -------
    Intrinsics
    """
    k = stream.get_intrinsics()
    return Intrinsics(k.width, k.height, k.fx, k.fy, k.ppx, k.ppy, units)
