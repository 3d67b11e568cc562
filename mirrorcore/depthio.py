"""Depth images on disk: uint16 PNG in `depth_scale` metres per unit, 0 = no reading (DESIGN.md)."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from .atomic import write_atomic
from .errors import FileFormatError


def read_depth_png(path: str | Path, depth_scale: float, shape: tuple[int, int] | None = None) -> np.ndarray:
    """Read a 16-bit depth PNG as metres.

    depth_scale : metres per unit; shape : expected (H, W), checked when given.
    returns (H, W) float32 metres, 0 = no reading. Raises FileFormatError naming the file and what is wrong.
    """
    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"{path}: no such depth image")
    raw = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if raw is None:
        raise FileFormatError(f"{path}: not a readable image (corrupt or not a PNG)")
    if raw.ndim != 2:
        raise FileFormatError(f"{path}: a depth image has one channel, this one has {raw.shape[2]}")
    if raw.dtype != np.uint16:
        raise FileFormatError(f"{path}: a depth image is 16-bit, this one is {raw.dtype} "
                              "(8-bit images cannot hold depth)")
    if shape is not None and raw.shape != tuple(shape):
        raise FileFormatError(f"{path}: size {raw.shape[1]}x{raw.shape[0]} does not match the camera's "
                              f"{shape[1]}x{shape[0]}")
    return raw.astype(np.float32) * np.float32(depth_scale)


def encode_depth_png(depth: np.ndarray, depth_scale: float) -> bytes:
    """depth : (H, W) float metres (0 or non-finite = no reading) -> PNG bytes of uint16 units.

    Depths beyond the uint16 range (65535 * depth_scale) become 0: a reading that cannot be stored is no reading.
    """
    depth = np.asarray(depth, dtype=np.float64)
    units = np.where(np.isfinite(depth), np.round(depth / depth_scale), 0)
    units[(units < 0) | (units > 65535)] = 0
    ok, buf = cv2.imencode(".png", units.astype(np.uint16))
    if not ok:
        raise FileFormatError("depth image: PNG encoding failed")
    return buf.tobytes()


def write_depth_png(path: str | Path, depth: np.ndarray, depth_scale: float) -> None:
    """Write metres as a uint16 PNG atomically (see encode_depth_png)."""
    write_atomic(path, encode_depth_png(depth, depth_scale))
