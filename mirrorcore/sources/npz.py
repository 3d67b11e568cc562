"""Depth frames from a .npz stack (a depth array in sensor units, with its camera and optional
colour), held in memory and seekable: read(i) for any i (modulo frame_count: playing loops)."""
from __future__ import annotations

import zipfile
import zlib
from pathlib import Path

import numpy as np

from mirrorcore.base.budget import check_memory
from mirrorcore.base.errors import FileFormatError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.io.fields import shown
from mirrorcore.sources.base import DepthSource, Frame, checked_depth

# the dtypes of a .npz's numbers (np.number also takes complex ones)
REAL = (np.integer, np.floating)
_NPY_HEADERS = {(1, 0): np.lib.format.read_array_header_1_0,
                (2, 0): np.lib.format.read_array_header_2_0}


class StackSource(DepthSource):
    """Frames held in memory as a stack of sensor units.

    Integer units are also given as Frame.units (uint16). NaN, inf and values <= 0 read as no
    reading.

    Parameters
    ----------
    name : str
    intrinsics : Intrinsics
    units : (N, H, W) integer or float array
        Metres = units * scale.
    scale : float
        Metres per unit.
    timestamps : (N,) float array
        Seconds.
    colour : (N, H, W, 3) uint8 array, optional
        RGB.
    fps : float
    """

    def __init__(self, name: str, intrinsics: Intrinsics, units: np.ndarray, scale: float,
                 timestamps: np.ndarray,
                 colour: np.ndarray | None = None, fps: float = 30.0):
        self.name, self.intrinsics = name, intrinsics
        self.fps, self.frame_count = float(fps), len(units)
        self.units, self.scale = units, np.float32(scale)
        self.timestamps, self.colour = np.asarray(timestamps, float), colour

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
        i = self._wrap(i)
        units = self.units[i]
        with np.errstate(invalid="ignore", over="ignore"):
            depth = checked_depth(units.astype(np.float32) * self.scale, self.intrinsics, self.name)
        sensor_units = units.astype(np.uint16) if np.issubdtype(units.dtype, np.integer) else None
        return Frame(depth, float(self.timestamps[i]),
                     None if self.colour is None else self.colour[i], sensor_units)

    @property
    def has_colour(self) -> bool:
        """True when the stack has a colour array."""
        return self.colour is not None


def open_npz(path: str | Path, fps: float = 30.0) -> StackSource:
    """Play a .npz stack, loaded without pickles.

    Parameters
    ----------
    path : str or Path
        Holds `depth` (N, H, W) or (H, W) in units of `depth_scale` metres (integer stacks need
        depth_scale; float stacks are metres unless it is given), `K` (3, 3) camera matrix, optional
        `timestamps` (N,) seconds (default i / fps) and `colour` (N, H, W, 3) uint8 RGB.
    fps : float

    Returns
    -------
    StackSource

    Raises
    ------
    FileFormatError
    """
    path = Path(path)
    arrays = load_npz(path)
    for key in ("depth", "K"):
        if key not in arrays:
            raise FileFormatError(f"{path}: missing array '{key}' (has "
                                  f"{', '.join(sorted(arrays)) or 'none'})")
    depth = arrays["depth"][None] if arrays["depth"].ndim == 2 else arrays["depth"]
    integer = np.issubdtype(depth.dtype, np.integer)
    if depth.ndim != 3 or not (integer
                               or np.issubdtype(depth.dtype, np.floating)) or not depth.size:
        raise FileFormatError(f"{path}: 'depth' must be a non-empty (N, H, W) numeric stack, got "
                              f"{depth.dtype} "
                              f"{depth.shape}")
    if integer and "depth_scale" not in arrays:
        raise FileFormatError(f"{path}: an integer depth stack needs 'depth_scale' (metres per "
                              "unit)")
    scale = float(_optional(path, arrays, "depth_scale", (), REAL, 1.0))
    if not (np.isfinite(scale) and scale > 0):
        raise FileFormatError(f"{path}: 'depth_scale' must be positive, got {scale:g}")
    K = _optional(path, arrays, "K", (3, 3), REAL, None).astype(float)
    try:
        camera = Intrinsics(depth.shape[2], depth.shape[1], K[0, 0], K[1, 1], K[0, 2], K[1, 2],
                            scale if integer else 0.001)
    except FileFormatError as exc:
        raise FileFormatError(f"{path}: {exc}") from None
    stamps = _optional(path, arrays, "timestamps", (len(depth),), REAL,
                       np.arange(len(depth)) / fps)
    colour = _optional(path, arrays, "colour", (*depth.shape, 3), (np.uint8,), None)
    return StackSource(f"npz {shown(path.name)}", camera, depth, scale, stamps, colour, fps)


def _optional(path: Path, arrays: dict, key: str, shape: tuple, kinds: tuple[type, ...], default):
    """arrays[key] checked for shape and dtype, one of `kinds` (REAL, (np.uint8,)...), or `default`
    when absent."""
    if key not in arrays:
        return default
    value = arrays[key]
    if value.shape != shape or not any(np.issubdtype(value.dtype, kind) for kind in kinds):
        raise FileFormatError(f"{path}: '{key}' must be {' or '.join(k.__name__ for k in kinds)} "
                              f"of shape {shape}, "
                              f"got {value.dtype} {value.shape}")
    return value


def load_npz(path: Path) -> dict[str, np.ndarray]:
    """Read every array of a .npz file with allow_pickle=False.

    Parameters
    ----------
    path : Path

    Returns
    -------
    dict of str to array

    Raises
    ------
    FileFormatError
        Missing, corrupt or pickled.
    MemoryBudgetError
        The arrays' declared shapes (read from their .npy headers first) would not fit in the memory
        budget.
    """
    if not path.is_file():
        raise FileFormatError(f"{path}: no such .npz file")
    if not zipfile.is_zipfile(path):
        raise FileFormatError(f"{path}: not a .npz archive (not a zip file)")
    try:   # our own file handle: numpy leaves its own open when the archive is broken
        with open(path, "rb") as f:
            check_memory(sum(npz_declared_bytes(f).values()), f"{path}: its arrays")
            f.seek(0)
            with np.load(f, allow_pickle=False) as data:
                return {key: data[key] for key in data.files}
    except ValueError as exc:
        if "allow_pickle" in str(exc):
            raise FileFormatError(f"{path}: holds pickled (object) arrays, which mirrorscan never "
                                  "loads") from None
        raise FileFormatError(f"{path}: not a readable .npz file ({exc})") from None
    except (OSError, zipfile.BadZipFile, EOFError, NotImplementedError, zlib.error) as exc:
        raise FileFormatError(f"{path}: not a readable .npz file ({type(exc).__name__}: "
                              f"{exc})") from None


def npz_declared_bytes(file) -> dict[str, int]:
    """Read the bytes each .npy member of an open .npz file declares, without loading any array.

    Shape x item size, from each member's header.

    Parameters
    ----------
    file : zipfile.ZipFile
        The open .npz.

    Returns
    -------
    dict of str to int
        {member name: bytes}.

    Raises
    ------
    ValueError
        A member that is not an .npy array.
    """
    sizes = {}
    with zipfile.ZipFile(file) as archive:
        for info in archive.infolist():
            if not info.filename.endswith(".npy"):
                continue
            with archive.open(info) as member:
                version = np.lib.format.read_magic(member)
                if version not in _NPY_HEADERS:
                    raise ValueError(f"{info.filename}: .npy format version {version} is not read "
                                     "here")
                shape, _, dtype = _NPY_HEADERS[version](member, max_header_size=10_000)
            sizes[info.filename] = int(np.prod(shape, dtype=object)) * max(dtype.itemsize, 1)
    return sizes
