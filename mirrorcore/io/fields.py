"""The typed fields of session.json: lists, pixels, polygons, relative paths and timestamps, each
read with a FileFormatError that names the file and the key."""
from __future__ import annotations

import re
from pathlib import Path, PurePosixPath

from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.base.jsonfile import finite_number
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.polygon import MAX_VERTICES, validate_polygon

Pixels = tuple[tuple[float, float], ...]
_SURROGATE = re.compile("[\ud800-\udfff]")


def read_list(value, where: str, limit: int | None = None, what: str = "items") -> list:
    """Read a list of at most `limit` items.

    Parameters
    ----------
    value : object
        The parsed JSON value.
    where : str
        The key, for the messages.
    limit : int, optional
        The most items.
    what : str
        What the items are, for the message.

    Returns
    -------
    list
        `value`.

    Raises
    ------
    FileFormatError
        Naming `where` and, beyond the limit, how many `what` it holds.
    """
    if not isinstance(value, list):
        raise FileFormatError(f"{where}: must be a list")
    if limit is not None and len(value) > limit:
        raise FileFormatError(f"{where}: {len(value):,} {what}, more than the {limit:,} a session "
                              "may hold")
    return value


def read_pixels(value, camera: Intrinsics, where: str, limit: int = MAX_VERTICES) -> Pixels:
    """Read a list of at most `limit` [u, v] inside the image.

    Parameters
    ----------
    value : object
        The parsed JSON value.
    camera : Intrinsics
        The image the pixels lie in.
    where : str
        The key, for the messages.
    limit : int
        The most pixels.

    Returns
    -------
    tuple of (float, float)
        (u, v) pixels.

    Raises
    ------
    FileFormatError
        Naming `where` and the item.
    """
    out = []
    for i, p in enumerate(read_list(value, where, limit, "points")):
        pair = isinstance(p, (list, tuple)) and len(p) == 2
        uv = [finite_number(c) for c in p] if pair else [None]
        if None in uv:
            raise FileFormatError(f"{where}[{i}]: must be a pair of numbers [u, v], got "
                                  f"{repr(p)[:80]}")
        u, v = uv
        if not (-0.5 <= u <= camera.width - 0.5 and -0.5 <= v <= camera.height - 0.5):
            raise FileFormatError(f"{where}[{i}]: pixel ({u:g}, {v:g}) is outside the "
                                  f"{camera.width}x{camera.height} image")
        out.append((u, v))
    return tuple(out)


def read_polygon(value, camera: Intrinsics, where: str) -> Pixels:
    """Read a polygon of pixels (empty allowed), checked by `validate_polygon` when it has vertices.

    Parameters
    ----------
    value : object
        The parsed JSON value.
    camera : Intrinsics
        The image the polygon lies in.
    where : str
        The key, for the messages.

    Returns
    -------
    tuple of (float, float)
        (u, v) pixels.

    Raises
    ------
    FileFormatError
        Naming `where`.
    """
    pixels = read_pixels(value, camera, where)
    if pixels:
        try:
            validate_polygon(pixels, camera.shape, where)
        except MirrorscanError as exc:
            raise FileFormatError(str(exc)) from None
    return pixels


def read_paths(value, folder: Path, where: str, limit: int) -> tuple[str, ...]:
    """Read a list of at most `limit` paths, each read by `read_relative_path`.

    Parameters
    ----------
    value : object
        The parsed JSON value.
    folder : Path
        The session folder.
    where : str
        The key, for the messages.
    limit : int
        The most paths.

    Returns
    -------
    tuple of str

    Raises
    ------
    FileFormatError
        Naming `where`.
    """
    items = read_list(value, where, limit, "paths")
    return tuple(read_relative_path(p, folder, f"{where}[{i}]") for i, p in enumerate(items))


def read_relative_path(value, folder: Path, where: str) -> str:
    """Read a path relative to the session folder that stays inside it.

    Parameters
    ----------
    value : object
        The parsed JSON value.
    folder : Path
        The session folder.
    where : str
        The key, for the messages.

    Returns
    -------
    str
        The path in POSIX form.

    Raises
    ------
    FileFormatError
        Naming `where`: not a relative path, or a path that leaves the folder.
    """
    if not isinstance(value, str) or not value or not encodable(value) or "\0" in value:
        raise FileFormatError(f"{where}: must be a path relative to the session folder")
    rel = PurePosixPath(value.replace("\\", "/"))
    if rel.is_absolute() or ".." in rel.parts or (len(value) > 1 and value[1] == ":"):
        raise FileFormatError(f"{where}: path {value!r} leaves the session folder")
    return str(rel)


def read_timestamps(value, n_frames: int, where: str) -> tuple[float, ...]:
    """Read one number of seconds per frame.

    Parameters
    ----------
    value : object
        The parsed JSON value.
    n_frames : int
        The number of frames.
    where : str
        The key, for the messages.

    Returns
    -------
    tuple of float
        n_frames seconds.

    Raises
    ------
    FileFormatError
        Naming `where` (and the item).
    """
    stamps = read_list(value, where)
    if len(stamps) != n_frames:
        raise FileFormatError(f"{where}: {len(stamps)} timestamps for {n_frames} frames")
    out = tuple(finite_number(t) for t in stamps)
    if None in out:
        i = out.index(None)
        raise FileFormatError(f"{where}[{i}]: must be a number of seconds, got "
                              f"{repr(stamps[i])[:80]}")
    return out


def encodable(text: str) -> bool:
    """Tell whether `text` can be written as UTF-8.

    A JSON string may hold lone surrogates, which cannot.

    Parameters
    ----------
    text : str

    Returns
    -------
    bool
    """
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def shown(text: str) -> str:
    """`text` with each lone surrogate replaced by U+FFFD, so that it can be written as UTF-8.

    A file name that is not UTF-8 reaches Python with such surrogates (os.fsdecode); a browser, a
    JSON file or a log cannot be sent them.

    Parameters
    ----------
    text : str

    Returns
    -------
    str
    """
    return _SURROGATE.sub("\ufffd", text)
