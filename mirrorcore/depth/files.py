"""Depth images on disk: uint16 PNG in `depth_scale` metres per unit, 0 = no reading
(docs/DESIGN.md); and the colour images beside them (8-bit RGB on the depth pixel grid)."""
from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from mirrorcore.base.atomic import write_atomic
from mirrorcore.base.budget import check_memory
from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.depth.imageheader import check_format, check_image
from mirrorcore.geometry.camera import Intrinsics

METRE_BYTES = 4           # a pixel's float32 metres, beside the image as decoded
HEAD_BYTES = 64           # enough for a PNG's size
# bytes a depth file may hold beyond twice its raw pixels (headers, text chunks)
FILE_SLACK = 1 << 20
COLOUR_SAMPLES = 4   # 16-bit samples a pixel of the largest colour file (RGBA)


def read_depth_png(path: str | Path, depth_scale: float,
                   shape: tuple[int, int] | None = None) -> np.ndarray:
    """Read a 16-bit depth PNG as metres (see `decode_depth_png`).

    Parameters
    ----------
    path : str or Path
        The file.
    depth_scale : float
        Metres per unit.
    shape : (int, int), optional
        Expected (H, W), checked when given.

    Returns
    -------
    (H, W) float32 array
        Metres, 0 = no reading.

    Raises
    ------
    FileFormatError
        Naming the file: missing, larger than an image of its size can be (checked before reading
        it: see `max_file_bytes`), or not a depth image of the expected size.
    """
    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"{path}: no such depth image")
    where = str(path)
    with open(path, "rb") as f:
        head = f.read(HEAD_BYTES)
        size = os.fstat(f.fileno()).st_size
        pixels = shape[0] * shape[1] if shape is not None else None
        if check_format(head, where, where) == "PNG":
            header = check_image(head, where, where, shape, METRE_BYTES, "a depth image")
            pixels = header.width * header.height
        limit = max_file_bytes(pixels) if pixels is not None else None
        if limit is not None and size > limit:
            raise FileFormatError(
                f"{path}: {size:,} bytes is more than a depth image of {pixels:,} pixels can "
                f"hold (at most {limit:,}); the file is damaged or not a depth image")
        check_memory(size, f"{path}: reading the file")
        f.seek(0)
        data = f.read()
    return decode_depth_png(data, depth_scale, shape, str(path))


def max_file_bytes(pixels: int) -> int:
    """Return the largest file a 16-bit depth image of `pixels` pixels may be.

    That is twice its raw size (PNG's worst case, stored without compression, is the raw size plus
    a byte a row and a few bytes a block), plus FILE_SLACK.

    Parameters
    ----------
    pixels : int
        H * W.

    Returns
    -------
    int
        Bytes.
    """
    return 4 * pixels + FILE_SLACK


def decode_depth_png(data: bytes, depth_scale: float, shape: tuple[int, int] | None = None,
                     where: str = "depth image") -> np.ndarray:
    """Decode a 16-bit depth image (PNG, or another of `imageheader.READABLE`) from its bytes.

    The format is read from the bytes and must be the one `where`'s suffix names (when it names
    one); the size is read from the header and checked before decoding.

    Parameters
    ----------
    data : bytes
        The file's content.
    depth_scale : float
        Metres per unit.
    shape : (int, int), optional
        Expected (H, W), checked when given, from the header before decoding (a small file can
        hold an image of gigabytes).
    where : str
        The file (its name, or a path), for the messages.

    Returns
    -------
    (H, W) float32 array
        Metres, 0 = no reading.

    Raises
    ------
    FileFormatError
        Naming `where` and what is wrong.
    MemoryBudgetError
        Decoding would need more than the memory budget.
    """
    check_image(data, where, where, shape, METRE_BYTES, "a depth image")
    raw = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if raw is None:
        raise FileFormatError(f"{where}: not a readable image (corrupt or not a PNG)")
    if raw.ndim != 2:
        raise FileFormatError(
            f"{where}: a depth image has one channel, this one has {raw.shape[2]}")
    if raw.dtype != np.uint16:
        raise FileFormatError(f"{where}: a depth image is 16-bit, this one is {raw.dtype} "
                              "(8-bit images cannot hold depth)")
    if shape is not None and raw.shape != tuple(shape):
        raise FileFormatError(
            f"{where}: size {raw.shape[1]}x{raw.shape[0]} does not match the camera's "
                              f"{shape[1]}x{shape[0]}")
    return raw.astype(np.float32) * np.float32(depth_scale)


def require_readings(depth: np.ndarray, where: str) -> np.ndarray:
    """Check that a depth image has a reading.

    A covered or unplugged camera, or a blank file, has nothing to calibrate or scan.

    Parameters
    ----------
    depth : (..., H, W) array
        Metres.
    where : str
        What the image is, for the message.

    Returns
    -------
    (..., H, W) array
        `depth`, unchanged.

    Raises
    ------
    MirrorscanError
        Naming `where`, when every pixel is 0 (or not finite).
    """
    if not np.any(np.isfinite(depth) & (depth > 0)):
        raise MirrorscanError(
            f"{where}: no depth reading at all (every pixel is 0); is the camera covered or "
                              "the file blank?")
    return depth


def encode_depth_png(depth: np.ndarray, depth_scale: float) -> bytes:
    """Encode a depth image as PNG bytes of uint16 units.

    Depths beyond the uint16 range (65535 * depth_scale) become 0: a reading that cannot be stored
    is no reading.

    Parameters
    ----------
    depth : (H, W) float array
        Metres; 0 or non-finite = no reading.
    depth_scale : float
        Metres per unit.

    Returns
    -------
    bytes
        The PNG.
    """
    depth = np.asarray(depth, dtype=np.float64)
    units = np.where(np.isfinite(depth), np.round(depth / depth_scale), 0)
    units[(units < 0) | (units > 65535)] = 0
    ok, buf = cv2.imencode(".png", units.astype(np.uint16))
    if not ok:
        raise FileFormatError("depth image: PNG encoding failed")
    return buf.tobytes()


def write_depth_png(path: str | Path, depth: np.ndarray, depth_scale: float) -> None:
    """Write a depth image as a uint16 PNG atomically (see `encode_depth_png`).

    Parameters
    ----------
    path : str or Path
        The file written.
    depth : (H, W) float array
        Metres; 0 or non-finite = no reading.
    depth_scale : float
        Metres per unit.
    """
    write_atomic(path, encode_depth_png(depth, depth_scale))


def read_colour(path: Path | None, intr: Intrinsics) -> np.ndarray | None:
    """Read a colour image of the camera's size.

    Parameters
    ----------
    path : Path or None
    intr : Intrinsics

    Returns
    -------
    (H, W, 3) uint8 array or None
        RGB; None for no path.

    Raises
    ------
    FileFormatError
        Naming the file: missing, larger than a 16-bit RGBA image of the camera's size can be, of
        a format other than its name's (see `imageheader.check_image`), or not the camera's size.
    MemoryBudgetError
        Decoding it would need more than the memory budget.
    """
    if path is None:
        return None
    if not Path(path).is_file():
        raise FileFormatError(f"{path}: no such colour image")
    with open(path, "rb") as f:
        size = os.fstat(f.fileno()).st_size
        limit = max_file_bytes(intr.width * intr.height * COLOUR_SAMPLES)
        if size > limit:
            raise FileFormatError(f"{path}: {size:,} bytes is more than a colour image of the "
                                  f"camera's size can hold (at most {limit:,})")
        data = f.read()
    check_image(data, str(path), str(path), intr.shape, 0, "a colour image")
    bgr = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    if bgr is None:
        raise FileFormatError(f"{path}: not a readable colour image")
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def write_colour_png(path: Path, colour) -> None:
    """Write an 8-bit colour PNG atomically.

    Parameters
    ----------
    path : Path
    colour : (H, W, 3) uint8 array
        RGB.
    """
    ok, buf = cv2.imencode(".png", cv2.cvtColor(colour, cv2.COLOR_RGB2BGR))
    if not ok:
        raise FileFormatError(f"{path}: PNG encoding failed")
    write_atomic(path, buf.tobytes())
