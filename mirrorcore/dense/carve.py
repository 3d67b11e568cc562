"""Space carving of a voxel volume with the camera and its mirrors (the paper's Algorithm 2, and a consistent carving).

How we read Algorithm 2 (method "paper", followed line by line): a voxel v of the volume in front of the mirrors is
projected to its nearest pixel p. If p is not an object pixel, v is removed. Otherwise v is kept when its distance
to the camera |v| is within th of |P|, P the reprojection of p at its measured depth (the camera sees v's surface).
Otherwise v is reflected through every mirror j in turn; it is removed as soon as one reflection v_j projects off the
object pixels, outside mirror j's boundary, or with | |v_j| - |P_j| | >= th (the `break`). So a voxel that the
camera does not see on the surface survives only if EVERY mirror sees it on the surface; the loop's order and its
`break` change nothing but the work done. The prose ("removed if the deviation condition is not satisfied with at
least one mirror") says the same. Voxels behind a mirror plane are outside the volume "in front of the mirrors" and
removed. Note what follows: a surface seen by one mirror only is lost wherever the camera does not see it, and the
kept set is a shell 2 th thick around the measured surfaces (the paper's "thicker surface"). *Extension*: the views
through several mirrors in turn (mirrorcore.dense.views) are virtual cameras like the mirrors' and join the loop, with
their outline (the pixels whose ray meets their mirrors in turn) as the mirror's boundary: read as written, a voxel
the camera does not see must then be seen by every one of them too, so "paper" keeps little beyond the camera's view in
a kaleidoscope.

Method "carve" (consistent carving): a voxel is removed (FREE) when any view, the camera or a virtual camera (a mirror,
or a sequence of mirrors), sees through it: its depth in that view is less than the measured depth minus th. It is kept
(SURFACE) when no view sees through it and at least one view shows the object's surface within th of it. A voxel that no
view sees through and none sees on the surface (inside the object, or behind it from every view) is HIDDEN: neither
carved nor kept as surface (SURFACE | HIDDEN is the carved solid). Depth is sampled bilinearly (sub-pixel, as the paper
suggests for the sparse mirror regions) where the four pixels around a point show the surface with no depth edge.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MirrorscanError
from ..rig import Rig
from .views import (
    View,
    direct_pixels,
    in_front_of_mirrors,
    padded_flat,
    pixel_index,
    project,
    rig_views,
    sample,
    transform,
)
from .volume import NO_SOURCE, Progress, Volume, run_slabs

FREE, SURFACE, HIDDEN = 0, 1, 2          # voxel states
METHODS = ("paper", "carve")


@dataclass(frozen=True, eq=False)
class CarveResult:
    """state : (nx, ny, nz) uint8 FREE / SURFACE / HIDDEN; source : (nx, ny, nz) uint8, the view (0 camera, j mirror
    j, from 33 a sequence of mirrors) that sees a SURFACE voxel nearest to its centre, NO_SOURCE elsewhere; threshold
    th in metres."""

    volume: Volume
    state: np.ndarray
    source: np.ndarray
    method: str
    threshold: float

    def surface_points(self) -> tuple[np.ndarray, np.ndarray]:
        """The SURFACE voxels' centres (n, 3) float32 metres, camera frame, and their sources (n,) uint8."""
        index = np.flatnonzero(self.state.reshape(-1) == SURFACE)
        return self.volume.centres(index), self.source.reshape(-1)[index]


def carve(rig: Rig, depth: np.ndarray, mask: np.ndarray, volume: Volume, method: str = "carve",
          threshold: float | None = None, progress: Progress | None = None, cancel=None,
          workers: int | None = None) -> CarveResult:
    """Carve `volume` with one depth frame (see the module docstring for the methods).

    depth : (H, W) float metres, 0 = no reading; mask : (H, W) bool, the object's pixels (direct and in mirrors);
    threshold : th in metres (default: the voxel size); progress(fraction) after each slab; cancel : a
    threading.Event or a callable returning True to stop. Raises Cancelled when stopped (nothing is returned),
    MirrorscanError for an unknown method or a non-positive threshold.
    """
    if method not in METHODS:
        raise MirrorscanError(f"carve: unknown method {method!r} (expected one of {', '.join(METHODS)})")
    th = volume.voxel if threshold is None else float(threshold)
    if not th > 0:
        raise MirrorscanError(f"carve: the threshold must be positive, got {threshold}")
    views = rig_views(rig, depth, mask)
    state = np.full(volume.shape, FREE, np.uint8)
    source = np.full(volume.shape, NO_SOURCE, np.uint8)
    if method == "paper":
        images = _PaperImages.of(rig, depth, mask)
        work = lambda slab: _paper_slab(rig, views, images, volume, th, slab, state, source)  # noqa: E731
    else:
        work = lambda slab: _carve_slab(rig, views, volume, th, slab, state, source)  # noqa: E731
    run_slabs(volume, work, progress, cancel, workers)
    return CarveResult(volume, state, source, method, th)


@dataclass(frozen=True, eq=False)
class _PaperImages:
    """Flat (H*W + 1,) per-pixel inputs of Algorithm 2 (pad cell last): `object` the object pixels {p}_n, `distance`
    |P| = Z |ray| the measured distance to the camera (each view's outline is View.outline)."""

    object: np.ndarray
    distance: np.ndarray

    @classmethod
    def of(cls, rig: Rig, depth: np.ndarray, mask: np.ndarray) -> "_PaperImages":
        rays = rig.intrinsics.rays
        z = np.asarray(depth, np.float32)
        return cls(padded_flat(np.asarray(mask, bool) & (z > 0), False),
                   padded_flat(z * np.sqrt(rays[0] ** 2 + rays[1] ** 2 + 1), np.nan))


def _carve_slab(rig: Rig, views: tuple[View, ...], volume: Volume, th: float, slab: slice, state: np.ndarray,
                source: np.ndarray) -> None:
    """Method 'carve' on one slab, in place. The camera's 3x3-minimum depth first removes, by broadcasting, the voxels
    it sees through even with sub-pixel lookup; the remaining ones are checked against every view."""
    z = volume.axes()[2].astype(np.float32)
    direct = views[0]
    local = np.flatnonzero(z >= direct.cull_depth[direct_pixels(rig.intrinsics, volume, slab)] - np.float32(th))
    index, points = volume.slab_points(slab, local)
    free = ~in_front_of_mirrors(rig, points)
    best = np.full(points.shape[1], np.inf, np.float32)
    best_source = np.full(points.shape[1], NO_SOURCE, np.uint8)
    for view in views:
        p = transform(view, points)
        d, surface = sample(rig.intrinsics, view, p)
        with np.errstate(invalid="ignore"):
            free |= p[2] < d - th
            gap = np.where(surface, np.abs(p[2] - d), np.inf)
        closer = gap < np.minimum(best, th + np.float32(1e-9))
        best = np.where(closer, gap, best)
        best_source[closer] = view.source
    seen = best_source != NO_SOURCE
    state.reshape(-1)[index] = np.where(free, FREE, np.where(seen, SURFACE, HIDDEN))
    source.reshape(-1)[index] = np.where(free, NO_SOURCE, best_source)


def _paper_slab(rig: Rig, views: tuple[View, ...], images: _PaperImages, volume: Volume, th: float, slab: slice,
                state: np.ndarray, source: np.ndarray) -> None:
    """Algorithm 2 as written on one slab, in place (see the module docstring); voxels start removed (FREE)."""
    intr = rig.intrinsics
    pixel = direct_pixels(rig.intrinsics, volume, slab).reshape(-1)
    local = np.flatnonzero(images.object[pixel])          # Project(v) in {p}_n, else removed
    index, points = volume.slab_points(slab, local)
    front = in_front_of_mirrors(rig, points)
    with np.errstate(invalid="ignore"):
        direct = np.abs(np.linalg.norm(points, axis=0) - images.distance[pixel[local]]) < th
    every_mirror = np.ones(points.shape[1], bool)
    best = np.full(points.shape[1], np.inf, np.float32)
    best_source = np.zeros(points.shape[1], np.uint8)
    for view in views[1:]:
        p = transform(view, points)
        at = pixel_index(intr, *project(intr, p))
        with np.errstate(invalid="ignore"):
            gap = np.abs(np.linalg.norm(p, axis=0) - images.distance[at])
            every_mirror &= images.object[at] & view.outline[at] & (gap < th)
        closer = gap < best
        best = np.where(closer, gap, best)
        best_source[closer] = view.source
    kept = front & (direct | every_mirror)
    state.reshape(-1)[index] = np.where(kept, SURFACE, FREE)
    source.reshape(-1)[index] = np.where(kept, np.where(direct, 0, best_source), NO_SOURCE)
