"""The views of a rig for dense reconstruction: the camera, each mirror's virtual camera and those of the sequences of
mirrors the camera sees through in turn, each with the depth it measures and which of its pixels show the object's
surface; sampling a view's depth at points (nearest or bilinear).

A mirror's view is the camera seen through the mirror: a point P is seen by mirror j where its reflection
P_j = reflect(P, plane j) projects into mirror j's boundary, at the measured (virtual, unfolded) depth of that pixel.
The reflection is the view's extrinsic (det -1); projecting P_j with the camera's intrinsics is the whole model. A
sequence of mirrors (a, b, ...) is a view the same way, with the extrinsic M_a M_b ... (det +1 for two mirrors), on
the pixels whose ray meets those mirrors in turn (mirrorcore.paths), between the depths where it meets them.

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
from ..palette import source_sequence
from ..paths import Chains, sequence_reflection
from ..rig import ReflectionTable, Rig
from .volume import Volume

BILINEAR_GAP = 0.03   # metres: four neighbours spread wider than this are a depth edge (nearest pixel used there)


@dataclass(frozen=True, eq=False)
class View:
    """One view of the rig. source : 0 camera, j mirror j, from 33 a sequence of mirrors (mirrorcore.palette).
    to_view : (3, 4) float64 [R | t] mapping camera-frame points to the points this view projects (identity, the
    reflection through mirror j's plane, or the composition M_1 M_2 ... of a sequence's: mirrorcore.paths).
    depth : (H*W + 1,) float32 flat depth per pixel as in the module docstring, its last cell NaN (off-image reads).
    surface : (H*W + 1,) bool, the pixel shows the object in this view (False in the last cell).
    cull_depth : (H*W + 1,) float32, the 3x3 minimum of depth (NaN read as +inf): a point nearer than
    cull_depth - th is empty in this view even with bilinear sampling.
    outline : (H*W + 1,) bool, the pixels this view sees through (a mirror's boundary; for a sequence, the pixels
    whose ray meets its mirrors in turn; every pixel for the camera), False in the last cell."""

    source: int
    to_view: np.ndarray
    depth: np.ndarray
    surface: np.ndarray
    cull_depth: np.ndarray
    outline: np.ndarray


def rig_views(rig: Rig, depth: np.ndarray, mask: np.ndarray) -> tuple[View, ...]:
    """The camera's view, one view per calibrated mirror with a boundary (session order), then one per sequence of
    mirrors that some pixel's ray follows (mirrorcore.paths; label order): the virtual cameras of the rig.

    depth : (H, W) float metres, 0 = no reading (typically smoothed as for Algorithm 1); mask : (H, W) bool, the
    object's pixels (direct or in a mirror). A pixel inside mirror j's boundary is mirror j's when its point lies
    behind plane j (the Algorithm 1 test) and, where its ray goes on to another mirror, before the depth where it
    meets that one; beyond it the pixel belongs to the sequence's view, up to the next mirror. The object pixels that
    no mirror claims are the camera's.
    """
    intr = rig.intrinsics
    z = check_depth_shape(intr, depth).astype(np.float32)
    mask = np.asarray(mask, bool) & (z > 0)
    empty = np.where(z > 0, z, np.float32(np.inf))           # off-mask pixels with no reading: empty rays
    segments = _Segments.of(rig.reflection_table, z)
    views, claimed = [], np.zeros(intr.shape, bool)
    for j, mirror in enumerate(rig.mirrors, start=1):
        if mirror.plane is None or mirror.boundary is None:
            continue
        n, d = mirror.plane.n, mirror.plane.d
        ray_dot = n[0] * intr.rays[0] + n[1] * intr.rays[1] + n[2]
        inside = polygon_mask(mirror.boundary, intr.shape)
        through = inside & ((z == 0) | (z * ray_dot + d < 0))  # the reflected ray exists: no reading, or behind
        seen = np.where(through, empty, np.float32(np.nan))
        surface = through & mask
        segments.end_first(j, seen, surface)
        claimed |= surface
        views.append(_view(j, mirror.plane.reflection_matrix()[:3], seen, surface, inside))
    for label, sequence in segments.sequences():
        seen, surface, outline = segments.view_of(label, empty, mask)
        claimed |= surface
        views.append(_view(label, sequence_reflection(rig.planes, sequence)[:3], seen, surface, outline))
    direct = _view(0, np.eye(4)[:3], empty, mask & ~claimed, np.ones(intr.shape, bool))
    return (direct, *views)


@dataclass(frozen=True, eq=False)
class _Segments:
    """Where the rays of the chains' pixels (ReflectionTable.chains) go on through further mirrors, as depth segments
    along each pixel's ray: segment k (k = 0: the first mirror's) spans z in (start[:, k], end[:, k]).
    chains : the table's chains; z : (c,) float32 their measured depth (0: no reading)."""

    chains: Chains
    first: np.ndarray
    start: np.ndarray
    end: np.ndarray
    z: np.ndarray
    shape: tuple[int, int]

    @classmethod
    def of(cls, table: ReflectionTable, z: np.ndarray) -> "_Segments":
        chains = table.chains
        flat_threshold = table.threshold.reshape(-1)[chains.pixel]
        start = np.concatenate([flat_threshold[:, None], chains.threshold.T], axis=1)
        end = np.minimum(np.concatenate([chains.threshold.T, chains.cutoff[:, None]], axis=1), chains.cutoff[:, None])
        return cls(chains, table.label.reshape(-1)[chains.pixel], start, end, z.reshape(-1)[chains.pixel], z.shape)

    def end_first(self, mirror: int, seen: np.ndarray, surface: np.ndarray) -> None:
        """Mirror `mirror`'s view (seen : (H, W) float32 depth, surface : (H, W) bool, in place) knows its pixels'
        rays only up to where they meet their second mirror."""
        rows = np.flatnonzero(self.first == mirror)
        pixel, end = self.chains.pixel[rows], self.end[rows, 0]
        seen.reshape(-1)[pixel] = np.minimum(seen.reshape(-1)[pixel], end)       # NaN (nothing known) stays NaN
        surface.reshape(-1)[pixel] &= self.z[rows] < end

    def sequences(self) -> list[tuple[int, tuple[int, ...]]]:
        """(label, sequence) of every sequence of two or more mirrors that some pixel follows, in label order."""
        return [(int(s), source_sequence(int(s))) for s in np.unique(self.chains.label[self.chains.label > 0])]

    def view_of(self, label: int, empty: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The depth (H, W) float32, surface (H, W) bool and outline (H, W) bool of the sequence `label`'s view: its
        pixels see the ray's segment after that sequence (empty up to the measured depth, or up to the next mirror);
        elsewhere, and where the measured point lies before the segment, the view knows nothing (NaN)."""
        level, rows = np.nonzero(self.chains.label == label)
        pixel, start, end, z = self.chains.pixel[rows], self.start[rows, level + 1], self.end[rows, level + 1], \
            self.z[rows]
        after = (z == 0) | (z > start)
        seen = np.full(self.shape, np.nan, np.float32)
        surface, outline = np.zeros(self.shape, bool), np.zeros(self.shape, bool)
        seen.reshape(-1)[pixel[after]] = np.minimum(empty.reshape(-1)[pixel[after]], end[after])
        surface.reshape(-1)[pixel] = mask.reshape(-1)[pixel] & after & (z < end)
        outline.reshape(-1)[pixel] = True
        return seen, surface, outline


def _view(source: int, to_view: np.ndarray, depth: np.ndarray, surface: np.ndarray, outline: np.ndarray) -> View:
    cull = cv2.erode(np.where(np.isnan(depth), np.inf, depth).astype(np.float32), np.ones((3, 3), np.uint8))
    return View(source, np.asarray(to_view, np.float64), padded_flat(depth, np.nan), padded_flat(surface, False),
                padded_flat(cull, np.inf), padded_flat(outline, False))


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
