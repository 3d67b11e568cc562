"""The rig: the depth camera's intrinsics and the mirrors (plane + image boundary), with boundary masks rasterised once."""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .errors import MirrorscanError
from .geometry.camera import Intrinsics
from .geometry.plane import Plane
from .geometry.polygon import polygon_mask, validate_polygon
from .session import Session

MAX_MIRRORS = 32  # one bit per mirror in Rig.inside_bits


@dataclass(frozen=True)
class Mirror:
    """One mirror: its name, its plane (None until calibrated) and its boundary polygon (m, 2) pixels (u, v), or None."""

    name: str
    plane: Plane | None
    boundary: np.ndarray | None

    def __hash__(self) -> int:
        return hash((self.name, self.plane, None if self.boundary is None else self.boundary.tobytes()))

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Mirror) and self.name == other.name and self.plane == other.plane
                and np.array_equal(self.boundary, other.boundary))


@dataclass(frozen=True, eq=False)
class Rig:
    """The camera and its mirrors, in session order (mirror j of the sources is mirrors[j - 1])."""

    intrinsics: Intrinsics
    mirrors: tuple[Mirror, ...]

    def __post_init__(self) -> None:
        if len(self.mirrors) > MAX_MIRRORS:
            raise MirrorscanError(f"rig: at most {MAX_MIRRORS} mirrors, got {len(self.mirrors)}")

    @classmethod
    def from_session(cls, session: Session) -> "Rig":
        mirrors = tuple(
            Mirror(m.name, m.plane,
                   validate_polygon(m.boundary, session.camera.shape, f"{m.name}: boundary") if m.boundary else None)
            for m in session.mirrors)
        return cls(session.camera, mirrors)

    @cached_property
    def inside_bits(self) -> np.ndarray:
        """(H, W) uint32: bit j-1 set where the pixel is inside (or on the edge of) mirror j's boundary."""
        bits = np.zeros(self.intrinsics.shape, dtype=np.uint32)
        for j, mirror in enumerate(self.mirrors):
            if mirror.boundary is not None:
                bits[polygon_mask(mirror.boundary, self.intrinsics.shape)] |= np.uint32(1 << j)
        bits.flags.writeable = False
        return bits

    @cached_property
    def reflection_table(self) -> "ReflectionTable":
        """Per-pixel geometry of Algorithm 1, computed once per rig (see ReflectionTable)."""
        return ReflectionTable.from_rig(self)


def calibrated_rig(session: Session) -> Rig:
    """The session's rig, refusing (MirrorscanError naming session.json) a session without mirrors or with a mirror
    that cannot reconstruct (no plane or no boundary)."""
    if not session.mirrors:
        raise MirrorscanError(f"{session.path}: the session has no mirrors")
    for m in session.mirrors:
        if m.plane is None:
            raise MirrorscanError(f"{session.path}: {m.name} has no plane; run `mirrorscan calibrate {session.root}`")
        if not m.boundary:
            raise MirrorscanError(f"{session.path}: {m.name} has no boundary polygon")
    return Rig.from_session(session)


@dataclass(frozen=True, eq=False)
class ReflectionTable:
    """Algorithm 1 per pixel, precomputed: a pixel at depth z is reflected through the first calibrated mirror whose
    boundary holds it (`label`) exactly when z > threshold, since its point z * ray is behind plane (n, d) when
    z (n . ray) + d < 0. All arrays are (H, W) (normal: (3, H, W)), read-only.

    label : uint8, that mirror (1-based), 0 for pixels in no calibrated mirror's boundary
    threshold : float32 metres, inf where the pixel can never be behind it (label 0, or its ray leaves the glass)
    normal, offset, ray_dot : float32, that mirror's n and d, and n . (x/z, y/z, 1) of the pixel's ray
    overlap : bool, inside the boundaries of more than one calibrated mirror (later mirrors are tried there too)
    uncalibrated : bool, inside the boundary of a mirror that has no plane yet
    """

    label: np.ndarray
    threshold: np.ndarray
    normal: np.ndarray
    offset: np.ndarray
    ray_dot: np.ndarray
    overlap: np.ndarray
    uncalibrated: np.ndarray

    @classmethod
    def from_rig(cls, rig: Rig) -> "ReflectionTable":
        shape, rays = rig.intrinsics.shape, rig.intrinsics.rays
        label = np.zeros(shape, np.uint8)
        count = np.zeros(shape, np.uint8)
        normal = np.zeros((3, *shape), np.float32)
        offset = np.zeros(shape, np.float32)
        uncalibrated = np.zeros(shape, bool)
        for j, mirror in enumerate(rig.mirrors, start=1):
            if mirror.boundary is None:
                continue
            inside = polygon_mask(mirror.boundary, shape)
            if mirror.plane is None:
                uncalibrated |= inside
                continue
            first = inside & (label == 0)
            label[first] = j
            normal[:, first] = mirror.plane.n[:, None]
            offset[first] = mirror.plane.d
            count += inside
        ray_dot = normal[0] * rays[0] + normal[1] * rays[1] + normal[2]
        with np.errstate(divide="ignore", invalid="ignore"):
            threshold = np.where((label > 0) & (ray_dot < 0), -offset / ray_dot, np.inf).astype(np.float32)
        arrays = dict(label=label, threshold=threshold, normal=normal, offset=offset, ray_dot=ray_dot,
                      overlap=count > 1, uncalibrated=uncalibrated)
        for a in arrays.values():
            a.flags.writeable = False
        return cls(**arrays)
