"""Live depth cameras through optional libraries, imported only when used: Kinect v1 (libfreenect)
and OpenNI2 devices and .oni recordings (PrimeSense, Xtion)."""
from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

import numpy as np

from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.depth.kinect import disparity_to_depth
from mirrorcore.sources.base import DepthSource, Frame, checked_depth, require

FREENECT_INSTALL = ("Debian's libfreenect-dev, then pip install 'mirrorscan[devices]' "
                    "(PyPI freenect builds against it)")
OPENNI2_INSTALL = "Debian's libopenni2-dev, then pip install 'mirrorscan[devices]' (PyPI openni)"
OPENNI2_LIBRARY_DIRS = ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib",
                        "/usr/local/lib")
# Nicolas Burrus' calibration of the Kinect v1's RGB camera, the grid of its registered depth (mm)
KINECT_V1_RGB = Intrinsics(640, 480, 529.21508098293293, 525.56393630057437, 328.94272028759258,
                           267.48068171871557, 0.001)
_OPENNI2_SCALES = {"PIXEL_FORMAT_DEPTH_1_MM": 0.001, "PIXEL_FORMAT_DEPTH_100_UM": 0.0001}


class FreenectSource(DepthSource):
    """A Kinect v1 through libfreenect's sync wrapper, live.

    Frames are 11-bit disparity counts (Frame.units, uint16, 2047 = no reading) converted to metres,
    without colour. With `colour`, frames are libfreenect's registered depth instead (millimetres
    on the RGB camera's 640x480 grid, warped by the device's own calibration tables; Frame.units
    holds the millimetres) with the RGB image (sync_get_video) as Frame.colour. Timestamps are
    seconds since the source opened, on the host's clock.

    Parameters
    ----------
    index : int
        The device.
    intrinsics : Intrinsics, optional
        The IR (depth) camera's, default Intrinsics.kinect_v1() (Burrus).
    disparity_model : callable
        (H, W) uint16 counts -> (H, W) float32 metres, 0 = no reading; by default Nicolas Burrus'
        calibration z = 1 / (counts * -0.0030711016 + 3.3309495161)
        (mirrorcore.depth.kinect.disparity_to_depth). Pass another function to use your own
        calibration.
    colour : bool
        Registered depth and colour; `intrinsics` then default to KINECT_V1_RGB.

    Raises
    ------
    MirrorscanError
        libfreenect is missing: what to install.
    """

    def __init__(self, index: int = 0, intrinsics: Intrinsics | None = None,
                 disparity_model: Callable[[np.ndarray], np.ndarray] = disparity_to_depth,
                 colour: bool = False):
        self.name, self.index = f"freenect:{index}", int(index)
        self._freenect = require("freenect", self.name, FREENECT_INSTALL)
        self._colour = bool(colour)
        self.intrinsics = intrinsics or (KINECT_V1_RGB if colour else Intrinsics.kinect_v1())
        self.fps, self.frame_count = 30.0, None
        self.disparity_model, self._t0 = disparity_model, time.monotonic()
        # fails here, at open, when there is no Kinect
        self._first: Frame | None = self._grab()

    @property
    def has_colour(self) -> bool:
        """True when opened with `colour` (registered depth and the RGB image)."""
        return self._colour

    def _grab(self) -> Frame:
        """Read the next frame from the device."""
        fn = self._freenect
        got = fn.sync_get_depth(self.index, fn.DEPTH_REGISTERED if self._colour else fn.DEPTH_11BIT)
        video = fn.sync_get_video(self.index, fn.VIDEO_RGB) if self._colour and got else None
        if got is None or (self._colour and video is None):
            raise MirrorscanError(f"{self.name}: no Kinect v1 found (plugged in, powered, and "
                                  "readable by this user?)")
        stamp = time.monotonic() - self._t0
        # copies: the binding reuses its buffers
        units = np.array(got[0], dtype=np.uint16)
        if not self._colour:
            return Frame(self.disparity_model(units), stamp, units=units)
        depth = checked_depth(units * np.float32(0.001), self.intrinsics, self.name)
        colour = np.array(video[0], dtype=np.uint8).reshape(*self.intrinsics.shape, 3)
        return Frame(depth, stamp, colour, units)

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
        frame, self._first = self._first or self._grab(), None
        return frame

    def close(self) -> None:
        """Stop the device."""
        self._freenect.sync_stop()


class OpenNI2Source(DepthSource):
    """An OpenNI2 device or an .oni recording (seekable).

    Depth comes in millimetres or 100 micrometres as the stream's pixel format says (Frame.units
    holds those units); intrinsics from the stream's fields of view (principal point at the image
    centre); timestamps from the device, seconds. With `colour`, the device registers depth to its
    colour camera (IMAGE_REGISTRATION_DEPTH_TO_COLOR, where it supports it; a recording keeps the
    registration it was made with) and the colour stream (RGB888 of the depth stream's size) is
    Frame.colour.

    Parameters
    ----------
    target : str
        '' = the first device, or a device URI, or an .oni file.
    colour : bool
        Read the colour stream too.

    Raises
    ------
    MirrorscanError
        OpenNI2 is missing, the device cannot be opened, or its depth pixel format is not one of
        those read.
    FileFormatError
        No such .oni recording.
    """

    def __init__(self, target: str = "", colour: bool = False):
        self.name = f"openni2:{target}"
        self._colour_stream = None
        self._openni2 = openni2 = require("openni.openni2", self.name, OPENNI2_INSTALL)
        initialise_openni2(openni2, self.name)
        is_file = target.lower().endswith(".oni")
        if is_file and not Path(target).is_file():
            raise FileFormatError(f"{target}: no such .oni recording")
        try:
            if is_file:
                self._device = openni2.Device.open_file(target.encode())
            else:
                self._device = (openni2.Device(target.encode()) if target
                                else openni2.Device.open_any())
            self._stream = self._device.create_depth_stream()
            self._stream.start()
            if colour:
                self._colour_stream = _registered_colour(openni2, self._device)
        except openni2.OpenNIError as exc:
            raise MirrorscanError(f"{self.name}: {_openni2_message(exc)}") from None
        mode = self._stream.get_video_mode()
        fmt = getattr(mode.pixelFormat, "name", str(mode.pixelFormat)).split(".")[-1]
        if fmt not in _OPENNI2_SCALES:
            raise MirrorscanError(f"{self.name}: depth pixel format {fmt} is not one of "
                                  f"{', '.join(_OPENNI2_SCALES)}")
        w, h = int(mode.resolutionX), int(mode.resolutionY)
        if self._colour_stream is not None:
            colour_mode = self._colour_stream.get_video_mode()
            if (int(colour_mode.resolutionX), int(colour_mode.resolutionY)) != (w, h):
                raise MirrorscanError(
                    f"{self.name}: colour {colour_mode.resolutionX}x{colour_mode.resolutionY} "
                    f"is not the depth's {w}x{h}; registration needs one size")
        fx = w / 2 / np.tan(self._stream.get_horizontal_fov() / 2)
        fy = h / 2 / np.tan(self._stream.get_vertical_fov() / 2)
        self.intrinsics = Intrinsics(w, h, fx, fy, (w - 1) / 2, (h - 1) / 2, _OPENNI2_SCALES[fmt])
        self.fps = float(mode.fps or 30)
        self._playback = self._device.playback if is_file else None
        if self._playback is not None:
            # manual: one frame per read, no real-time pacing
            self._playback.set_speed(-1)
        self.frame_count = (None if self._playback is None
                            else self._playback.get_number_of_frames(self._stream))

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
        streams = [s for s in (self._stream, self._colour_stream) if s is not None]
        if self._playback is not None:
            for stream in streams:
                self._playback.seek(stream, self._wrap(i))
        frame = self._stream.read_frame()
        h, w = self.intrinsics.shape
        units = np.frombuffer(frame.get_buffer_as_uint16(), np.uint16, h * w).reshape(h, w).copy()
        colour = None
        if self._colour_stream is not None:
            image = self._colour_stream.read_frame().get_buffer_as_uint8()
            colour = np.frombuffer(image, np.uint8, h * w * 3).reshape(h, w, 3).copy()
        return Frame(units.astype(np.float32) * np.float32(self.intrinsics.depth_scale),
                     frame.timestamp * 1e-6, colour, units)

    @property
    def has_colour(self) -> bool:
        """True when opened with `colour` (registered colour stream)."""
        return self._colour_stream is not None

    def close(self) -> None:
        """Stop the streams and close the device."""
        for stream in (self._stream, self._colour_stream):
            if stream is not None:
                stream.stop()
        self._device.close()


def _registered_colour(openni2, device):
    """Register the device's depth to its colour camera (where it can) and start its colour
    stream as RGB888; returns the stream."""
    mode = openni2.IMAGE_REGISTRATION_DEPTH_TO_COLOR
    if device.is_image_registration_mode_supported(mode):
        device.set_image_registration_mode(mode)
    stream = device.create_color_stream()
    stream.start()
    return stream


def initialise_openni2(openni2, what: str) -> None:
    """Load libOpenNI2 from the usual library folders.

    Parameters
    ----------
    openni2 : module
        openni.openni2.
    what : str
        The source, for the message.

    Raises
    ------
    MirrorscanError
        Saying what to install, when it is missing.
    """
    try:
        openni2.initialize([d for d in OPENNI2_LIBRARY_DIRS if (Path(d) / "libOpenNI2.so").exists()]
                           or ["."])
    except Exception as exc:  # openni raises its own InitializationError, not an ImportError
        raise MirrorscanError(f"{what}: cannot load libOpenNI2 "
                              f"({str(exc).splitlines()[0].strip()}); "
                              f"install {OPENNI2_INSTALL}") from None


def _openni2_message(exc: Exception) -> str:
    """OpenNIError(status, b'message', ...) -> its message as one line."""
    detail = exc.args[1] if len(exc.args) > 1 else exc
    return (detail.decode(errors="replace") if isinstance(detail, bytes)
            else str(detail)).strip().replace("\n", " ")
