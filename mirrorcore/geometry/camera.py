"""Pinhole depth camera: intrinsics, presets, reprojection (paper eq. 1) and projection (the
files are in camerafiles).

Conventions (docs/DESIGN.md): metres, OpenCV axes (x right, y down, z forward), origin at the depth
camera's centre, pixel (u, v) = (column, row) with integer coordinates at pixel centres.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from functools import cached_property

import numpy as np

from mirrorcore.base.errors import FileFormatError

_FIELDS = ("width", "height", "fx", "fy", "cx", "cy", "depth_scale")
# pixels: no depth camera comes near; a larger size in a file is damage, not a camera
MAX_IMAGE_SIDE = 16384


@dataclass(frozen=True)
class Intrinsics:
    """A depth camera's pinhole model.

    Attributes
    ----------
    width, height : int
        Image size, pixels (1 to MAX_IMAGE_SIDE).
    fx, fy : float
        Focal lengths, pixels.
    cx, cy : float
        Principal point, pixels (pixel centres are integers).
    depth_scale : float
        Metres per unit of the uint16 depth images on disk.

    Raises
    ------
    FileFormatError
        A size outside 1..MAX_IMAGE_SIDE, or fx, fy or depth_scale not finite and positive.
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    depth_scale: float = 0.001

    def __post_init__(self) -> None:
        size = np.array([self.width, self.height], dtype=float)
        if not (np.all(np.isfinite(size)) and np.all(size >= 1) and np.all(size <= MAX_IMAGE_SIDE)):
            raise FileFormatError(f"camera: width and height must be 1 to {MAX_IMAGE_SIDE} pixels, "
                                  f"got {size[0]:g}x{size[1]:g}")
        values = np.array([self.fx, self.fy, self.cx, self.cy, self.depth_scale], dtype=float)
        if not np.all(np.isfinite(values)) or self.fx <= 0 or self.fy <= 0 or self.depth_scale <= 0:
            raise FileFormatError(
                f"camera: fx, fy and depth_scale must be finite and positive, got fx={self.fx} "
                f"fy={self.fy} "
                f"depth_scale={self.depth_scale}")
        object.__setattr__(self, "width", int(self.width))
        object.__setattr__(self, "height", int(self.height))

    # ----------------------------------------------------------------- constructors and presets
    @classmethod
    def from_dict(cls, data: dict, where: str = "camera") -> "Intrinsics":
        """Build intrinsics from a mapping with the keys of a session's `camera` object.

        The keys are those of docs/DESIGN.md.

        Parameters
        ----------
        data : dict
            width, height, fx, fy, cx, cy and optionally depth_scale.
        where : str
            What the mapping is, for the messages.

        Returns
        -------
        Intrinsics

        Raises
        ------
        FileFormatError
            Naming `where`: not a mapping, a key missing, a value not a number, a size not an
            integer, or values the camera refuses.
        """
        if not isinstance(data, dict):
            raise FileFormatError(f"{where}: expected an object with {', '.join(_FIELDS)}")
        missing = [k for k in _FIELDS[:6] if k not in data]
        if missing:
            raise FileFormatError(f"{where}: missing key(s) {', '.join(missing)}")
        try:
            values = {k: float(data[k]) for k in _FIELDS if k in data}
        except (TypeError, ValueError, OverflowError) as exc:
            raise FileFormatError(f"{where}: camera values must be numbers ({exc})") from None
        if not (values["width"].is_integer() and values["height"].is_integer()):
            raise FileFormatError(
                f"{where}: width and height must be integers, got {data['width']}x{data['height']}")
        try:
            return cls(**values)
        except FileFormatError as exc:
            raise FileFormatError(f"{where}: {str(exc).removeprefix('camera: ')}") from None

    def to_dict(self) -> dict:
        """The fields as a dict (the session's `camera` object)."""
        return asdict(self)

    @classmethod
    def kinect_v1(cls) -> "Intrinsics":
        """Kinect v1 depth (IR) camera, Nicolas Burrus' calibration, 640x480."""
        return cls(640, 480, 594.21434211923247, 591.04053696870778, 339.30780975300314,
                   242.73913761751615)

    @classmethod
    def primesense(cls) -> "Intrinsics":
        """OpenNI / PrimeSense default depth intrinsics (Open3D's PrimeSenseDefault), 640x480."""
        return cls(640, 480, 525.0, 525.0, 319.5, 239.5)

    def scaled(self, factor: float) -> "Intrinsics":
        """Return the same camera at `factor` times the resolution.

        Parameters
        ----------
        factor : float
            The scale of the image size; pixel centres stay at integer coordinates.

        Returns
        -------
        Intrinsics
        """
        w, h = round(self.width * factor), round(self.height * factor)
        return replace(self, width=w, height=h, fx=self.fx * factor, fy=self.fy * factor,
                       cx=(self.cx + 0.5) * factor - 0.5, cy=(self.cy + 0.5) * factor - 0.5)

    # ----------------------------------------------------------------- matrices and ray tables
    @property
    def shape(self) -> tuple[int, int]:
        """(height, width) of the images."""
        return self.height, self.width

    @property
    def K(self) -> np.ndarray:
        """(3, 3) float64 camera matrix."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @cached_property
    def rays(self) -> np.ndarray:
        """(2, H, W) float32 read-only table of (x/z, y/z) for every pixel.

        A pixel at depth z reprojects to (rays[0] * z, rays[1] * z, z). Two planes rather than
        (H, W, 3) so that gathers and products stay contiguous.
        """
        table = np.empty((2, self.height, self.width), dtype=np.float32)
        table[0] = ((np.arange(self.width) - self.cx) / self.fx)[None, :]
        table[1] = ((np.arange(self.height) - self.cy) / self.fy)[:, None]
        table.flags.writeable = False
        return table

    @cached_property
    def axis_rays(self) -> tuple[np.ndarray, np.ndarray]:
        """The x/z of each column, (W,), and the y/z of each row, (H,), float32 read-only.

        The same values as `rays`, in two tables small enough to stay in cache.
        """
        x, y = np.array(self.rays[0, 0]), np.array(self.rays[1, :, 0])
        x.flags.writeable = y.flags.writeable = False
        return x, y


def reproject_pixels(intr: Intrinsics, u: np.ndarray, v: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Reproject pixels with depth to points in the camera frame (paper eq. 1).

    Parameters
    ----------
    intr : Intrinsics
        The camera.
    u, v : (n,) array
        Pixel coordinates (any real values).
    z : (n,) array
        Depth, metres.

    Returns
    -------
    (n, 3) float32 array
        Points, metres, camera frame.
    """
    z = np.asarray(z, dtype=np.float32)
    x = (np.asarray(u, dtype=np.float32) - np.float32(intr.cx)) * (z / np.float32(intr.fx))
    y = (np.asarray(v, dtype=np.float32) - np.float32(intr.cy)) * (z / np.float32(intr.fy))
    return np.stack([x, y, z], axis=-1)


def reproject_depth(intr: Intrinsics, depth: np.ndarray, mask: np.ndarray | None = None):
    """Reproject the valid pixels of a depth image (paper eq. 1, through the cached ray table).

    Parameters
    ----------
    intr : Intrinsics
        The camera.
    depth : (H, W) float array
        Depth, metres; 0 = no reading.
    mask : (H, W) bool array, optional
        The pixels to keep.

    Returns
    -------
    points_cam : (n, 3) float32 array
        Metres, camera frame, in row-major pixel order.
    pixels : (n, 2) int32 array
        (u, v) of each point.

    Raises
    ------
    FileFormatError
        The depth image's size does not match the intrinsics.
    """
    depth = check_depth_shape(intr, depth)
    keep = depth > 0
    if mask is not None:
        keep &= mask
    v, u = np.nonzero(keep)
    z = depth[v, u].astype(np.float32)
    points = np.stack([intr.rays[0, v, u] * z, intr.rays[1, v, u] * z, z], axis=-1)
    return points, np.stack([u, v], axis=-1).astype(np.int32)


def pixels_on_plane(intr: Intrinsics, uv: np.ndarray, plane) -> np.ndarray:
    """Find where the rays of pixels meet a plane.

    Parameters
    ----------
    intr : Intrinsics
        The camera.
    uv : (n, 2) array
        Pixel coordinates.
    plane : mirrorcore.geometry.plane.Plane
        The plane.

    Returns
    -------
    (n, 3) float64 array
        Metres, camera frame; NaN where the ray is parallel to the plane or meets it behind the
        camera.
    """
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    rays = np.stack([(uv[:, 0] - intr.cx) / intr.fx, (uv[:, 1] - intr.cy) / intr.fy,
                     np.ones(len(uv))], axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -plane.d / (rays @ plane.n)
    t[~(t > 0)] = np.nan
    return rays * t[:, None]


def project_points(intr: Intrinsics, points_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Project camera-frame points to pixel coordinates (inverse of eq. 1).

    Parameters
    ----------
    intr : Intrinsics
        The camera.
    points_cam : (n, 3) float array
        Metres, camera frame; only points with z > 0 project.

    Returns
    -------
    uv : (n, 2) float64 array
        Pixel coordinates, NaN where z <= 0.
    z : (n,) float64 array
        Depth, metres.
    """
    p = np.asarray(points_cam, dtype=np.float64).reshape(-1, 3)
    z = p[:, 2]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        uv = np.stack([intr.fx * p[:, 0] / z + intr.cx, intr.fy * p[:, 1] / z + intr.cy], axis=-1)
    uv[z <= 0] = np.nan
    return uv, z


def check_depth_shape(intr: Intrinsics, depth: np.ndarray,
                      where: str = "depth image") -> np.ndarray:
    """Check that a depth image has the size of the intrinsics.

    Parameters
    ----------
    intr : Intrinsics
        The camera.
    depth : array_like
        The depth image.
    where : str
        What the image is, for the message.

    Returns
    -------
    (H, W) array
        `depth` as an array.

    Raises
    ------
    FileFormatError
        Its size does not match the intrinsics.
    """
    depth = np.asarray(depth)
    if depth.shape != intr.shape:
        raise FileFormatError(
            f"{where}: size "
            f"{depth.shape[1] if depth.ndim > 1 else '?'}x{depth.shape[0] if depth.ndim else '?'} "
            f"does not match the camera's {intr.width}x{intr.height}")
    return depth

