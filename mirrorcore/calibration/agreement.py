"""The agreement of the views of a rig in one frame: how a point of one view compares with what
another view saw where the point would be; and, for a labelled cloud, each mirror point's distance
to the direct surface (the heat map of a calibration's quality).

A point P of view a, mapped into view b's space (reflected through mirror b's plane when b is a
mirror), falls on a pixel of the image. Where b has a reading there whose surface is P's (their
normals agree, P faces b, and the two surfaces are within a few standard deviations), the residual
is P's distance to the surface of that reading's neighbours (readings.py), along its normal,
evaluated where P falls: depth noise only when the planes are right. Anything else says nothing: b
saw nearer (P is hidden behind another part), cannot see there (outside the image or the mirror's
boundary, the real object in front of the glass, no reading), or saw a different surface (the front
of a part and its back).

A point falls where its neighbours' surface (its anchor) falls, so whether it is compared does not
depend on its own reading's noise. The anchor's error along P's ray moves that place along the
surface where the ray is oblique, and there the tangent of a curved surface passes beside P: on
average by -k sin^2(t) var / 2 (k the surface's curvature along the way, t the ray's incidence, var
the anchor's variance along its ray), inside a convex surface. That part is removed
(CURVATURE_STEP): it was 0.2 to 0.9 mm for each pair of views of the walking figure, whose limbs are
4 to 6 cm across, and is within +-0.2 mm after. Where P falls on a reading on the rim of the other
view's silhouette, the anchor's error may be all that puts it there, beside a surface the other view
does not see: such a comparison counts only when the anchor falls there within RIM_LANDING_PX (its
standard deviation along the ray, in pixels of the image).

Points are matched by pixel (projective association, as KinectFusion does), never with their nearest
neighbour in 3D, which prefers the readings that noise moved towards them and matches a point beside
the other view's silhouette with the silhouette.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mirrorcore.rig.cloud import Cloud
from mirrorcore.geometry.camera import Intrinsics, project_points
from mirrorcore.geometry.plane import Plane
from mirrorcore.calibration.readings import (MAX_INCIDENCE_DEG, MIN_NEIGHBOURS, ViewPoints,
                                             view_points)
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.rig.model import Rig

# a point agrees with a reading when their normals are within 45 degrees...
MIN_NORMAL_COSINE = 0.7
# ... and their surfaces within this many standard deviations of each other,
AGREE_SIGMAS = 3.0
# a neighbours' surface having this share of a reading's noise (wider windows let the walking
# figure's limbs compare with the wrong surfaces: 1.5 mm more bias at 0.5)
ANCHOR_NOISE = 0.3
# metres: distances shown (heat map, reports) count surfaces this far apart as the same
SHOWN_GATE = 0.03
# pixels: the heat map colours a point by the mean distance of its view's compared points in this
# window about it (one point's distance scatters with the depth noise, which would mottle correct
# planes red and blue at a 10 mm scale; on the sphere's true planes the window leaves 0 to 3 % of
# the points beyond 5 mm, single points 3 to 8 %)
HEAT_WINDOW = 7
# metres along a point's ray: the step of the second difference that measures the target surface's
# curvature where the anchor's error moves it (its quadratic: any step < 2 cm)
CURVATURE_STEP = 0.005
# pixels: how surely a point must fall on a reading on the rim of the other view to be compared with
# it (on the walking figure, noisy anchors admitted 12 % more comparisons than exact ones, 60 % of
# them there, 0.3 to 3 mm inside the surface; the planes from the truth -1.9 -> -1.4 mm, the
# sphere's unchanged; 0.75 px: -0.8 mm, but the sphere's +0.1 mm and the scatter 1.6 times larger)
RIM_LANDING_PX = 1.0


@dataclass(frozen=True, eq=False)
class Comparison:
    """Points of one view that agree with readings of another view.

    Attributes
    ----------
    index : (m,) int64 array
        Into the points.
    reading : (m,) int64 array
        Into the other view's readings: the one each point is compared with.
    residual : (m,) float64 array
        Metres, each point's signed distance to the other view's surface (> 0 outside it).
    sigma : (m,) float64 array
        Metres, the noise of the residual.
    direction : (m, 3) float64 array
        The residual's gradient with respect to the point, in the other view's space (the normal of
        its surface).
    """

    index: np.ndarray
    reading: np.ndarray
    residual: np.ndarray
    sigma: np.ndarray
    direction: np.ndarray

    def __len__(self) -> int:
        return len(self.index)


def in_view(seen: ViewPoints, plane: Plane | None) -> ViewPoints:
    """Map real points into the space of a view.

    Parameters
    ----------
    seen : ViewPoints
        Real points.
    plane : Plane or None
        The mirror's plane the points are reflected through; None for the camera (as they are).

    Returns
    -------
    ViewPoints
    """
    return seen if plane is None else seen.reflected(plane)


class TargetView:
    """What one view saw in a frame, in its own space, for comparing other views' points with it.

    Its space is the camera frame for the camera, its mirror image for a mirror (`in_view` maps
    points there). It holds its readings and, per pixel of the image, the reading there (-1 for
    none).

    Parameters
    ----------
    intrinsics : Intrinsics
    view : ViewPoints
        The view's readings, in its own space.
    """

    def __init__(self, intrinsics: Intrinsics, view: ViewPoints):
        self.intrinsics, self.view = intrinsics, view
        self.index = np.full(intrinsics.width * intrinsics.height, -1, dtype=np.int64)
        self.index[view.pixels] = np.arange(len(view))

    def compare(self, mapped: ViewPoints, gate: float = 0.0) -> Comparison:
        """Compare points with this view's readings (see the module docstring).

        Parameters
        ----------
        mapped : ViewPoints
            Points in this view's space (`in_view`), normals out of the object.
        gate : float
            Metres that widen what counts as the same surface while the planes may still be far off.

        Returns
        -------
        Comparison
        """
        uv, z = project_points(self.intrinsics, mapped.anchors)
        u, v = np.round(np.nan_to_num(uv, nan=-1.0)).T.astype(np.int64)
        inside = np.flatnonzero((z > 0) & (u >= 0) & (u < self.intrinsics.width) & (v >= 0)
                                & (v < self.intrinsics.height))
        reading = self.index[v[inside] * self.intrinsics.width + u[inside]]
        index, reading, uv = inside[reading >= 0], reading[reading >= 0], uv[inside[reading >= 0]]
        target = self.view
        normal, theirs = target.normals[reading], mapped.normals[index]
        facing = ((np.einsum("ij,ij->i", normal, theirs) > MIN_NORMAL_COSINE)
                  & (-np.einsum("ij,ij->i", theirs,
                                target.rays[reading]) > np.cos(np.radians(MAX_INCIDENCE_DEG))))
        index, reading, uv, normal = index[facing], reading[facing], uv[facing], normal[facing]
        surface = target.surface_points(self.intrinsics, reading, uv)
        sigma = np.hypot(_along(target, reading, normal), _along(mapped, index, normal))
        # > 0: in front of the surface
        offset = np.einsum("ij,ij->i", normal, mapped.anchors[index] - surface)
        velocity = self._velocity(mapped, index)
        agree = ((np.abs(offset) <= AGREE_SIGMAS * ANCHOR_NOISE * sigma + gate)
                 & (~target.rim[reading]
                    | (np.sqrt(mapped.anchor_var[index]) * np.hypot(
                        *velocity.T) <= RIM_LANDING_PX)))
        index, normal, reading, uv, surface, velocity = (
            a[agree] for a in (index, normal, reading, uv, surface, velocity))
        residual = np.einsum("ij,ij->i", normal, mapped.points[index] - surface)
        residual -= 0.5 * mapped.anchor_var[index] * self._curvature(
            reading, uv, surface, normal, velocity)
        return Comparison(index, reading, residual, sigma[agree], normal)

    def _velocity(self, mapped: ViewPoints, index: np.ndarray) -> np.ndarray:
        """(m, 2) pixels per metre: how fast the anchors of points `index` (m,) of `mapped` move
        across the image as they move along their rays."""
        anchors, rays = mapped.anchors[index], mapped.rays[index]
        return np.column_stack([self.intrinsics.fx * (rays[:, 0] * anchors[:, 2] - anchors[
            :, 0] * rays[:, 2]),
                                self.intrinsics.fy * (rays[:, 1] * anchors[:, 2] - anchors[
                                    :, 1] * rays[:, 2])]
                               ) / anchors[:, 2:] ** 2

    def _curvature(self, reading: np.ndarray, uv: np.ndarray, surface: np.ndarray,
                   normal: np.ndarray,
                   velocity: np.ndarray) -> np.ndarray:
        """(m,) 1/metres: the second derivative, along `normal` (m, 3), of the surface of readings
        `reading` (m,) where points' anchors would fall if they moved along their rays from where
        they fall now (uv (m, 2) pixels, on `surface` (m, 3) metres; `velocity` (m, 2) pixels per
        metre, _velocity): the residual's curvature in the anchor's error."""
        step = CURVATURE_STEP * velocity                                  # pixels
        ahead, behind = (self.view.surface_points(self.intrinsics, reading, uv + sign * step)
                         for sign in (1, -1))
        return np.einsum("ij,ij->i", normal, ahead + behind - 2 * surface) / CURVATURE_STEP ** 2


def _along(view: ViewPoints, index: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """The noise (metres) along unit `normal` (m, 3) of readings `index` of `view`: their depth
    noise along their rays and their lateral uncertainty across them."""
    cosine = np.einsum("ij,ij->i", normal, view.rays[index])
    return np.sqrt((view.sigma[index] * cosine) ** 2 + view.lateral[index] ** 2 * np.maximum(
        1 - cosine ** 2, 0))


@dataclass(frozen=True, eq=False)
class FrameViews:
    """The views of one frame.

    Attributes
    ----------
    targets : dict of int to TargetView
        {0: the camera, j: mirror j} for every view with readings.
    centre : (3,) array
        Metres, the median of the direct readings (of all the object's points without any).
    """

    targets: dict[int, TargetView]
    centre: np.ndarray

    def points(self, j: int) -> ViewPoints:
        """Return the readings of a view, in its own space.

        Parameters
        ----------
        j : int
            0 the camera, j mirror j.

        Returns
        -------
        ViewPoints
        """
        return self.targets[j].view


def frame_views(rig: Rig, depth: np.ndarray, mask: np.ndarray) -> FrameViews:
    """Return a frame's views.

    Algorithm 1 (reconstruct_raw) says which view each of the object's pixels belongs to; mirrors
    without a plane have no view.

    Parameters
    ----------
    rig : Rig
    depth : (H, W) float array
        Metres as measured (not smoothed).
    mask : (H, W) bool array
        The object's pixels (mirrorcore.rig.pipeline.prepare_frame's).

    Returns
    -------
    FrameViews
    """
    depth = np.asarray(depth, dtype=np.float32)
    mask = np.asarray(mask, bool) & (depth > 0)
    cloud = reconstruct_raw(rig, depth, mask)
    labels = np.full(depth.size, -1, np.int64)
    labels[cloud.pixel_index] = cloud.sources
    labels = labels.reshape(depth.shape)
    rim = cv2.dilate((~mask).view(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    targets = {}
    for j in range(len(rig.mirrors) + 1):
        mine = mask & (labels == j)
        if (j and rig.mirrors[j - 1].plane is None) or mine.sum() < MIN_NEIGHBOURS:
            continue
        view = view_points(rig.intrinsics, depth, np.flatnonzero(mine), rim)
        if len(view):
            targets[j] = TargetView(rig.intrinsics, view)
    direct = targets[0].view.points if 0 in targets else cloud.points
    centre = np.median(direct, axis=0) if len(direct) else np.zeros(3)
    return FrameViews(targets, np.asarray(centre, dtype=np.float64))


def surface_distances(rig: Rig, cloud: Cloud, depth: np.ndarray) -> np.ndarray:
    """Measure each point's signed distance to the surface the camera sees directly (the heat map).

    Parameters
    ----------
    rig : Rig
        The rig whose planes made `cloud` (Algorithm 1) from `depth`.
    cloud : Cloud
    depth : (H, W) float array
        Metres.

    Returns
    -------
    (n,) float32 array
        mm: > 0 where a mirror's point lies outside the direct surface (in front of it, along its
        normal), < 0 inside; NaN for the direct points themselves and for mirror points with nothing
        to compare with (parts of the object that the camera does not see, readings too oblique or
        at a depth edge).
    """
    out = np.full(len(cloud), np.nan, dtype=np.float32)
    mask = np.zeros(rig.intrinsics.shape, bool)
    mask.reshape(-1)[cloud.pixel_index] = True
    views = frame_views(rig, depth, mask)
    if 0 not in views.targets:
        return out
    for j in views.targets:
        if j:
            found = views.targets[0].compare(views.points(j).reflected(rig.mirrors[j - 1].plane),
                                             SHOWN_GATE)
            pixels = views.points(j).pixels[found.index]
            out[np.searchsorted(cloud.pixel_index, pixels)] = 1e3 * found.residual
    return out


def local_means(values: np.ndarray, pixel_index: np.ndarray, sources: np.ndarray,
                shape: tuple[int, int],
                size: int = HEAT_WINDOW) -> np.ndarray:
    """Replace each finite value by the mean of its own source's finite values around its pixel.

    Over the size x size pixels about its pixel; NaN stays NaN.

    Parameters
    ----------
    values : (n,) float array
    pixel_index : (n,) integer array
        Flat indices into an image of `shape` (one point a pixel).
    sources : (n,) integer array
        Labels.
    shape : (int, int)
        (H, W).
    size : int
        Pixels, the window's side.

    Returns
    -------
    (n,) float32 array
    """
    values, sources = np.asarray(values, np.float32), np.asarray(sources)
    out = np.full(len(values), np.nan, np.float32)
    finite = np.isfinite(values)
    for label in np.unique(sources[finite]):             # a few views a frame
        pick = finite & (sources == label)
        pixels = np.asarray(pixel_index)[pick]
        total, count = np.zeros(shape, np.float32), np.zeros(shape, np.float32)
        total.reshape(-1)[pixels], count.reshape(-1)[pixels] = values[pick], 1.0
        total, count = (cv2.boxFilter(image, -1, (size, size), normalize=False,
                                      borderType=cv2.BORDER_CONSTANT)
                        for image in (total, count))
        out[pick] = total.reshape(-1)[pixels] / count.reshape(-1)[pixels]
    return out


def heat_figures(distances: np.ndarray, sources: np.ndarray) -> dict[int, tuple[float, float]]:
    """Return, per view seen in a mirror, what the heat map shows.

    Parameters
    ----------
    distances : (n,) float array
        mm, as `surface_distances` gives them.
    sources : (n,) integer array
        Their labels.

    Returns
    -------
    dict of int to (float, float)
        {source label: (median distance mm to the direct surface, NaN when none is compared; the
        share of its points compared, 0 to 1)}.
    """
    distances, sources = np.asarray(distances, dtype=np.float64), np.asarray(sources)
    figures = {}
    for label in np.unique(sources[sources != 0]):
        mine = distances[sources == label]
        compared = mine[np.isfinite(mine)]
        figures[int(label)] = (float(np.median(compared)) if len(compared) else float("nan"),
                               len(compared) / len(mine))
    return figures
