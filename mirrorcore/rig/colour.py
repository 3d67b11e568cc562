"""The colour of a cloud's points: each point takes its pixel's colour, divided by the colour gains
of the mirrors its view reflects on (SessionMirror.colour_gain), so that every view shows the
surface's own colour."""
from __future__ import annotations

from typing import Sequence

import cv2
import numpy as np

from mirrorcore.base.errors import FileFormatError
from mirrorcore.base.palette import LAST_LABEL, source_sequence
from mirrorcore.geometry.camera import Intrinsics


def view_gain(gains: Sequence[Sequence[float] | None], label: int) -> np.ndarray:
    """Return the colour gain of one view: the product of the gains of the mirrors it reflects on.

    Parameters
    ----------
    gains : sequence of (3,) or None
        Each mirror's gain, session order (None: not measured, taken as 1).
    label : int
        A source label (mirrorcore.base.palette).

    Returns
    -------
    (3,) float64
        Red, green, blue; ones for the direct view.
    """
    gain = np.ones(3)
    for j in source_sequence(label):
        if j <= len(gains) and gains[j - 1] is not None:
            gain *= gains[j - 1]
    return gain


def correction_table(gains: Sequence[Sequence[float] | None]) -> np.ndarray:
    """Return the colour correction of every source label.

    Parameters
    ----------
    gains : sequence of (3,) or None
        Each mirror's gain, session order.

    Returns
    -------
    (LAST_LABEL + 1, 4) float32
        Row `label`: 1 / view_gain(gains, label) for red, green and blue, then 1 (so that a row
        is one 16-byte word for point_colours); ones for labels that name no view.
    """
    table = np.ones((LAST_LABEL + 1, 4), np.float32)
    for label in range(LAST_LABEL + 1):
        try:
            table[label, :3] = 1.0 / view_gain(gains, label)
        except ValueError:
            continue
    table.flags.writeable = False
    return table


def rgb_words(rgb: np.ndarray) -> np.ndarray:
    """Pack RGB colours as one 4-byte word each, so that a selection of them is one take.

    Parameters
    ----------
    rgb : (..., 3) uint8 array
        An image (H, W, 3) or colours (n, 3); a strided view is fine.

    Returns
    -------
    (N,) uint32 array
        Each colour's bytes red, green, blue, 255, in C order of `rgb`'s leading axes.
    """
    rgb = np.asarray(rgb)
    # OpenCV refuses an empty image: an empty cloud has no words
    if rgb.size == 0:
        return np.zeros(0, np.uint32)
    return cv2.cvtColor(rgb.reshape(-1, 1, 3), cv2.COLOR_RGB2RGBA).view(np.uint32).reshape(-1)


def point_colours(image: np.ndarray, pixel_index: np.ndarray, sources: np.ndarray,
                  correction: np.ndarray) -> np.ndarray:
    """Return the corrected colour of points from their pixels.

    Parameters
    ----------
    image : (H, W, 3) uint8
        RGB registered to the depth image.
    pixel_index : (n,) int
        Flat depth pixel index v * W + u of each point.
    sources : (n,) uint8
        Each point's source label.
    correction : (LAST_LABEL + 1, 4) float32
        correction_table's factors by label.

    Returns
    -------
    (n, 3) uint8
        RGB levels, rounded and saturated at 255: a strided view of (n, 4) rows
        (np.ascontiguousarray before handing its buffer on).
    """
    # one 4-byte word a pixel and one 16-byte row of factors a label: each point's colour and
    # factors are then single-element takes (a third of the time of (n, 3) takes)
    rgba = rgb_words(image)
    raw = np.take(rgba, pixel_index).view(np.uint8).reshape(-1, 4)
    rows = np.ascontiguousarray(correction, np.float32).view(np.complex128).reshape(-1)
    scale = np.take(rows, sources).view(np.float32)
    return cv2.multiply(raw, scale.reshape(-1, 4), dtype=cv2.CV_8U)[:, :3]


def check_colour_image(intr: Intrinsics, image: np.ndarray,
                       where: str = "colour image") -> np.ndarray:
    """Check that a colour image is RGB on the depth pixel grid.

    Parameters
    ----------
    intr : Intrinsics
        The depth camera.
    image : array_like
        The colour image.
    where : str
        What the image is, for the message.

    Returns
    -------
    (H, W, 3) uint8
        `image` as an array.

    Raises
    ------
    FileFormatError
        Not 8-bit RGB of the depth image's size.
    """
    image = np.asarray(image)
    if image.shape != (*intr.shape, 3) or image.dtype != np.uint8:
        raise FileFormatError(
            f"{where}: {image.dtype} {'x'.join(map(str, image.shape))} is not 8-bit RGB of the "
            f"depth camera's {intr.width}x{intr.height}")
    return image
