"""The views of a rig for dense reconstruction: the camera and each mirror's virtual camera, each with the depth it
measures and which of its pixels show the object's surface; sampling a view's depth at points (nearest or bilinear).

A mirror's view is the camera seen through the mirror: a point P is seen by mirror j where its reflection
P_j = reflect(P, plane j) projects into mirror j's boundary, at the measured (virtual, unfolded) depth of that pixel.
The reflection is the view's extrinsic (det -1); projecting P_j with the camera's intrinsics is the whole model.

Per view and per pixel, `depth` (float32 metres, z of the unfolded point) reads:
  finite : the ray is empty up to this depth (and, where `surface` is set, meets the object's surface there)
  +inf   : the ray is empty all the way (a pixel off the object mask with no reading)
  NaN    : the view knows nothing along this ray (a mirror view outside its boundary, or something in front of the
           glass hides the mirror there)
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..geometry.camera import Intrinsics, check_depth_shape
from ..geometry.polygon import polygon_mask
from ..rig import Rig
from .volume import Volume

BILINEAR_GAP = 0.03   # metres: four neighbours spread wider than this are a depth edge (nearest pixel used there)


@dataclass(frozen=True, eq=False)
class View:
    """One view of the rig. source : 0 camera, j mirror j. to_view : (3, 4) float64 [R | t] mapping camera-frame
    points to the points this view projects (identity, or the reflection through mirror j's plane).
    depth : (H*W + 1,) float32 flat depth per pixel as in the module docstring, its last cell NaN (off-image reads).
    surface : (H*W + 1,) bool, the pixel shows the object in this view (False in the last cell).
    cull_depth : (H*W + 1,) float32, the 3x3 minimum of depth (NaN read as +inf): a point nearer than
    cull_depth - th is empty in this view even with bilinear sampling."""

    source: int
    to_view: np.ndarray
    depth: np.ndarray
    surface: np.ndarray
    cull_depth: np.ndarray


def rig_views(rig: Rig, depth: np.ndarray, mask: np.ndarray) -> tuple[View, ...]:
    """The camera's view and one view per calibrated mirror with a boundary, in session order.

    depth : (H, W) float metres, 0 = no reading (typically smoothed as for Algorithm 1); mask : (H, W) bool, the
    object's pixels (direct or in a mirror). A pixel inside mirror j's boundary is mirror j's when its point lies
    behind plane j (the Algorithm 1 test); the object pixels that no mirror claims are the camera's.
    """
    intr = rig.intrinsics
    z = check_depth_shape(intr, depth).astype(np.float32)
    mask = np.asarray(mask, bool) & (z > 0)
    empty = np.where(z > 0, z, np.float32(np.inf))           # off-mask pixels with no reading: empty rays
    views, claimed = [], np.zeros(intr.shape, bool)
    for j, mirror in enumerate(rig.mirrors, start=1):
        if mirror.plane is None or mirror.boundary is None:
            continue
        n, d = mirror.plane.n, mirror.plane.d
        ray_dot = n[0] * intr.rays[0] + n[1] * intr.rays[1] + n[2]
        inside = polygon_mask(mirror.boundary, intr.shape)
        through = inside & ((z == 0) | (z * ray_dot + d < 0))  # the reflected ray exists: no reading, or behind
        surface = through & mask
        claimed |= surface
        views.append(_view(j, mirror.plane.reflection_matrix()[:3], np.where(through, empty, np.nan), surface))
    direct = _view(0, np.eye(4)[:3], empty, mask & ~claimed)
    return (direct, *views)


def _view(source: int, to_view: np.ndarray, depth: np.ndarray, surface: np.ndarray) -> View:
    cull = cv2.erode(np.where(np.isnan(depth), np.inf, depth).astype(np.float32), np.ones((3, 3), np.uint8))
    return View(source, np.asarray(to_view, np.float64), padded_flat(depth, np.nan), padded_flat(surface, False),
                padded_flat(cull, np.inf))


def padded_flat(image: np.ndarray, pad) -> np.ndarray:
    """(H, W) image -> (H*W + 1,) of its dtype with `pad` in the last cell: index H*W (see pixel_index) reads `pad`."""
    return np.append(image.ravel(), np.array(pad, image.dtype))


def transform(view: View, points: np.ndarray) -> np.ndarray:
    """points (3, n) float32 rows x, y, z, camera frame -> (3, n) float32 in the frame this view projects
    (see View.to_view); one multiply-add per coefficient (a (n, 3) @ (3, 3) product is several times slower)."""
    m = view.to_view.astype(np.float32)
    return np.stack([m[r, 0] * points[0] + m[r, 1] * points[1] + m[r, 2] * points[2] + m[r, 3] for r in range(3)])


def pixel_index(intr: Intrinsics, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Nearest pixel of real coordinates u, v (any broadcastable shapes; NaN allowed) -> int64 flat index v*W + u,
    H*W (the pad cell) off the image."""
    iu, iv = np.rint(u), np.rint(v)
    ok = (iu >= 0) & (iu < intr.width) & (iv >= 0) & (iv < intr.height)
    with np.errstate(invalid="ignore"):
        return np.where(ok, iv * intr.width + iu, intr.width * intr.height).astype(np.int64)


def project(intr: Intrinsics, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(3, n) float32 points in a view's frame -> u, v (n,) float32 pixel coordinates, NaN where z <= 0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(p[2] > 0, np.float32(1) / p[2], np.float32(np.nan))
    return (np.float32(intr.fx) * p[0] * inv + np.float32(intr.cx),
            np.float32(intr.fy) * p[1] * inv + np.float32(intr.cy))


def sample(intr: Intrinsics, view: View, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The view's depth at points p (3, n) float32 in the view's frame (see `transform`), with sub-pixel lookup.

    Where the four pixels around a point all show the surface within BILINEAR_GAP of each other, the depth is their
    bilinear interpolation and the point counts as on the surface's ray. Elsewhere (a depth edge, the silhouette, no
    surface) the depth is the least of the four (NaN ones ignored): the ray is empty up to there whichever of the four
    the point's own ray is closest to, and the point does not count as on the surface.
    returns depth (n,) float32 metres (as in the module docstring; NaN off the image, behind the camera, or where
    the view knows nothing) and surface (n,) bool.
    """
    u, v = project(intr, p)
    with np.errstate(invalid="ignore"):
        u0 = np.clip(np.floor(u), 0, intr.width - 2)
        v0 = np.clip(np.floor(v), 0, intr.height - 2)
    fu, fv = np.clip(u - u0, 0, 1), np.clip(v - v0, 0, 1)
    i00 = pixel_index(intr, u0, v0)
    pad = i00 == intr.width * intr.height
    corners = [i00, np.where(pad, i00, i00 + 1), np.where(pad, i00, i00 + intr.width),
               np.where(pad, i00, i00 + intr.width + 1)]
    d = [view.depth[i] for i in corners]
    surface = view.surface[corners[0]] & view.surface[corners[1]] & view.surface[corners[2]] \
        & view.surface[corners[3]]
    low = np.fmin(np.fmin(d[0], d[1]), np.fmin(d[2], d[3]))
    with np.errstate(invalid="ignore"):
        surface &= np.fmax(np.fmax(d[0], d[1]), np.fmax(d[2], d[3])) - low < BILINEAR_GAP
        top = d[0] + fu * (d[1] - d[0])
        bottom = d[2] + fu * (d[3] - d[2])
        return np.where(surface, top + fv * (bottom - top), low), surface


def direct_pixels(intr: Intrinsics, volume: Volume, slab: slice) -> np.ndarray:
    """(ni, ny, nz) int64 nearest pixel (flat index, H*W off the image or behind the camera) of every voxel of the
    slab (see Volume.slabs), by broadcasting: u depends on (x, z) only and v on (y, z) only."""
    x, y, z = (a.astype(np.float32) for a in volume.axes())
    inv_z = np.where(z > 0, np.float32(1) / np.maximum(z, np.float32(1e-9)), np.float32(np.nan))  # behind: off image
    u = np.float32(intr.fx) * x[slab, None, None] * inv_z + np.float32(intr.cx)
    v = np.float32(intr.fy) * y[None, :, None] * inv_z + np.float32(intr.cy)
    return pixel_index(intr, u, v)


def in_front_of_mirrors(rig: Rig, points: np.ndarray) -> np.ndarray:
    """points (3, n) float32 camera frame -> (n,) bool: in front of every calibrated mirror plane (the volume the
    algorithms carve)."""
    ok = np.ones(points.shape[1], bool)
    for m in rig.mirrors:
        if m.plane is not None:
            n = m.plane.n.astype(np.float32)
            ok &= n[0] * points[0] + n[1] * points[1] + n[2] * points[2] + np.float32(m.plane.d) > 0
    return ok
