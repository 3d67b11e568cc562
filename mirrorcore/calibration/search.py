"""The search for a mirror's plane without markers: in one frame where something is seen both
directly and in a mirror, the plane that makes the two views consistent (scene.py then refines it).

A candidate plane reflects the mirror's view of the object (its virtual points) into the room, and
the camera's view into the mirror's: a reflected point agrees when the other view measured about its
depth where it falls, and contradicts it when that view saw farther (it would have seen the point).
The score is agreements minus contradictions; the search tries a cone of normals around the
direction from the virtual object to the real one (their medians: the plane is about their
perpendicular bisector) and a range of offsets, coarse then fine. Mirrors calibrated already are
views like the camera's (scene.calibrate_scene finds the mirrors in rounds).
"""
from __future__ import annotations

from typing import NamedTuple

import cv2
import numpy as np

from mirrorcore.base.errors import CalibrationError, Cancelled
from mirrorcore.geometry.camera import reproject_depth
from mirrorcore.geometry.plane import Plane
from mirrorcore.depth.noise import axial_sigma
from mirrorcore.base.progress import Progress, Ratchet, cancel_requested
from mirrorcore.rig.model import Rig

SEARCH_POINTS = 800                  # points of each view scored (a random subset)
MIN_POINTS = 100                     # the object's readings needed in each view
CONE_DEG = 20.0                      # normals tried, around the bisector's
OFFSETS = 0.15                       # metres tried either side of the bisector
# a wide search (a mirror searched again, against the mirrors found before it): degrees and metres
# tried, and its coarse candidates scored on this many points of each view (the first of
# SEARCH_POINTS). An arc's middle mirror sees the upper back of the walking figure, the camera all
# of its front: the bisector of their medians is 18 to 20 degrees and 0.2 to 0.27 m off its plane
WIDE = (35.0, 0.5, 300)
# degrees between normals, metres between offsets, tolerance of agreement (m)
COARSE = (2.0, 0.02, 0.03)
FINE = (0.5, 0.005, 0.01)
KEEP = 5                             # coarse candidates refined finely
# of a search's progress: the coarse candidates (about 0.6 of its time)
COARSE_PART = 0.6
BATCH = 256                          # candidates scored at once
# metres beyond the direct object's depth where its mirror image starts
FAR_MARGIN = 0.02
# pixels around a mirror's outline where readings beyond the direct object are its image spilling
# over the outline
SPILL_PX = 15
# metres: a gap in the depths seen outside the outlines beyond which an image lies (an outline drawn
# too narrow leaves part of it outside; the Kinect's depth steps are 25 to 35 mm at 3 to 3.5 m)
IMAGE_GAP = 0.1
# a reflected point agrees within this many standard deviations of depth noise
AGREE_SIGMAS = 3.0
CONTRADICTION_WEIGHT = 2.0             # a contradiction counts as much as two agreements
# Metres: a found plane is moved this much towards the camera before the refinement, which comes
# back with scene.SEARCH_GATE from planes 4 cm too near and 2 cm too far, not from 4 cm too far
# (the mirror's points then hide behind the object).
NEARER = 0.02

class Found(NamedTuple):
    """A searched plane, and how well it explains the frame.

    Attributes
    ----------
    plane : Plane
    support : float
        The best candidate's score (_Scorer.scores: the share of the points scored that agree, less
        twice the share contradicted, summed over the ways compared).
    """

    plane: Plane
    support: float


def search_plane(rig: Rig, depth: np.ndarray, mask: np.ndarray, index: int,
                 rng: np.random.Generator,
                 cancel=None, wide: bool = False, progress: Progress | None = None) -> Found:
    """Find the plane of a mirror that best explains one frame.

    The candidates are scored against the camera's view (the object's pixels outside every mirror's
    boundary) and the views of the rig's other mirrors that have a plane (an arc's middle mirror
    sees the person's back, which the camera does not see, and the sides that the mirrors beside it
    see).

    Parameters
    ----------
    rig : Rig
    depth : (H, W) float array
        Metres.
    mask : (H, W) bool array
        The object's pixels (prepare_frame's).
    index : int
        The mirror (0-based); its boundary drawn, its plane ignored.
    rng : numpy.random.Generator
    cancel : optional
        Stops the search with Cancelled when it asks to.
    wide : bool
        Search a wider range of planes (WIDE).
    progress : Progress, optional
        progress(fraction) as the candidates are scored (the coarse ones COARSE_PART of it).

    Returns
    -------
    Found

    Raises
    ------
    CalibrationError
        Naming the mirror when it has no boundary or the object is not seen both directly and in
        it.
    """
    mirror = rig.mirrors[index]
    if mirror.boundary is None:
        raise CalibrationError(f"{mirror.name}: no boundary; draw the mirror's outline first",
                               (mirror.name,))
    depth = np.asarray(depth, np.float32)
    far = direct_far(depth[mask & (rig.inside_bits == 0)])
    outside = mask & (rig.inside_bits == 0) & (depth <= far)
    inside = _inside(rig, index)
    _check_outline(mirror.name, inside, mask & (rig.inside_bits == 0) & (depth > far))
    direct = reproject_depth(rig.intrinsics, depth, outside)[0].astype(np.float64)
    # in the mirror's outline, the object's readings beyond everything seen directly are its image
    # (the real object in front of the glass is as near as the rest of it)
    here = mask & inside & (depth > far)
    virtual = reproject_depth(rig.intrinsics, depth, here)[0].astype(np.float64)
    if len(direct) < MIN_POINTS:
        within = int(np.count_nonzero(mask & (rig.inside_bits != 0) & (depth > 0)))
        raise CalibrationError(
            f"{mirror.name}: the object is not seen directly outside the mirrors' outlines in this "
                               f"frame ({len(direct)} readings there, {MIN_POINTS} needed; "
                               f"{within} more inside the "
                               "outlines, where the search cannot tell the object from its "
                               "images): move the object "
                               "so that the camera sees part of it beside the mirrors, or click "
                               "markers on this mirror",
                               (mirror.name,))
    if len(virtual) < MIN_POINTS:
        raise CalibrationError(
            f"{mirror.name}: the object is not seen in the mirror in this frame ({len(virtual)} "
                               "readings inside its outline beyond what the camera sees directly, "
                               f"{MIN_POINTS} "
                               "needed): move the object so that the mirror shows it, or check the "
                               "mirror's outline",
                               (mirror.name,))
    views = [_View(None, None, outside.reshape(-1), _subset(direct, rng))]
    views += _mirror_views(rig, depth, mask & (depth > far), index, rng)
    scorer = _Scorer(rig.intrinsics, depth, inside, here, _subset(virtual, rng), views)
    real, image = np.median(direct, axis=0), np.median(virtual, axis=0)
    axis = (real - image) / np.linalg.norm(real - image)
    middle = (real + image) / 2
    cone, offsets, points = WIDE if wide else (CONE_DEG, OFFSETS, SEARCH_POINTS)
    coarse = _candidates(axis, middle, cone, offsets, COARSE)
    bar = Ratchet(progress)
    scores = scorer.scores(coarse, COARSE[2], cancel, points, bar.part(0.0, COARSE_PART))
    best = []
    for k in np.argsort(scores)[::-1][:KEEP]:
        n, d = coarse[k, :3], coarse[k, 3]
        fine = _candidates(n, -d * n, COARSE[0], COARSE[1], FINE)
        part = bar.part(COARSE_PART + (1 - COARSE_PART) * len(best) / KEEP,
                        COARSE_PART + (1 - COARSE_PART) * (len(best) + 1) / KEEP)
        fine_scores = scorer.scores(fine, FINE[2], cancel, progress=part)
        best.append((fine_scores.max(), fine[np.argmax(fine_scores)]))
    support, abcd = max(best, key=lambda b: b[0])
    try:
        return Found(Plane.from_abcd(abcd - [0, 0, 0, NEARER], mirror.name), float(support))
    except CalibrationError:
        raise CalibrationError(
            f"{mirror.name}: no plane found that puts the camera in front of the mirror",
                               (mirror.name,)) from None


def _inside(rig: Rig, index: int) -> np.ndarray:
    """(H, W) bool: the pixels inside mirror `index`'s boundary (0-based)."""
    return ((rig.inside_bits >> np.uint32(index)) & np.uint32(1)).astype(bool)


def _mirror_views(rig: Rig, depth: np.ndarray, beyond: np.ndarray, index: int,
                  rng: np.random.Generator
                  ) -> list["_View"]:
    """The views of the rig's mirrors other than `index` that have a plane and a boundary, each with
    at least MIN_POINTS of the object's readings `beyond` (H, W) bool (beyond what the camera sees
    directly) inside it."""
    views = []
    for k, other in enumerate(rig.mirrors):
        if k == index or other.plane is None or other.boundary is None:
            continue
        field = _inside(rig, k)
        seen = beyond & field
        points = reproject_depth(rig.intrinsics, depth, seen)[0].astype(np.float64)
        if len(points) >= MIN_POINTS:
            views.append(_View(other.plane.abcd, field.reshape(-1), seen.reshape(-1),
                               other.plane.reflect(_subset(points, rng))))
    return views


def _check_outline(name: str, inside: np.ndarray, beyond: np.ndarray) -> None:
    """Refuse, naming the mirror, when MIN_POINTS of the object's readings beyond the direct object
    (beyond: (H, W) bool, outside every outline) lie within SPILL_PX of the mirror's outline
    (inside: (H, W) bool): its image spills over an outline drawn too narrow, and those readings
    would be taken for the object seen directly."""
    spilled = int(np.count_nonzero(beyond & near_outline(inside)))
    if spilled >= MIN_POINTS:
        raise CalibrationError(
            f"{name}: {spilled} readings just outside its outline lie beyond the "
                               "object seen directly: its image spills over the outline; draw the "
                               "outline along the glass's edge", (name,))


def near_outline(inside: np.ndarray) -> np.ndarray:
    """Return the pixels within SPILL_PX of `inside`, and those pixels themselves.

    Parameters
    ----------
    inside : (H, W) bool array

    Returns
    -------
    (H, W) bool array
    """
    kernel = np.ones((2 * SPILL_PX + 1, 2 * SPILL_PX + 1), np.uint8)
    return cv2.dilate(inside.astype(np.uint8), kernel).astype(bool)


def direct_far(z: np.ndarray) -> float:
    """Return the depth beyond which the object's readings outside every outline are an image.

    That is FAR_MARGIN beyond the 99th percentile of the readings up to the first gap of IMAGE_GAP
    above their median (an outline drawn too narrow leaves part of the mirror's image outside,
    which must not raise the cut above the whole image).

    Parameters
    ----------
    z : (n,) array
        Metres, the readings outside every outline.

    Returns
    -------
    float
        Metres; inf without readings.
    """
    z = np.sort(z[z > 0])
    if not len(z):
        return np.inf
    middle = len(z) // 2
    gaps = np.flatnonzero(np.diff(z[middle:]) > IMAGE_GAP)
    return float(np.percentile(z[:middle + gaps[0] + 1] if len(gaps) else z, 99)) + FAR_MARGIN


def _subset(points: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """At most SEARCH_POINTS of `points`, drawn without replacement."""
    return points[rng.choice(len(points), SEARCH_POINTS,
                             replace=False)] if len(points) > SEARCH_POINTS else points


def _candidates(axis: np.ndarray, point: np.ndarray, cone_deg: float, offsets: float,
                step: tuple) -> np.ndarray:
    """(k, 4) planes [n, d]: unit normals within cone_deg of `axis` (a square grid of tilts, step[0]
    degrees apart) and, for each, offsets every step[1] metres within `offsets` of the plane through
    `point` (3,)."""
    e1 = np.cross(axis, np.eye(3)[int(np.argmin(np.abs(axis)))])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    tilts = np.radians(np.arange(-cone_deg, cone_deg + 1e-9, step[0]))
    a, b = (t.reshape(-1) for t in np.meshgrid(tilts, tilts))
    keep = np.hypot(a, b) <= np.radians(cone_deg) + 1e-9
    normals = axis + np.tan(a[keep])[:, None] * e1 + np.tan(b[keep])[:, None] * e2
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    shifts = np.arange(-offsets, offsets + 1e-9, step[1])
    d = -(normals @ point)[:, None] - shifts[None, :]
    return np.column_stack([np.repeat(normals, len(shifts), axis=0), d.reshape(-1)])


class _View(NamedTuple):
    """A calibrated view a candidate plane is scored against: `plane` (4,) [n, d], the mirror that
    shows it (None: the camera itself); `field` (H * W,) bool, its pixels (None: the whole image);
    `objects` (H * W,) bool, the object's pixels in it; `points` (m, 3) metres, a subset of its
    readings of the object, in the room."""

    plane: np.ndarray | None
    field: np.ndarray | None
    objects: np.ndarray
    points: np.ndarray


class _Scorer:
    """Scores candidate planes of one mirror against one frame (see the module docstring): its
    points (the object's images in the mirror) against each calibrated view, and each view's points
    against the mirror's readings."""

    def __init__(self, intr, depth: np.ndarray, inside: np.ndarray, virtual: np.ndarray,
                 virtual_points: np.ndarray, views: list[_View]):
        self.intr = intr
        self.depth = depth.reshape(-1)
        self.mirror = _View(None, inside.reshape(-1), virtual.reshape(-1), virtual_points)
        self.views = views

    def scores(self, planes: np.ndarray, tolerance: float, cancel, points: int = SEARCH_POINTS,
               progress: Progress | None = None) -> np.ndarray:
        """Score candidate planes: agreements minus twice the contradictions, as a share.

        Both ways with each view, as a share of the points scored: the first `points` of each
        view's; progress(fraction) after each BATCH of candidates. Returns (k,) scores.
        """
        out = np.zeros(len(planes))
        for start in range(0, len(planes), BATCH):
            if cancel_requested(cancel):
                raise Cancelled("search cancelled")
            batch = planes[start:start + BATCH]
            for view in self.views:
                out[start:start + BATCH] += (self._one_way(self.mirror.points[:points], batch,
                                                           tolerance, view)
                                             + self._one_way(view.points[
                                                 :points], batch, tolerance, self.mirror))
            if progress is not None:
                progress(min(start + BATCH, len(planes)) / len(planes))
        return out

    def _one_way(self, points: np.ndarray, planes: np.ndarray, tolerance: float,
                 view: _View) -> np.ndarray:
        """points (m, 3) reflected through each plane (k, 4) and seen in `view` (through its mirror,
        if any), compared with the depth where they fall: agreeing on its object's pixels,
        contradicted where it (its field of pixels) saw farther."""
        n, d = planes[:, None, :3], planes[:, None, 3]
        # (k, m, 3)
        reflected = points[None] - 2 * (points[None] @ n.transpose(0, 2, 1) + d[..., None]) * n
        if view.plane is not None:
            reflected = reflected - 2 * (reflected @ view.plane[:3] + view.plane[3])[
                ..., None] * view.plane[:3]
        z = reflected[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.round(self.intr.fx * reflected[..., 0] / z + self.intr.cx)
            v = np.round(self.intr.fy * reflected[..., 1] / z + self.intr.cy)
        inside = (z > 0) & (u >= 0) & (u < self.intr.width) & (v >= 0) & (v < self.intr.height)
        pixel = np.where(inside, v * self.intr.width + u, 0).astype(np.int64)
        measured = self.depth[pixel]
        seen = inside & (measured > 0) & (True if view.field is None else view.field[pixel])
        margin = tolerance + AGREE_SIGMAS * axial_sigma(np.where(seen, measured, 1.0))
        agree = seen & view.objects[pixel] & (np.abs(measured - z) < margin)
        contradict = seen & (measured > z + margin)
        return (agree.sum(axis=1) - CONTRADICTION_WEIGHT * contradict.sum(axis=1)) / points.shape[0]
