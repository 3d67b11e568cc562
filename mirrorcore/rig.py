"""The rig: the depth camera's intrinsics and the mirrors (plane + image boundary), with boundary masks rasterised once."""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .camera import Intrinsics
from .errors import MirrorscanError
from .plane import Plane
from .polygon import polygon_mask, validate_polygon
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
    def uncalibrated_bits(self) -> int:
        """Bit mask of the mirrors that have a boundary but no plane yet."""
        return sum(1 << j for j, m in enumerate(self.mirrors) if m.plane is None and m.boundary is not None)

    def mirror_label(self) -> np.ndarray:
        """(H, W) uint8: j for pixels inside mirror j's boundary (the first in session order on overlaps), else 0."""
        bits = self.inside_bits
        label = np.zeros(bits.shape, dtype=np.uint8)
        for j in range(len(self.mirrors), 0, -1):
            label[(bits >> np.uint32(j - 1)) & np.uint32(1) == 1] = j
        return label
