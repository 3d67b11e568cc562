"""Depth images on disk: uint16 PNG in `depth_scale` metres per unit, 0 = no reading (docs/DESIGN.md)."""
from __future__ import annotations

import struct
from pathlib import Path

import cv2
import numpy as np

from .atomic import write_atomic
from .errors import FileFormatError, MirrorscanError
from .geometry.camera import MAX_IMAGE_SIDE

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def read_depth_png(path: str | Path, depth_scale: float, shape: tuple[int, int] | None = None) -> np.ndarray:
    """Read a 16-bit depth PNG as metres (see decode_depth_png); FileFormatError naming the file when it is missing."""
    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"{path}: no such depth image")
    return decode_depth_png(path.read_bytes(), depth_scale, shape, str(path))


def decode_depth_png(data: bytes, depth_scale: float, shape: tuple[int, int] | None = None,
                     where: str = "depth image") -> np.ndarray:
    """Decode a 16-bit depth image (PNG, or another format OpenCV reads) from its bytes.

    depth_scale : metres per unit; shape : expected (H, W), checked when given (for a PNG, from its header before
    decoding: a small file can hold an image of gigabytes). returns (H, W) float32 metres, 0 = no reading.
    Raises FileFormatError naming `where` (the file) and what is wrong.
    """
    _check_png_size(data[:24], shape, where)
    raw = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED) if data else None
    if raw is None:
        raise FileFormatError(f"{where}: not a readable image (corrupt or not a PNG)")
    if raw.ndim != 2:
        raise FileFormatError(f"{where}: a depth image has one channel, this one has {raw.shape[2]}")
    if raw.dtype != np.uint16:
        raise FileFormatError(f"{where}: a depth image is 16-bit, this one is {raw.dtype} "
                              "(8-bit images cannot hold depth)")
    if shape is not None and raw.shape != tuple(shape):
        raise FileFormatError(f"{where}: size {raw.shape[1]}x{raw.shape[0]} does not match the camera's "
                              f"{shape[1]}x{shape[0]}")
    return raw.astype(np.float32) * np.float32(depth_scale)


def _check_png_size(head: bytes, shape: tuple[int, int] | None, where: str) -> None:
    """From a PNG's first 24 bytes: refuse a size other than `shape` (H, W) or a side above MAX_IMAGE_SIDE. Other
    formats pass (they are checked after decoding)."""
    if len(head) < 24 or head[:8] != _PNG_SIGNATURE or head[12:16] != b"IHDR":
        return
    width, height = struct.unpack(">II", head[16:24])
    if max(width, height) > MAX_IMAGE_SIDE:
        raise FileFormatError(f"{where}: size {width}x{height} is too large for a depth image "
                              f"(at most {MAX_IMAGE_SIDE} pixels a side)")
    if shape is not None and (height, width) != tuple(shape):
        raise FileFormatError(f"{where}: size {width}x{height} does not match the camera's {shape[1]}x{shape[0]}")


def require_readings(depth: np.ndarray, where: str) -> np.ndarray:
    """Return `depth` ((..., H, W) metres) when any pixel has a reading; MirrorscanError naming `where` when every
    pixel is 0 (or not finite): a covered or unplugged camera, or a blank file, has nothing to calibrate or scan."""
    if not np.any(np.isfinite(depth) & (depth > 0)):
        raise MirrorscanError(f"{where}: no depth reading at all (every pixel is 0); is the camera covered or "
                              "the file blank?")
    return depth


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
