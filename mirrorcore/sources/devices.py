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
from mirrorcore.sources.base import DepthSource, Frame, require

FREENECT_INSTALL = ("Debian's libfreenect-dev, then pip install 'mirrorscan[devices]' "
                    "(PyPI freenect builds against it)")
OPENNI2_INSTALL = "Debian's libopenni2-dev, then pip install 'mirrorscan[devices]' (PyPI openni)"
OPENNI2_LIBRARY_DIRS = ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib",
                        "/usr/local/lib")
_OPENNI2_SCALES = {"PIXEL_FORMAT_DEPTH_1_MM": 0.001, "PIXEL_FORMAT_DEPTH_100_UM": 0.0001}


class FreenectSource(DepthSource):
    """A Kinect v1 through libfreenect's sync wrapper, live.

    Frames are 11-bit disparity counts (Frame.units, uint16, 2047 = no reading) converted to metres.
    Timestamps are seconds since the source opened, on the host's clock.

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

    Raises
    ------
    MirrorscanError
        libfreenect is missing: what to install.
    """

    def __init__(self, index: int = 0, intrinsics: Intrinsics | None = None,
                 disparity_model: Callable[[np.ndarray], np.ndarray] = disparity_to_depth):
        self.name, self.index = f"freenect:{index}", int(index)
        self._freenect = require("freenect", self.name, FREENECT_INSTALL)
        self.intrinsics = intrinsics or Intrinsics.kinect_v1()
        self.fps, self.frame_count = 30.0, None
        self.disparity_model, self._t0 = disparity_model, time.monotonic()
        # fails here, at open, when there is no Kinect
        self._first: Frame | None = self._grab()

    def _grab(self) -> Frame:
        """Read the next frame from the device."""
        got = self._freenect.sync_get_depth(self.index, self._freenect.DEPTH_11BIT)
        if got is None:
            raise MirrorscanError(f"{self.name}: no Kinect v1 found (plugged in, powered, and "
                                  "readable by this user?)")
        counts = np.array(got[0], dtype=np.uint16)        # a copy: the binding reuses its buffer
        return Frame(self.disparity_model(counts), time.monotonic() - self._t0, units=counts)

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
    centre); timestamps from the device, seconds.

    Parameters
    ----------
    target : str
        '' = the first device, or a device URI, or an .oni file.

    Raises
    ------
    MirrorscanError
        OpenNI2 is missing, the device cannot be opened, or its depth pixel format is not one of
        those read.
    FileFormatError
        No such .oni recording.
    """

    def __init__(self, target: str = ""):
        self.name = f"openni2:{target}"
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
        except openni2.OpenNIError as exc:
            raise MirrorscanError(f"{self.name}: {_openni2_message(exc)}") from None
        mode = self._stream.get_video_mode()
        fmt = getattr(mode.pixelFormat, "name", str(mode.pixelFormat)).split(".")[-1]
        if fmt not in _OPENNI2_SCALES:
            raise MirrorscanError(f"{self.name}: depth pixel format {fmt} is not one of "
                                  f"{', '.join(_OPENNI2_SCALES)}")
        w, h = int(mode.resolutionX), int(mode.resolutionY)
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
        if self._playback is not None:
            self._playback.seek(self._stream, self._wrap(i))
        frame = self._stream.read_frame()
        h, w = self.intrinsics.shape
        units = np.frombuffer(frame.get_buffer_as_uint16(), np.uint16, h * w).reshape(h, w).copy()
        return Frame(units.astype(np.float32) * np.float32(self.intrinsics.depth_scale),
                     frame.timestamp * 1e-6,
                     units=units)

    def close(self) -> None:
        """Stop the stream and close the device."""
        self._stream.stop()
        self._device.close()


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
