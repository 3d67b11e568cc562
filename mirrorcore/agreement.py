"""The agreement of the views of a rig in one frame: how a point of one view compares with what another view saw where
the point would be; and, for a labelled cloud, each mirror point's distance to the direct surface (the heat map of a
calibration's quality).

A point P of view a, mapped into view b's space (reflected through mirror b's plane when b is a mirror), falls on a
pixel of the image. What view b saw there says one of three things:
- AGREE: b has a reading there whose surface is P's: the residual is P's distance to the surface of that reading's
  neighbours (readings.py), along its normal, evaluated where P falls (no lateral offset, so no bias from the
  surface's curvature); depth noise only when the planes are right;
- SEE_THROUGH or OUTSIDE: b saw beyond P there (P's surface is well in front of b's reading, or b saw no object
  there at all): b would have seen P, so P is misplaced; the residual is P's distance in front of b's surface, or
  its distance to b's silhouette beyond what noise explains;
- nothing: b saw nearer (P is hidden behind another part), or cannot see there (outside the image or the mirror's
  boundary, the real object in front of the glass, no reading).
A point falls where its neighbours' surface (its anchor) falls, so which case applies does not depend on its own
reading's noise. Points are compared with a reading only when both surfaces face the other view and their normals
agree, so that the front of a part is never compared with its back. Points are matched by pixel (projective
association, as KinectFusion does), never with their nearest neighbour in 3D, which prefers the readings that noise
moved towards them.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .cloud import Cloud
from .geometry.camera import Intrinsics, project_points
from .geometry.plane import Plane
from .readings import MAX_INCIDENCE_DEG, MIN_NEIGHBOURS, ViewPoints, view_points
from .reconstruct import reconstruct_raw
from .rig import Rig

MIN_NORMAL_COSINE = 0.7      # a point agrees with a reading when their normals are within 45 degrees...
AGREE_SIGMAS = 3.0           # ... and their surfaces within this many standard deviations of each other,
ANCHOR_NOISE = 0.3           # a neighbours' surface having this share of a reading's noise
SILHOUETTE_PX = 1.0          # pixels: uncertainty of a view's silhouette
OUTSIDE_SIGMAS = 2.0         # a point outside a view's silhouette counts beyond this many standard deviations
AGREE, SEE_THROUGH, OUTSIDE = 0, 1, 2   # kinds of comparison
SHOWN_GATE = 0.03            # metres: distances shown (heat map, reports) count surfaces this far apart as the same


@dataclass(frozen=True, eq=False)
class Comparison:
    """Points of one view compared with what another view saw.

    index : (m,) int64 into the points; kind : (m,) uint8 AGREE, SEE_THROUGH or OUTSIDE
    residual : (m,) float64 metres: for AGREE the point's signed distance to the other view's surface (> 0 outside
        it); for the others how far the point is where that view saw nothing (> 0)
    sigma : (m,) float64 metres, the noise of the residual
    direction : (m, 3) float64, the residual's gradient with respect to the point, in the other view's space (its
        surface's normal, or the way out of its silhouette)
    """

    index: np.ndarray
    kind: np.ndarray
    residual: np.ndarray
    sigma: np.ndarray
    direction: np.ndarray

    def __len__(self) -> int:
        return len(self.index)


def in_view(seen: ViewPoints, plane: Plane | None) -> ViewPoints:
    """Real points into the space of a view: reflected through the mirror's plane, or as they are for the camera
    (plane None)."""
    return seen if plane is None else seen.reflected(plane)


class TargetView:
    """What one view saw in a frame, as points of other views are compared with it, in its own space (the camera
    frame for the camera, its mirror image for a mirror: `in_view` maps points there).

    view : its readings; object, free : (H, W) bool, its object's pixels (whether or not they became readings), and
    where it saw beyond the object (the background; for the camera, anything but its own view of the object).
    """

    def __init__(self, intrinsics: Intrinsics, view: ViewPoints, object: np.ndarray, free: np.ndarray):
        self.intrinsics, self.view = intrinsics, view
        self.index = np.full(object.size, -1, dtype=np.int64)       # per pixel, the reading there
        self.index[view.pixels] = np.arange(len(view))
        self.free = free.reshape(-1)
        outside = cv2.distanceTransform((~object).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE) - 0.5
        self.outside = np.maximum(outside, 0).astype(np.float32)      # pixels to the silhouette, 0 on the object
        self.gradient = np.stack([cv2.Sobel(self.outside, cv2.CV_32F, 1, 0, ksize=3) / 8,
                                  cv2.Sobel(self.outside, cv2.CV_32F, 0, 1, ksize=3) / 8])

    def compare(self, mapped: ViewPoints, gate: float = 0.0) -> Comparison:
        """Points in this view's space (`in_view`), normals out of the object, compared with what it saw (see the
        module); `gate` (metres) widens what counts as the same surface while the planes may still be far off."""
        uv, z = project_points(self.intrinsics, mapped.anchors)
        u, v = np.round(np.nan_to_num(uv, nan=-1.0)).T.astype(np.int64)
        inside = np.flatnonzero((z > 0) & (u >= 0) & (u < self.intrinsics.width) & (v >= 0)
                                & (v < self.intrinsics.height))
        pixel = v[inside] * self.intrinsics.width + u[inside]
        reading = self.index[pixel]
        on = reading >= 0
        out = self.free[pixel]
        parts = [self._against_readings(mapped, inside[on], reading[on], uv[inside[on]], gate),
                 self._outside(mapped, inside[out])]
        return Comparison(*(np.concatenate(a) for a in zip(*parts)))

    def _against_readings(self, mapped: ViewPoints, index: np.ndarray, reading: np.ndarray, uv: np.ndarray,
                          gate: float) -> tuple:
        """Points whose anchors fall at uv (m, 2) on the view's readings `reading` (m,)."""
        target = self.view
        normal = target.normals[reading]
        surface = target.surface_points(self.intrinsics, reading, uv)
        sigma = np.hypot(_along(target, reading, normal), _along(mapped, index, normal))
        offset = np.einsum("ij,ij->i", normal, mapped.anchors[index] - surface)   # > 0: in front of the surface
        window = AGREE_SIGMAS * ANCHOR_NOISE * sigma + gate
        agree = ((np.abs(offset) <= window)
                 & (np.einsum("ij,ij->i", normal, mapped.normals[index]) > MIN_NORMAL_COSINE)
                 & (-np.einsum("ij,ij->i", mapped.normals[index], target.rays[reading])
                    > np.cos(np.radians(MAX_INCIDENCE_DEG))))
        # well in front, beyond what any noise explains: the view saw through the point (a window as narrow as
        # agreement's would take the noisy points in front and drop those behind, and push every point in)
        keep = agree | (offset > AGREE_SIGMAS * sigma + gate)
        index, normal = index[keep], normal[keep]
        residual = np.einsum("ij,ij->i", normal, mapped.points[index] - surface[keep])
        return index, np.where(agree[keep], AGREE, SEE_THROUGH).astype(np.uint8), residual, sigma[keep], normal

    def _outside(self, mapped: ViewPoints, index: np.ndarray) -> tuple:
        """Points whose anchors fall where the view saw no object: their distance to its silhouette, beyond what
        noise explains (a one-sided penalty would otherwise push every noisy point in)."""
        p = mapped.points[index]                        # as measured: their own noise is zero-mean
        uv, _ = project_points(self.intrinsics, p)
        scale = p[:, 2] / self.intrinsics.fx           # metres per pixel at the point's depth
        ray = mapped.anchors[index] / np.linalg.norm(mapped.anchors[index], axis=1, keepdims=True)
        across = np.sqrt(np.maximum(1 - np.einsum("ij,ij->i", mapped.rays[index], ray) ** 2, 0))
        sigma = np.sqrt((SILHOUETTE_PX * scale) ** 2 + (mapped.sigma[index] * across) ** 2
                        + mapped.lateral[index] ** 2)
        beyond = _bilinear(self.outside, uv) * scale - OUTSIDE_SIGMAS * sigma
        g = np.stack([_bilinear(self.gradient[0], uv), _bilinear(self.gradient[1], uv)], axis=-1)
        # d(distance in metres)/dP: the image gradient through the projection's derivative
        direction = np.column_stack([g, -(g[:, 0] * p[:, 0] + g[:, 1] * p[:, 1]) / p[:, 2]])
        keep = beyond > 0
        return (index[keep], np.full(int(keep.sum()), OUTSIDE, np.uint8), beyond[keep], sigma[keep],
                direction[keep])


def _along(view: ViewPoints, index: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """The noise (metres) along unit `normal` (m, 3) of readings `index` of `view`: their depth noise along their
    rays and their lateral uncertainty across them."""
    cosine = np.einsum("ij,ij->i", normal, view.rays[index])
    return np.sqrt((view.sigma[index] * cosine) ** 2 + view.lateral[index] ** 2 * np.maximum(1 - cosine ** 2, 0))


def _bilinear(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """image (H, W) sampled bilinearly at uv (m, 2) pixel coordinates (clamped to the image) -> (m,) float64."""
    h, w = image.shape
    u, v = np.clip(uv[:, 0], 0, w - 1.001), np.clip(uv[:, 1], 0, h - 1.001)
    u0, v0 = u.astype(np.int64), v.astype(np.int64)
    fu, fv = u - u0, v - v0
    flat = image.reshape(-1).astype(np.float64)
    top = flat[v0 * w + u0] * (1 - fu) + flat[v0 * w + u0 + 1] * fu
    bottom = flat[(v0 + 1) * w + u0] * (1 - fu) + flat[(v0 + 1) * w + u0 + 1] * fu
    return top * (1 - fv) + bottom * fv


@dataclass(frozen=True, eq=False)
class FrameViews:
    """The views of one frame: `targets` {0: the camera, j: mirror j} for every view with readings; `centre` (3,)
    metres, the median of the direct readings (of all the object's points without any)."""

    targets: dict[int, TargetView]
    centre: np.ndarray

    def points(self, j: int) -> ViewPoints:
        return self.targets[j].view


def frame_views(rig: Rig, depth: np.ndarray, mask: np.ndarray) -> FrameViews:
    """A frame's views: depth (H, W) float metres as measured (not smoothed), mask (H, W) bool the object's pixels
    (mirrorcore.pipeline.prepare_frame's). Algorithm 1 (reconstruct_raw) on every reading says which view each pixel
    belongs to; mirrors without a plane have no view."""
    depth = np.asarray(depth, dtype=np.float32)
    scene = reconstruct_raw(rig, depth)
    labels = np.full(depth.size, -1, np.int64)
    labels[scene.pixel_index] = scene.sources
    labels = labels.reshape(depth.shape)
    mask = np.asarray(mask, bool) & (depth > 0)
    rim = cv2.dilate((~mask).view(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    targets = {}
    for j in range(len(rig.mirrors) + 1):
        mine = mask & (labels == j)
        if (j and rig.mirrors[j - 1].plane is None) or mine.sum() < MIN_NEIGHBOURS:
            continue
        view = view_points(rig.intrinsics, depth, np.flatnonzero(mine), rim)
        if len(view):
            free = (labels == j) & ~mask if j else (depth > 0) & ~mine
            targets[j] = TargetView(rig.intrinsics, view, mine, free)
    direct = targets[0].view.points if 0 in targets else scene.points[mask.reshape(-1)[scene.pixel_index]]
    centre = np.median(direct, axis=0) if len(direct) else np.zeros(3)
    return FrameViews(targets, np.asarray(centre, dtype=np.float64))


def surface_distances(rig: Rig, cloud: Cloud, depth: np.ndarray) -> np.ndarray:
    """For the heat map of a calibration: each point's signed distance (mm) to the surface the camera sees directly.

    rig : the rig whose planes made `cloud` (Algorithm 1) from `depth` (H, W) float metres -> (n,) float32 mm: > 0
    where a mirror's point lies outside the direct surface (in front of it, along its normal), < 0 inside; NaN for the
    direct points themselves and for mirror points with nothing to compare with (parts of the object that the camera
    does not see, readings too oblique or at a depth edge).
    """
    out = np.full(len(cloud), np.nan, dtype=np.float32)
    mask = np.zeros(rig.intrinsics.shape, bool)
    mask.reshape(-1)[cloud.pixel_index] = True
    views = frame_views(rig, depth, mask)
    if 0 not in views.targets:
        return out
    for j in views.targets:
        if j:
            found = views.targets[0].compare(views.points(j).reflected(rig.mirrors[j - 1].plane), SHOWN_GATE)
            near = found.kind != OUTSIDE
            pixels = views.points(j).pixels[found.index[near]]
            out[np.searchsorted(cloud.pixel_index, pixels)] = 1e3 * found.residual[near]
    return out
