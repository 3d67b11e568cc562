"""Image files as their first bytes say they are, whatever their name: the format and the size from
the header, read before anything is decoded (OpenCV picks its decoder from the bytes, and a 1 kB
JPEG 2000 file named .png decodes to gigabytes).

mirrorcore reads PNG, JPEG, BMP, PGM/PPM and TIFF, and only under a name that says the same format
(or a name that says none)."""
from __future__ import annotations

import re
import struct
from dataclasses import dataclass
from pathlib import PurePath

from mirrorcore.base.budget import check_memory
from mirrorcore.base.errors import FileFormatError
from mirrorcore.geometry.camera import MAX_IMAGE_SIDE

READABLE = ("PNG", "JPEG", "BMP", "PGM/PPM", "TIFF")
SUFFIXES = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG", ".jpe": "JPEG", ".bmp": "BMP",
            ".pgm": "PGM/PPM", ".ppm": "PGM/PPM", ".pnm": "PGM/PPM", ".pbm": "PGM/PPM",
            ".tif": "TIFF", ".tiff": "TIFF", ".jp2": "JPEG 2000", ".j2k": "JPEG 2000",
            ".webp": "WebP", ".exr": "OpenEXR", ".gif": "GIF", ".hdr": "Radiance HDR"}
# (leading bytes, format): the formats OpenCV or a user's files may have
_MAGIC = ((b"\x89PNG\r\n\x1a\n", "PNG"), (b"\xff\xd8\xff", "JPEG"), (b"BM", "BMP"),
          (b"II*\x00", "TIFF"), (b"MM\x00*", "TIFF"), (b"\x00\x00\x00\x0cjP  ", "JPEG 2000"),
          (b"\xff\x4f\xff\x51", "JPEG 2000"), (b"v/1\x01", "OpenEXR"), (b"GIF8", "GIF"),
          (b"#?RADIANCE", "Radiance HDR"), (b"#?RGBE", "Radiance HDR"))
# JPEG start-of-frame markers (baseline, progressive, lossless, arithmetic): the size follows
_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


@dataclass(frozen=True)
class ImageHeader:
    """What an image file's header says.

    Attributes
    ----------
    format : str
        One of READABLE.
    width, height : int
        Pixels.
    decoded_bytes : int
        The most bytes a pixel takes once decoded (channels times bytes a sample).
    """

    format: str
    width: int
    height: int
    decoded_bytes: int


def sniff(head: bytes) -> str:
    """The format the first bytes of a file say ('unknown' when none mirrorcore knows).

    Parameters
    ----------
    head : bytes
        The file's first bytes (12 are enough).

    Returns
    -------
    str
    """
    for magic, name in _MAGIC:
        if head.startswith(magic):
            return name
    if len(head) >= 3 and head[:1] == b"P" and head[1:2] in b"123456" and head[2:3].isspace():
        return "PGM/PPM"
    if head[:4] == b"RIFF" and head[8:12] == b"WEBP":
        return "WebP"
    return "unknown"


def check_format(head: bytes, where: str, name: str | None = None) -> str:
    """The format of a file's first bytes, refusing one that is not the name's or not readable.

    Parameters
    ----------
    head : bytes
        The file's first bytes (16 are enough).
    where : str
        The file, for the messages.
    name : str, optional
        The file's name; its suffix, when it names a format, must be the format of the bytes.

    Returns
    -------
    str
        One of READABLE.

    Raises
    ------
    FileFormatError
        Naming `where`: a format other than the name's, or one mirrorcore does not read.
    """
    found = sniff(head[:16])
    said = SUFFIXES.get(PurePath(name).suffix.lower()) if name else None
    if said is not None and found not in (said, "unknown"):
        raise FileFormatError(f"{where}: named {PurePath(name).suffix} but its bytes are a "
                              f"{found} image; save it as a {said} image")
    if found == "unknown":
        raise FileFormatError(f"{where}: not a readable image (corrupt or not a PNG)")
    if found not in READABLE:
        raise FileFormatError(f"{where}: a {found} image; mirrorscan reads "
                              f"{', '.join(READABLE)}")
    return found


def read_header(data: bytes, where: str, name: str | None = None) -> ImageHeader:
    """Read an image's format (see `check_format`) and size from its bytes.

    Parameters
    ----------
    data : bytes
        The file's content (or at least its header).
    where : str
        The file, for the messages.
    name : str, optional
        The file's name.

    Returns
    -------
    ImageHeader

    Raises
    ------
    FileFormatError
        Naming `where`: as `check_format`, or a header that cannot be read.
    """
    header = _SIZE_READERS[check_format(data, where, name)](data)
    if header is None or min(header.width, header.height) < 1:
        raise FileFormatError(f"{where}: not a readable image (corrupt or not a PNG)")
    return header


def check_image(data: bytes, where: str, name: str | None = None,
                shape: tuple[int, int] | None = None, extra_bytes: int = 0,
                what: str = "an image") -> ImageHeader:
    """`read_header`, then refuse a side above MAX_IMAGE_SIDE, a size other than `shape` and an
    image whose decoding would not fit in the memory budget.

    Parameters
    ----------
    data : bytes
        The file's content.
    where : str
        The file, for the messages.
    name : str, optional
        The file's name (see `read_header`).
    shape : (int, int), optional
        The expected (H, W).
    extra_bytes : int
        Bytes a pixel takes beyond its decoded form (a conversion to metres).
    what : str
        The kind of image, for the message ('a depth image').

    Returns
    -------
    ImageHeader

    Raises
    ------
    FileFormatError
        As `read_header`, or the size is wrong.
    MemoryBudgetError
        Decoding would need more than the budget.
    """
    header = read_header(data, where, name)
    width, height = header.width, header.height
    if max(width, height) > MAX_IMAGE_SIDE:
        raise FileFormatError(f"{where}: size {width}x{height} is too large for {what} "
                              f"(at most {MAX_IMAGE_SIDE} pixels a side)")
    if shape is not None and (height, width) != tuple(shape):
        raise FileFormatError(
            f"{where}: size {width}x{height} does not match the camera's {shape[1]}x{shape[0]}")
    check_memory(width * height * (header.decoded_bytes + extra_bytes),
                 f"{where}: decoding a {width}x{height} image")
    return header


def _png(data: bytes) -> ImageHeader | None:
    if len(data) < 26 or data[12:16] != b"IHDR":
        return None
    width, height = struct.unpack(">II", data[16:24])
    channels = {0: 1, 2: 3, 3: 3, 4: 4, 6: 4}.get(data[25], 4)
    return ImageHeader("PNG", width, height, channels * (2 if data[24] == 16 else 1))


def _jpeg(data: bytes) -> ImageHeader | None:
    i = 2
    while i + 9 < len(data) and data[i] == 0xFF:
        marker = data[i + 1]
        if marker in _SOF:
            height, width = struct.unpack(">HH", data[i + 5:i + 9])
            return ImageHeader("JPEG", width, height, 4 * (2 if data[i + 4] > 8 else 1))
        if marker == 0xDA:      # the scan: no frame header before it
            return None
        i += 2 if marker == 0xFF or 0xD0 <= marker <= 0xD9 else 2 + struct.unpack(
            ">H", data[i + 2:i + 4])[0]
    return None


def _bmp(data: bytes) -> ImageHeader | None:
    if len(data) < 26:
        return None
    if struct.unpack("<I", data[14:18])[0] == 12:     # the OS/2 header: 16-bit sizes
        width, height = struct.unpack("<HH", data[18:22])
    else:
        width, height = struct.unpack("<ii", data[18:26])
    return ImageHeader("BMP", width, abs(height), 4)


def _pnm(data: bytes) -> ImageHeader | None:
    # the magic number, width, height and (but for bitmaps) the largest value, between comments
    tokens = re.sub(rb"#[^\n]*", b" ", data[:1024]).split()[:4]
    kind = tokens[0][1:2]
    if len(tokens) < 3 or not all(t.isdigit() for t in tokens[1:]):
        return None
    width, height = int(tokens[1]), int(tokens[2])
    wide = kind not in b"14" and len(tokens) > 3 and int(tokens[3]) > 255
    return ImageHeader("PGM/PPM", width, height, (3 if kind in b"36" else 1) * (1 + wide))


def _tiff(data: bytes) -> ImageHeader | None:
    order = "<" if data[:2] == b"II" else ">"
    if len(data) < 8:
        return None
    ifd = struct.unpack(order + "I", data[4:8])[0]
    if ifd + 2 > len(data):
        return None
    sizes = {}
    for k in range(struct.unpack(order + "H", data[ifd:ifd + 2])[0]):
        entry = data[ifd + 2 + 12 * k:ifd + 14 + 12 * k]
        if len(entry) < 12:
            return None
        tag, kind = struct.unpack(order + "HH", entry[:4])
        if tag in (256, 257):
            sizes[tag] = struct.unpack(order + ("H" if kind == 3 else "I"),
                                       entry[8:10] if kind == 3 else entry[8:12])[0]
    if len(sizes) < 2:
        return None
    # any samples: up to four channels of 64-bit floats
    return ImageHeader("TIFF", sizes[256], sizes[257], 32)


_SIZE_READERS = {"PNG": _png, "JPEG": _jpeg, "BMP": _bmp, "PGM/PPM": _pnm, "TIFF": _tiff}
