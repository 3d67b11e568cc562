"""Mirror planes without markers (`calibrate --method scene`): in one frame where something is seen both directly and
in a mirror, search for the plane that makes the two views consistent, then refine (refine.py).

A candidate plane reflects the mirror's view of the object (its virtual points) into the room, and the camera's view
into the mirror's: a reflected point agrees when the other view measured about its depth where it falls, and
contradicts it when that view saw farther (it would have seen the point). The score is agreements minus
contradictions; the search tries a cone of normals around the direction from the virtual object to the real one
(their medians: the plane is about their perpendicular bisector) and a range of offsets, coarse then fine.
"""
from __future__ import annotations

from dataclasses import replace

import cv2
import numpy as np

from .errors import CalibrationError, Cancelled
from .geometry.camera import reproject_depth
from .geometry.plane import Plane
from .noise import axial_sigma
from .progress import Progress, cancel_requested
from .refine import MAX_DISAGREEMENT, Leash, Refinement, refine_session
from .rig import Mirror, Rig
from .session import Session

SEARCH_POINTS = 800                  # points of each view scored (a random subset)
MIN_POINTS = 100                     # the object's readings needed in each view
CONE_DEG = 20.0                      # normals tried, around the bisector's
OFFSETS = 0.15                       # metres tried either side of the bisector
COARSE = (2.0, 0.02, 0.03)           # degrees between normals, metres between offsets, tolerance of agreement (m)
FINE = (0.5, 0.005, 0.01)
KEEP = 5                             # coarse candidates refined finely
BATCH = 256                          # candidates scored at once
FAR_MARGIN = 0.02                    # metres beyond the direct object's depth where its mirror image starts
SPILL_PX = 15                        # pixels around a mirror's outline where readings beyond the direct object are
                                     # its image spilling over the outline
IMAGE_GAP = 0.1                      # metres: a gap in the depths seen outside the outlines beyond which an image
                                     # lies (an outline drawn too narrow leaves part of it outside; the Kinect's
                                     # depth steps are 25 to 35 mm at 3 to 3.5 m)
AGREE_SIGMAS = 3.0                   # a reflected point agrees within this many standard deviations of depth noise
CONTRADICTION_WEIGHT = 2.0             # a contradiction counts as much as two agreements
SEARCH_GATE = 0.03                   # metres: the refinement after a search starts with this wide agreement...
NEARER = 0.02                        # ... from the found plane moved this much towards the camera: with that gate it
                                     # came back from planes 4 cm too near and 2 cm too far, not 4 cm too far (the
                                     # mirror's points then hide behind the object)
SEARCH_CHANGE = (0.2, 15.0)          # metres, degrees: how far the refinement may move a searched plane
FROM_SEARCH = Leash(SEARCH_GATE, SEARCH_CHANGE, MAX_DISAGREEMENT, camera_only=True)   # the refinement after it


def search_plane(rig: Rig, depth: np.ndarray, mask: np.ndarray, index: int, rng: np.random.Generator,
                 cancel=None) -> Plane:
    """The plane of mirror `index` (0-based; its boundary drawn, its plane ignored) that best explains one frame.

    depth : (H, W) float metres; mask : (H, W) bool, the object's pixels (prepare_frame's). The camera's view is the
    object's pixels outside every mirror's boundary. Raises CalibrationError naming the mirror when it has no
    boundary or the object is not seen both directly and in it.
    """
    mirror = rig.mirrors[index]
    if mirror.boundary is None:
        raise CalibrationError(f"{mirror.name}: no boundary; draw the mirror's outline first")
    depth = np.asarray(depth, np.float32)
    far = _direct_far(depth[mask & (rig.inside_bits == 0)])
    outside = mask & (rig.inside_bits == 0) & (depth <= far)
    inside = ((rig.inside_bits >> np.uint32(index)) & np.uint32(1)).astype(bool)
    _check_outline(mirror.name, inside, mask & (rig.inside_bits == 0) & (depth > far))
    direct = reproject_depth(rig.intrinsics, depth, outside)[0].astype(np.float64)
    # in the mirror's outline, the object's readings beyond everything seen directly are its image (the real object
    # in front of the glass is as near as the rest of it)
    here = mask & inside & (depth > far)
    virtual = reproject_depth(rig.intrinsics, depth, here)[0].astype(np.float64)
    if len(direct) < MIN_POINTS:
        within = int(np.count_nonzero(mask & (rig.inside_bits != 0) & (depth > 0)))
        raise CalibrationError(f"{mirror.name}: the object is not seen directly outside the mirrors' outlines in this "
                               f"frame ({len(direct)} readings there, {MIN_POINTS} needed; {within} more inside the "
                               "outlines, where the search cannot tell the object from its images): move the object "
                               "so that the camera sees part of it beside the mirrors, or click markers on this mirror")
    if len(virtual) < MIN_POINTS:
        raise CalibrationError(f"{mirror.name}: the object is not seen in the mirror in this frame ({len(virtual)} "
                               f"readings inside its outline beyond what the camera sees directly, {MIN_POINTS} "
                               "needed): move the object so that the mirror shows it, or check the mirror's outline")
    scorer = _Scorer(rig, depth, outside, here, index, _subset(direct, rng), _subset(virtual, rng))
    real, image = np.median(direct, axis=0), np.median(virtual, axis=0)
    axis = (real - image) / np.linalg.norm(real - image)
    middle = (real + image) / 2
    coarse = _candidates(axis, middle, CONE_DEG, OFFSETS, COARSE)
    scores = scorer.scores(coarse, COARSE[2], cancel)
    best = []
    for k in np.argsort(scores)[::-1][:KEEP]:
        n, d = coarse[k, :3], coarse[k, 3]
        fine = _candidates(n, -d * n, COARSE[0], COARSE[1], FINE)
        fine_scores = scorer.scores(fine, FINE[2], cancel)
        best.append((fine_scores.max(), fine[np.argmax(fine_scores)]))
    _, abcd = max(best, key=lambda b: b[0])
    try:
        return Plane.from_abcd(abcd - [0, 0, 0, NEARER], mirror.name)
    except CalibrationError:
        raise CalibrationError(f"{mirror.name}: no plane found that puts the camera in front of the mirror") from None


def _check_outline(name: str, inside: np.ndarray, beyond: np.ndarray) -> None:
    """Refuse, naming the mirror, when MIN_POINTS of the object's readings beyond the direct object (beyond: (H, W)
    bool, outside every outline) lie within SPILL_PX of the mirror's outline (inside: (H, W) bool): its image spills
    over an outline drawn too narrow, and those readings would be taken for the object seen directly (a helper's
    outline a third too narrow: the search said the mirror did not show the object)."""
    kernel = np.ones((2 * SPILL_PX + 1, 2 * SPILL_PX + 1), np.uint8)
    spilled = int(np.count_nonzero(beyond & cv2.dilate(inside.astype(np.uint8), kernel).astype(bool)))
    if spilled >= MIN_POINTS:
        raise CalibrationError(f"{name}: {spilled} readings just outside its outline lie beyond the object seen "
                               "directly: its image spills over the outline; draw the outline along the glass's edge")


def _direct_far(z: np.ndarray) -> float:
    """Metres: the depth beyond which the object's readings outside every outline (z (n,) metres) are an image, not
    the object seen directly: FAR_MARGIN beyond the 99th percentile of those up to the first gap of IMAGE_GAP above
    their median (an outline drawn too narrow leaves part of the mirror's image outside: it had raised the cut above
    the whole image, and the search said the mirror did not show the object: a helper); inf without readings."""
    z = np.sort(z[z > 0])
    if not len(z):
        return np.inf
    middle = len(z) // 2
    gaps = np.flatnonzero(np.diff(z[middle:]) > IMAGE_GAP)
    return float(np.percentile(z[:middle + gaps[0] + 1] if len(gaps) else z, 99)) + FAR_MARGIN


def _subset(points: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    return points[rng.choice(len(points), SEARCH_POINTS, replace=False)] if len(points) > SEARCH_POINTS else points


def _candidates(axis: np.ndarray, point: np.ndarray, cone_deg: float, offsets: float, step: tuple) -> np.ndarray:
    """(k, 4) planes [n, d]: unit normals within cone_deg of `axis` (a square grid of tilts, step[0] degrees apart)
    and, for each, offsets every step[1] metres within `offsets` of the plane through `point` (3,)."""
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


class _Scorer:
    """Scores candidate planes of one mirror against one frame (see the module docstring)."""

    def __init__(self, rig: Rig, depth: np.ndarray, direct: np.ndarray, virtual: np.ndarray, index: int,
                 direct_points: np.ndarray, virtual_points: np.ndarray):
        self.intr = rig.intrinsics
        self.depth = depth.reshape(-1)
        self.direct_object = direct.reshape(-1)
        self.mirror = ((rig.inside_bits >> np.uint32(index)) & np.uint32(1)).astype(bool).reshape(-1)
        self.mirror_object = virtual.reshape(-1)
        self.points = (direct_points, virtual_points)

    def scores(self, planes: np.ndarray, tolerance: float, cancel) -> np.ndarray:
        """(k,) agreements minus twice the contradictions, both ways, as a share of the points scored."""
        out = np.empty(len(planes))
        for start in range(0, len(planes), BATCH):
            if cancel_requested(cancel):
                raise Cancelled("search cancelled")
            batch = planes[start:start + BATCH]
            direct, virtual = self.points
            out[start:start + BATCH] = (self._one_way(virtual, batch, tolerance, self.direct_object, None)
                                        + self._one_way(direct, batch, tolerance, self.mirror_object, self.mirror))
        return out

    def _one_way(self, points: np.ndarray, planes: np.ndarray, tolerance: float, objects: np.ndarray,
                 field: np.ndarray | None) -> np.ndarray:
        """points (m, 3) reflected through each plane (k, 4), compared with the depth where they fall: agreeing on
        `objects` pixels, contradicted where the view (its `field` of pixels; None: anywhere) saw farther."""
        n, d = planes[:, None, :3], planes[:, None, 3]
        reflected = points[None] - 2 * (points[None] @ n.transpose(0, 2, 1) + d[..., None]) * n   # (k, m, 3)
        z = reflected[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.round(self.intr.fx * reflected[..., 0] / z + self.intr.cx)
            v = np.round(self.intr.fy * reflected[..., 1] / z + self.intr.cy)
        inside = (z > 0) & (u >= 0) & (u < self.intr.width) & (v >= 0) & (v < self.intr.height)
        pixel = np.where(inside, v * self.intr.width + u, 0).astype(np.int64)
        measured = self.depth[pixel]
        seen = inside & (measured > 0) & (True if field is None else field[pixel])
        margin = tolerance + AGREE_SIGMAS * axial_sigma(np.where(seen, measured, 1.0))
        agree = seen & objects[pixel] & (np.abs(measured - z) < margin)
        contradict = seen & (measured > z + margin)
        return (agree.sum(axis=1) - CONTRADICTION_WEIGHT * contradict.sum(axis=1)) / points.shape[0]


def calibrate_scene(session: Session, depths: np.ndarray, masks: np.ndarray, rng: np.random.Generator,
                    indices=None, progress: Progress | None = None, cancel=None, with_: str = "auto"
                    ) -> tuple[Session, Refinement]:
    """Calibrate a session's mirrors (all, or those at `indices`, 0-based) without markers: search each plane in the
    first frame (search_plane, ignoring any plane they had), then refine them all over every frame
    (refine.refine_session, comparing `with_`). depths (F, H, W) float metres as measured; masks (F, H, W) bool, the
    object's pixels.
    All or nothing: CalibrationError naming the first mirror that cannot be calibrated."""
    indices = range(len(session.mirrors)) if indices is None else list(indices)
    if not len(indices):
        raise CalibrationError(f"{session.path}: the session has no mirrors")
    depths, masks = np.asarray(depths), np.asarray(masks, bool)
    if depths.ndim == 2:
        depths, masks = depths[None], masks[None]
    rig = Rig.from_session(session)
    blind = Rig(rig.intrinsics, tuple(Mirror(m.name, None if i in indices else m.plane, m.boundary)
                                      for i, m in enumerate(rig.mirrors)))
    for k, i in enumerate(indices):
        plane = search_plane(blind, depths[0], masks[0], i, rng, cancel)
        session = session.with_mirror(i, replace(session.mirrors[i], plane=plane))
        if progress is not None:
            progress(0.5 * (k + 1) / len(indices))
    later = None if progress is None else (lambda f: progress(0.5 + 0.5 * f))
    return refine_session(session, depths, masks, indices, later, cancel, with_, FROM_SEARCH)
