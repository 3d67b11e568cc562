"""Small analytic scenes for the unit tests: depth images of planes and spheres computed in closed form."""
from __future__ import annotations

import numpy as np

from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane


def plane_depth(intr: Intrinsics, plane: Plane) -> np.ndarray:
    """(H, W) float32 depth of every pixel's ray hitting `plane` (0 where the ray misses it or hits behind)."""
    n = plane.n
    denom = n[0] * intr.rays[0] + n[1] * intr.rays[1] + n[2]
    with np.errstate(divide="ignore"):
        z = -plane.d / denom
    return np.where(np.isfinite(z) & (z > 0), z, 0).astype(np.float32)


def sphere_depth(intr: Intrinsics, centre, radius: float) -> np.ndarray:
    """(H, W) float32 depth of the near side of a sphere along each pixel's ray, 0 where the ray misses."""
    r = np.stack([intr.rays[0], intr.rays[1], np.ones(intr.shape, np.float32)], -1).astype(np.float64)
    c = np.asarray(centre, float)
    a = (r * r).sum(-1)
    b = (r @ c)
    disc = b * b - a * (c @ c - radius * radius)
    z = (b - np.sqrt(np.maximum(disc, 0))) / a
    return np.where(disc > 0, z, 0).astype(np.float32)
