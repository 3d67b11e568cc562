"""The views of a rig for dense reconstruction: the camera, each mirror's virtual camera and those
of the sequences of mirrors the camera sees through in turn, each with the depth it measures and
which of its pixels show the object's surface (what is sampled where points fall in a view:
mirrorcore.dense.sampling).

A mirror's view is the camera seen through the mirror: a point P is seen by mirror j where its
reflection P_j = reflect(P, plane j) projects into mirror j's boundary, at the measured (virtual,
unfolded) depth of that pixel. The reflection is the view's extrinsic (det -1); projecting P_j with
the camera's intrinsics is the whole model. A sequence of mirrors (a, b, ...) is a view the same
way, with the extrinsic M_a M_b ... (det +1 for two mirrors), on the pixels whose ray meets those
mirrors in turn (mirrorcore.rig.raypaths), between the depths where it meets them.

Per view and per pixel, `depth` (float32 metres, z of the unfolded point) reads:
  finite : the ray is empty up to this depth (and, where `surface` is set, meets the object's
  surface there) +inf   : the ray is empty all the way (a pixel off the object mask with no reading)
  NaN    : the view knows nothing along this ray (a mirror view outside its boundary, or something
  in front of the
           glass hides the mirror there)
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache

import cv2
import numpy as np

from mirrorcore.geometry.camera import check_depth_shape
from mirrorcore.geometry.polygon import polygon_mask
from mirrorcore.base.palette import source_sequence
from mirrorcore.rig.raypaths import Chains, sequence_reflection
from mirrorcore.rig.model import ReflectionTable, Rig
from mirrorcore.dense.sampling import Quads


@dataclass(frozen=True, eq=False)
class View:
    """One view of the rig.

    The tables derived from these (`cull_depth`, `quads`) are made on first use.

    Attributes
    ----------
    source : int
        0 camera, j mirror j, from 33 a sequence of mirrors (mirrorcore.base.palette).
    to_view : (3, 4) float64 array
        [R | t] mapping camera-frame points to the points this view projects (identity, the
        reflection through mirror j's plane, or the composition M_1 M_2 ... of a sequence's:
        mirrorcore.rig.raypaths).
    depth : (H*W + 1,) float32 array
        Flat depth per pixel as in the module docstring, metres; its last cell NaN (off-image
        reads).
    surface : (H*W + 1,) bool array
        The pixel shows the object in this view (False in the last cell).
    outline : (H*W + 1,) bool array
        The pixels this view sees through (a mirror's boundary; for a sequence, the pixels whose ray
        meets its mirrors in turn; every pixel for the camera), False in the last cell.
    shape : (int, int)
        (H, W).
    """

    source: int
    to_view: np.ndarray
    depth: np.ndarray
    surface: np.ndarray
    outline: np.ndarray
    shape: tuple[int, int]

    @cached_property
    def cull_depth(self) -> np.ndarray:
        """(H*W + 1,) float32, the 3x3 minimum of depth (NaN read as +inf; +inf in the last cell).

        A point nearer than cull_depth - th is empty in this view even with bilinear sampling.
        """
        return cull_depth(self.depth, self.shape)

    @cached_property
    def quads(self) -> Quads:
        """The depth read by quads of pixels, for sampling at points (sampling.Quads)."""
        return Quads.of(self.depth[:-1].reshape(self.shape), self.surface[:-1].reshape(self.shape))


def rig_views(rig: Rig, depth: np.ndarray, mask: np.ndarray) -> tuple[View, ...]:
    """Return the virtual cameras of the rig as views of one frame.

    The camera's view, one view per calibrated mirror with a boundary (session order), then one per
    sequence of mirrors that some pixel's ray follows (mirrorcore.rig.raypaths; label order). A
    pixel inside mirror j's boundary is mirror j's when its point lies behind plane j (the
    Algorithm 1 test) and, where its ray goes on to another mirror, before the depth where it meets
    that one; beyond it the pixel belongs to the sequence's view, up to the next mirror. The object
    pixels that no mirror claims are the camera's.

    Parameters
    ----------
    rig : Rig
    depth : (H, W) float array
        Metres, 0 = no reading (typically smoothed as for Algorithm 1).
    mask : (H, W) bool array
        The object's pixels (direct or in a mirror).

    Returns
    -------
    tuple of View
    """
    intr = rig.intrinsics
    z = check_depth_shape(intr, depth).astype(np.float32)
    mask = np.asarray(mask, bool) & (z > 0)
    empty, empty_image = _padded(intr.shape, np.nan, np.float32)
    empty_image[:] = z
    # off-mask pixels with no reading: empty rays
    np.copyto(empty_image, np.float32(np.inf), where=~(z > 0))
    segments = _Segments.of(rig.reflection_table, z)
    views, claimed = [], np.zeros(intr.shape, bool)
    for j, (mirror, tables) in enumerate(zip(rig.mirrors, _mirror_tables(rig)), start=1):
        if tables is None:
            continue
        inside, behind, outline = tables
        # the reflected ray exists: behind, or no reading
        through = (z > behind) | ((z == 0) & inside)
        seen, seen_image = _padded(intr.shape, np.nan, np.float32)
        np.copyto(seen_image, empty_image, where=through)
        surface, surface_image = _padded(intr.shape, False, bool)
        np.logical_and(through, mask, out=surface_image)
        segments.end_first(j, seen_image, surface_image)
        claimed |= surface_image
        views.append(View(j, mirror.plane.reflection_matrix()[:3], seen, surface, outline,
                          intr.shape))
    for label, sequence in segments.sequences():
        seen, surface, outline = segments.view_of(label, empty, mask)
        claimed |= surface[:-1].reshape(intr.shape)
        views.append(View(label, sequence_reflection(rig.planes, sequence)[:3], seen, surface,
                          outline, intr.shape))
    surface, surface_image = _padded(intr.shape, False, bool)
    np.logical_and(mask, ~claimed, out=surface_image)
    direct = View(0, np.eye(3, 4), empty, surface, _everywhere(intr.shape), intr.shape)
    return (direct, *views)


def cull_depth(depth: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Return View.cull_depth of a flat depth.

    The least of several views' cull depths is the cull depth of their least depth (erosion and the
    minimum commute).

    Parameters
    ----------
    depth : (H*W + 1,) float32 array
        Metres (View.depth).
    shape : (int, int)
        (H, W).

    Returns
    -------
    (H*W + 1,) float32 array
    """
    image = depth[:-1].reshape(shape)
    cull = cv2.erode(np.where(np.isnan(image), np.float32(np.inf), image),
                     np.ones((3, 3), np.uint8))
    return padded_flat(cull, np.inf)


def _padded(shape: tuple[int, int], fill, dtype) -> tuple[np.ndarray, np.ndarray]:
    """A flat (H*W + 1,) array filled with `fill` (View's layout: the last cell is the pad), and its
    (H, W) view."""
    flat = np.full(shape[0] * shape[1] + 1, fill, dtype)
    return flat, flat[:-1].reshape(shape)


@lru_cache(maxsize=8)
def _everywhere(shape: tuple[int, int]) -> np.ndarray:
    """(H*W + 1,) bool, True but in the pad cell: the camera's outline."""
    flat, image = _padded(shape, False, bool)
    image[:] = True
    flat.flags.writeable = False
    return flat


@lru_cache(maxsize=8)
def _mirror_tables(rig: Rig) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray] | None, ...]:
    """Per mirror of the rig (made once per rig), None when it has no plane or no boundary, else:
    inside (H, W) bool, the pixels of its boundary; behind (H, W) float32, the depth beyond which a
    pixel's point is behind its plane (+inf outside the boundary or where the ray never gets behind
    it); outline (H*W + 1,) bool, inside padded as View.outline. A float32 depth z is behind exactly
    when z > behind: z (n . ray) + d < 0 in float64 for ray = (x/z, y/z, 1), with the float64
    threshold -d / (n . ray) rounded down to float32."""
    rays = rig.intrinsics.rays
    tables = []
    for m in rig.mirrors:
        if m.plane is None or m.boundary is None:
            tables.append(None)
            continue
        inside = polygon_mask(m.boundary, rig.intrinsics.shape)
        ray_dot = m.plane.n[0] * rays[0] + m.plane.n[1] * rays[1] + m.plane.n[2]
        with np.errstate(divide="ignore"):
            exact = np.where(inside & (ray_dot < 0), -m.plane.d / ray_dot, np.inf)
        behind = exact.astype(np.float32)
        behind = np.where(behind > exact, np.nextafter(behind, np.float32(-np.inf)), behind)
        outline, image = _padded(rig.intrinsics.shape, False, bool)
        image[:] = inside
        for a in (inside, behind, outline):
            a.flags.writeable = False
        tables.append((inside, behind, outline))
    return tuple(tables)


@dataclass(frozen=True, eq=False)
class _Segments:
    """Where the rays of the chains' pixels (ReflectionTable.chains) go on through further mirrors,
    as depth segments along each pixel's ray: segment k (k = 0: the first mirror's) spans z in
    (start[:, k], end[:, k]).
    chains : the table's chains; z : (c,) float32 their measured depth (0: no reading)."""

    chains: Chains
    first: np.ndarray
    start: np.ndarray
    end: np.ndarray
    z: np.ndarray
    shape: tuple[int, int]

    @classmethod
    def of(cls, table: ReflectionTable, z: np.ndarray) -> "_Segments":
        """The segments of the table's chains, for their measured depths z (c,) float32."""
        chains = table.chains
        flat_threshold = table.threshold.reshape(-1)[chains.pixel]
        start = np.concatenate([flat_threshold[:, None], chains.threshold.T], axis=1)
        end = np.minimum(np.concatenate([chains.threshold.T, chains.cutoff[:, None]], axis=1),
                         chains.cutoff[:, None])
        return cls(chains, table.label.reshape(-1)[chains.pixel], start, end,
                   z.reshape(-1)[chains.pixel], z.shape)

    def end_first(self, mirror: int, seen: np.ndarray, surface: np.ndarray) -> None:
        """Cut mirror `mirror`'s view at where its pixels' rays meet their second mirror.

        seen : (H, W) float32 depth, surface : (H, W) bool, both changed in place.
        """
        rows = np.flatnonzero(self.first == mirror)
        pixel, end = self.chains.pixel[rows], self.end[rows, 0]
        # NaN (nothing known) stays NaN
        seen.reshape(-1)[pixel] = np.minimum(seen.reshape(-1)[pixel], end)
        surface.reshape(-1)[pixel] &= self.z[rows] < end

    def sequences(self) -> list[tuple[int, tuple[int, ...]]]:
        """(label, sequence) of every sequence of 2+ mirrors some pixel follows, label order."""
        return [(int(s), source_sequence(int(s)))
                for s in np.unique(self.chains.label[self.chains.label > 0])]

    def view_of(self, label: int, empty: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray,
                                                                                np.ndarray,
                                                                                np.ndarray]:
        """Return the depth, surface and outline of the sequence `label`'s view.

        (H*W + 1,) float32, bool, bool as in View. Its pixels see the ray's segment after that
        sequence (empty up to the measured depth (empty (H*W + 1,)), or up to the next mirror);
        elsewhere, and where the measured point lies before the segment, the view knows nothing
        (NaN). mask : (H, W) bool, the object's pixels.
        """
        level, rows = np.nonzero(self.chains.label == label)
        pixel, z = self.chains.pixel[rows], self.z[rows]
        start, end = self.start[rows, level + 1], self.end[rows, level + 1]
        after = (z == 0) | (z > start)
        seen, _ = _padded(self.shape, np.nan, np.float32)
        surface, _ = _padded(self.shape, False, bool)
        outline, _ = _padded(self.shape, False, bool)
        seen[pixel[after]] = np.minimum(empty[pixel[after]], end[after])
        surface[pixel] = mask.reshape(-1)[pixel] & after & (z < end)
        outline[pixel] = True
        return seen, surface, outline


def padded_flat(image: np.ndarray, pad) -> np.ndarray:
    """Flatten an image with `pad` in an extra last cell: index H*W (see pixel_index) reads `pad`.

    Parameters
    ----------
    image : (H, W) array
    pad : scalar

    Returns
    -------
    (H*W + 1,) array
        Of the image's dtype.
    """
    return np.append(image.ravel(), np.array(pad, image.dtype))
