"""Small analytic scenes for the unit tests: depth images of planes and spheres computed in closed
form; and the real TUM RGB-D globe's points."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from mirrorcore.geometry.camera import Intrinsics, reproject_depth
from mirrorcore.geometry.plane import Plane

GLOBE_DEPTH = Path("/work/shared/data/real/tum_globe_depth.png")


def plane_depth(intr: Intrinsics, plane: Plane) -> np.ndarray:
    """(H, W) float32 depth of every pixel's ray hitting `plane` (0 where the ray misses it or hits
    behind)."""
    n = plane.n
    denom = n[0] * intr.rays[0] + n[1] * intr.rays[1] + n[2]
    with np.errstate(divide="ignore"):
        z = -plane.d / denom
    return np.where(np.isfinite(z) & (z > 0), z, 0).astype(np.float32)


def sphere_depth(intr: Intrinsics, centre, radius: float) -> np.ndarray:
    """(H, W) float32 depth of the near side of a sphere along each pixel's ray, 0 where the ray
    misses."""
    r = np.stack([intr.rays[0], intr.rays[1], np.ones(intr.shape, np.float32)], -1).astype(
        np.float64
    )
    c = np.asarray(centre, float)
    a = (r * r).sum(-1)
    b = r @ c
    disc = b * b - a * (c @ c - radius * radius)
    z = (b - np.sqrt(np.maximum(disc, 0))) / a
    return np.where(disc > 0, z, 0).astype(np.float32)


def globe_points() -> np.ndarray:
    """The TUM RGB-D globe (README: ~21-23 cm radius, top left, ~2.1-2.3 m) as camera-frame points
    (n, 3) float32.

    Selection, found by looking at the depth image: pixels u 50-179, v 5-99 (above the cabinet the
    globe stands on) with depth 2.0-2.36 m (the wall behind is at 2.4-2.5 m), their largest
    4-connected region, eroded by 3 pixels to drop the mixed foreground/background depths of
    structured light at the silhouette."""
    # TUM's recommended default
    intr = Intrinsics(640, 480, 525.0, 525.0, 319.5, 239.5, depth_scale=1 / 5000)
    depth = cv2.imread(str(GLOBE_DEPTH), cv2.IMREAD_UNCHANGED).astype(np.float32) * np.float32(
        intr.depth_scale
    )
    band = np.zeros(depth.shape, np.uint8)
    band[5:100, 50:180] = (depth[5:100, 50:180] > 2.0) & (depth[5:100, 50:180] < 2.36)
    _, labels = cv2.connectedComponents(band, connectivity=4)
    globe = (labels == np.argmax(np.bincount(labels[labels > 0]))).astype(np.uint8)
    points, _ = reproject_depth(
        intr, depth, cv2.erode(globe, np.ones((7, 7), np.uint8)).astype(bool)
    )
    return points
