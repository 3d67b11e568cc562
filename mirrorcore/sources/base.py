"""The depth source interface: Frame (one depth image with its time, colour and the sensor's own
units) and DepthSource."""
from __future__ import annotations

import importlib
from abc import ABC, abstractmethod
from dataclasses import dataclass
from types import ModuleType
from typing import Iterator

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics, check_depth_shape


@dataclass(frozen=True)
class Frame:
    """One frame of a depth source.

    Attributes
    ----------
    depth : (H, W) float32 array
        Metres, 0 = no reading (never NaN or inf).
    timestamp : float
        Seconds on the source's clock (a recording's own times, or seconds since a live source
        opened).
    colour : (H, W, 3) uint8 array or None
        RGB registered to the depth image: pixel (v, u) is the colour of depth pixel (v, u). None
        for a frame without colour (see `DepthSource.has_colour`).
    units : (H, W) uint16 array or None
        The sensor's own values before conversion to metres (Kinect v1: 11-bit disparity, 2047 = no
        reading, or millimetres in its registered mode; RealSense: z16 units).
    """

    depth: np.ndarray
    timestamp: float
    colour: np.ndarray | None = None
    units: np.ndarray | None = None


class DepthSource(ABC):
    """Frames of one depth camera, live or recorded.

    read(i): a seekable source returns frame i modulo frame_count (so playing i = 0, 1, 2... loops
    and any i seeks); a live source ignores i and returns its next frame, blocking until it arrives.
    Use a source as a context manager (close() releases the device or the file) and as an iterator
    (a recording's frames once; a live source's forever).

    Attributes
    ----------
    name : str
        For people.
    intrinsics : Intrinsics
        The depth camera's (depth_scale = the units its recording uses).
    fps : float
        Nominal frame rate.
    frame_count : int or None
        The frames of a seekable source (a recording); None for a live one.
    """

    name: str
    intrinsics: Intrinsics
    fps: float
    frame_count: int | None

    @property
    def live(self) -> bool:
        """True for a live camera (no frame count, no seeking)."""
        return self.frame_count is None

    @property
    def camera(self) -> bool:
        """True for a physical camera: live, and not a rendering of a simulated rig."""
        return self.live

    @property
    def has_colour(self) -> bool:
        """True when the source's frames carry `Frame.colour` (RGB registered to the depth
        image); False when every frame's colour is None and the views fall back to the source
        colours."""
        return False

    @abstractmethod
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

    def background(self) -> np.ndarray | None:
        """The scene without the object as (H, W) float32 metres, or None if the source has none."""
        return None

    def truth(self) -> dict | None:
        """What a simulated source knows of its scene (the truth.json object a recording of it
        holds, sim.export.truth_json), or None for any other source."""
        return None

    def close(self) -> None:
        """Release the device or files; reading after close is an error.

        Closing twice does nothing.
        """

    def __enter__(self) -> "DepthSource":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __iter__(self) -> Iterator[Frame]:
        i = 0
        while self.frame_count is None or i < self.frame_count:
            yield self.read(i)
            i += 1

    def _wrap(self, i: int) -> int:
        """i modulo frame_count for a seekable source (looping); MirrorscanError for an empty
        one."""
        if not self.frame_count:
            raise MirrorscanError(f"{self.name}: no frames to read")
        return int(i) % self.frame_count


def checked_depth(depth: np.ndarray, intr: Intrinsics, where: str) -> np.ndarray:
    """Check a depth image against the camera and clean it.

    Parameters
    ----------
    depth : (H, W) array
        Metres.
    intr : Intrinsics
    where : str
        The image, for the message.

    Returns
    -------
    (H, W) float32 array
        Metres, with NaN, inf and negative values set to 0 (no reading).

    Raises
    ------
    FileFormatError
        Naming `where`, when the size does not match.
    """
    depth = np.asarray(check_depth_shape(intr, depth, where), dtype=np.float32)
    return np.where(np.isfinite(depth) & (depth > 0), depth, np.float32(0))


def require(module: str, what: str, install: str) -> ModuleType:
    """Import an optional library when a source needs it.

    Parameters
    ----------
    module : str
        The module to import.
    what : str
        The source, for the message ('freenect:0').
    install : str
        How to get the library.

    Returns
    -------
    module

    Raises
    ------
    MirrorscanError
        Saying what to install, when the library is missing.
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MirrorscanError(
            f"{what}: cannot import {module} ({exc}); install {install}") from None
