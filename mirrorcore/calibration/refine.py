"""Refinement of the mirror planes from the agreement of the views, the calibration's last step: from any planes
(markers, a region, pairs, a search), adjust each mirror's tilt and offset so that its reflected points lie on the
surface the camera sees directly and on the other mirrors' surfaces where they see the same part of the object, over
one or more frames of any object.

This is multi-view ICP with three parameters per mirror (a reflection is fixed by its plane): in each frame, every
view's points are compared with every other view (agreement.py), residuals normalised by their noise, Cauchy weights,
Gauss-Newton on all mirrors at once, comparisons found again at every iteration. The normal equations also say how
well the data determine each plane; a mirror whose views overlap too little is refused by name and nothing changes.

A plane's step is (tilt about two axes in the plane, radians; offset along its normal at the object's centre,
metres): tilt and offset stay apart at the object, where they matter.

When the object is a round sphere that every view sees (a calibration ball), its centres say more than the surfaces
do (spheretarget.py: each plane from the sphere's centre seen directly and in the mirror, within 0.35 mm of the truth
on the simulator where the surfaces leave up to 1.1 mm); `with_` chooses: "auto" (the sphere when there is one),
"sphere" or "surfaces".
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from mirrorcore.calibration.agreement import SHOWN_GATE, FrameViews, frame_views, in_view
from mirrorcore.calibration.fit import MIN_MARKER_PIXELS, marker_points
from mirrorcore.depth.ops import MEAN_SIGMAS
from mirrorcore.base.errors import CalibrationError, Cancelled
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.depth.noise import axial_sigma
from mirrorcore.base.progress import Progress, Ratchet, cancel_requested
from mirrorcore.calibration.readings import reflect_directions
from mirrorcore.rig.model import Mirror, Rig
from mirrorcore.io.session import MAX_MARKER_OFFSET, Session
from mirrorcore.calibration.spheretarget import SCATTER_AUTO, SCATTER_FRAMES, NotASphere, SpherePlanes, sphere_planes
from mirrorcore.base.words import listed

CAUCHY = 2.385               # the Cauchy weight's scale, in standard deviations (95 % efficient on Gaussian noise)
MAX_ITERATIONS = 30
SETTLED = 0.1                # the iterations stop when no parameter moves by more than this share of its std
MIN_AGREEMENTS = 200         # readings of a mirror and of the camera (or of mirrors fixed so) that agree, both ways,
                             # over all frames (_fixed_by)...
MAX_SHIFT_STD = 1e-3         # ... and the plane's offset at the object known to this (metres, 1 sigma)...
MAX_TILT_STD_DEG = 0.2       # ... and its tilt to this, or the mirror is refused: its views overlap too little
MAX_CHANGE = (0.05, 5.0)     # metres at the object, degrees: a plane moving more has not settled, and is refused
SAME_PLANE = (0.05, 0.005)   # mm at the object, degrees: a refinement that moves no plane more than this...
SAME_GLASS_MM = 0.05         # ... nor any glass more than this changes nothing (Refinement.changed)
REFINE_WITH = ("auto", "sphere", "surfaces")   # what the refinement compares (refine_planes' `with_`)


class MethodBias(NamedTuple):
    """What a way of comparing may leave on the planes beyond the 1 sigma it reports (README: the walking figure,
    and the sphere at 1.2 to 3 m): in `words` for the reports, and at most `shift` metres at the object and
    `tilt_deg` degrees, which the glass's 1 sigma takes in (_glass_std); `better`: what does better, said after
    the words in a plane's report (a helper took a person's "±0.15 mm" for the planes' error, which was 1.5 mm)."""

    words: str
    shift: float
    tilt_deg: float
    better: str = ""

    @property
    def reported(self) -> str:
        """The words as a plane's report says them: with what does better."""
        return self.words + self.better


METHOD_BIAS = {"surfaces": MethodBias("the method may add 1 to 2 mm", 2e-3, 0.05,
                                       ", a ball in every view only 0.3 mm"),
               "sphere": MethodBias("the method may add 0.3 mm and 0.04°", 0.3e-3, 0.04)}
SPHERE_PART = 0.8            # of the progress: the sphere's centres, then the views' agreement for the report
REFINE_FRAMES = 10           # the frames of a recording a calibration from the object uses, evenly spaced over it
RELABEL = 0.005              # metres at the object: planes that moved more label the frames' pixels again
RELABEL_ITERATIONS = 2       # ... and those views move the bar as far as this many iterations (they had held it
                             # for 12 s on the arc's three mirrors: a helper); it then holds until the iterations
                             # catch up (progress.Ratchet)
NOISE_EXPLAINS = 1.0         # a view's agreement RMS up to this multiple of what the depth noise explains is as good
                             # as the noise allows, beyond it flagged. On the simulator (Kinect noise; the sphere at
                             # 2 m, the walking figure at 2 and 3 m) the true planes give 0.66 to 0.87 times; a plane
                             # tilted by 1 degree 0.75 to 1.3 times, by 2 degrees 0.9 to 1.7; moved by 10 mm, 0.75 to
                             # 1.1 (an offset moves the points along the surface where the views overlap: the mean
                             # below shows it, the refinement measures it)
MEAN_EXPLAINS = 0.3          # ... and its mean up to this multiple of it. True planes: at most 0.1 times (the sphere
                             # at 2 m, the walking figure at 2 and 3 m, Kinect noise, one frame at a time; the demo's
                             # planes from markers 0.08 to 0.21); a plane moved by 10 mm 0.7 to 1.4 times, and the
                             # other mirror, right, as much (their comparisons with each other); tilted by 0.5 degree
                             # 0.15 to 0.35 times (the camera's comparisons show that)
CAMERA_MEAN_EXPLAINS = 0.4   # ... and the mean of its comparisons with the camera alone up to this multiple of their
                             # noise (the same scenes): true planes at most 0.18 times (the demo's 0.27), a plane
                             # tilted by 0.5 degree 0.55 to 1.25 times, moved by 10 mm 0.1 to 0.5; the other mirror,
                             # right, stays as true planes do
MAX_DISAGREEMENT = 1.5       # a plane found by a search whose view, refined, still disagrees this many times more
                             # than the depth noise explains is refused: the search locked on a wrong plane (true
                             # planes read 0.7 to 0.9 times with Kinect v1 noise; one 50 degrees off, 2 times). Only
                             # searched planes: markers tie a plane down, and a sensor noisier than noise.py's model
                             # would read above it with its planes right


@dataclass(frozen=True)
class MirrorRefinement:
    """What the refinement did to one mirror (the report the command line and the browser tool show).

    index : the mirror's position in the session (0-based); name : its name
    before, after : its plane before and after
    agreement_before_mm, agreement_after_mm : RMS distance (mm) of its points to the other views' surfaces where they
        see the same surface (and of theirs to its), before and after
    offset_before_mm, offset_after_mm : the mean signed distance (mm) of its points to those surfaces, > 0 when its
        points lie outside them
    shift_mm : how far the plane moved at the object, along its normal (mm, > 0 away from the camera)
    tilt_deg : the angle between the planes before and after (degrees)
    shift_std_mm, tilt_std_deg : how well the data determined the plane (1 sigma): the fit's own estimate, or with
        SCATTER_FRAMES frames or more the spread of the planes each frame alone gives over the square root of their
        number, whichever is larger (on the simulator the fit's own is 2.5 to 3 times smaller than the planes' actual
        scatter from frame to frame: the comparisons themselves change with the noise)
    agreements : comparisons of its readings that agree with those of the views that fix it (both ways, all frames:
        the camera's, or on an arc the mirrors' beside it; _fixed_by)
    camera_agreements : those with the camera's
    noise_mm : the RMS (mm) that the depth noise of the readings compared after would give alone
    marker_offset : metres from its markers' faces to the refined plane (the glass), or None (no usable markers)
    marker_offset_std : metres, how well that is known (1 sigma: the spread of its markers and the plane's own
        uncertainty where they are), or None
    sphere_radius_mm : the sphere's radius (mm) when the plane came from its centres (spheretarget.py), else None
    glass_typed : metres, the glass typed in for the mirror, which the refinement kept (refine_session), else None
    """

    index: int
    name: str
    before: Plane
    after: Plane
    agreement_before_mm: float
    agreement_after_mm: float
    offset_before_mm: float
    offset_after_mm: float
    shift_mm: float
    tilt_deg: float
    shift_std_mm: float
    tilt_std_deg: float
    agreements: int
    camera_agreements: int
    noise_mm: float = float("nan")
    marker_offset: float | None = None
    marker_offset_std: float | None = None
    sphere_radius_mm: float | None = None
    glass_typed: float | None = None

    def summary(self, searched: bool = False, saved: bool = True) -> str:
        """One line: how far the plane moved (not for a plane a search found, `searched`: its start was a guess),
        whether its points now agree with the other views as well as the depth noise allows (NOISE_EXPLAINS), their
        RMS and mean distance before and after against the noise's RMS, and how well the data fix the plane. A
        plane's offset hardly shows in the agreement (it moves the points along the surface where the views
        overlap: 3 mm of glass moved the mean by 0.6 to 0.7 mm), so the verdict leads. The glass is said to be saved
        unless `saved` is False (the session had it already)."""
        if searched:                 # its start was the search's guess: nothing before worth saying
            figures = f"RMS {self.agreement_after_mm:.2f} mm, mean {self.offset_after_mm:+.2f} mm"
        else:
            figures = (f"RMS {self.agreement_before_mm:.2f} mm before, {self.agreement_after_mm:.2f} mm after, mean "
                       f"{self.offset_before_mm:+.2f} mm before, {self.offset_after_mm:+.2f} mm after")
        figures += f" over the frames used, where the depth noise alone would give {self.noise_mm:.2f} mm RMS"
        if self.agreement_after_mm <= NOISE_EXPLAINS * self.noise_mm:
            text = f"its points agree with the other views as well as the depth noise allows ({figures})"
        else:
            text = (f"⚠ its points agree with the other views less well than the depth noise explains ({figures}): "
                    "check its boundary")
        if not searched:
            text = f"plane moved {self.shift_mm:+.2f} mm (> 0: away from the camera) and {self.tilt_deg:.3f}°; {text}"
        if self.sphere_radius_mm is None:
            whom = ("the camera" if self.agreements == self.camera_agreements else
                    f"the camera and the mirrors that fix it, {self.camera_agreements:,} with the camera")
            how = f"{METHOD_BIAS['surfaces'].reported}; {self.agreements:,} points seen both ways with {whom}"
        else:
            how = (f"from the centres of the sphere (radius {self.sphere_radius_mm:.1f} mm) seen directly and in it; "
                   f"{METHOD_BIAS['sphere'].words}")
        text += f"; the data fix it to ±{self.shift_std_mm:.2f} mm and ±{self.tilt_std_deg:.3f}° (1σ; {how})"
        if self.glass_typed is not None:
            text += (f", markers {1e3 * self.marker_offset:.1f} ± {1e3 * self.marker_offset_std:.1f} mm in front of "
                     f"the refined plane (its glass stays {1e3 * self.glass_typed:.1f} mm, as typed in)")
        elif self.marker_offset is not None:
            text += (f", markers {1e3 * self.marker_offset:.1f} ± {1e3 * self.marker_offset_std:.1f} mm in front of "
                     f"the silver ({'saved as its glass' if saved else 'its glass already'})")
        return text


@dataclass(frozen=True)
class Refinement:
    """The refined mirrors (in session order), the frames used, the Gauss-Newton iterations (0 from a sphere), the
    point (3,) metres, camera frame, where offsets are measured (the object's centre), what was compared:
    "surfaces" or "sphere" (REFINE_WITH), and the mirrors a calibration without markers could not calibrate while
    it did the others (search.calibrate_scene): (session index, the one-line refusal) each, in session order."""

    mirrors: tuple[MirrorRefinement, ...]
    frames: int
    iterations: int
    centre: tuple[float, float, float]
    compared: str = "surfaces"
    refused: tuple[tuple[int, str], ...] = ()

    @property
    def planes(self) -> dict[int, Plane]:
        """{session index (0-based): refined plane}."""
        return {m.index: m.after for m in self.mirrors}

    def changed(self, before: Session, after: Session) -> bool:
        """Whether it moved a plane (SAME_PLANE) or a glass (SAME_GLASS_MM, from the session `before` to `after`) by
        more than nothing: one right after the search's own refinement, on the same frames, made an undo step of
        'moved 0.0 mm and 0.00°' in the browser and rewrote session.json on the command line (helpers)."""
        return any(abs(r.shift_mm) >= SAME_PLANE[0] or r.tilt_deg >= SAME_PLANE[1]
                   or abs(after.mirrors[r.index].marker_offset - before.mirrors[r.index].marker_offset) * 1e3
                   >= SAME_GLASS_MM for r in self.mirrors)


# --------------------------------------------------------------------------------------------- one plane's step
def tangent_basis(n: np.ndarray) -> np.ndarray:
    """(2, 3) float64: two unit vectors orthogonal to the unit vector n (3,) and to each other."""
    e1 = np.cross(n, np.eye(3)[int(np.argmin(np.abs(n)))])
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(n, e1)])


def offset_at(plane: Plane, point) -> float:
    """The signed distance (metres) of `point` (3,) from the plane, > 0 on the camera's side."""
    return float(plane.signed_distance(np.asarray(point, dtype=np.float64)))


def moved_plane(plane: Plane, centre: np.ndarray, step: np.ndarray) -> Plane:
    """The plane tilted by step[0], step[1] radians about its tangent_basis and moved by step[2] metres along its
    normal at `centre` (3,)."""
    basis = tangent_basis(plane.n)
    n = plane.n + step[0] * basis[0] + step[1] * basis[1]
    n /= np.linalg.norm(n)
    return Plane.from_abcd([*n, offset_at(plane, centre) + step[2] - float(n @ centre)])


def reflection_jacobian(plane: Plane, centre: np.ndarray, points: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """d(direction . reflect(points)) / d(step) of moved_plane at step 0, direction held fixed: points (m, 3) metres,
    direction (m, 3) -> (m, 3) float64 (reflect(P) = P - 2 s n with s = n . P + d)."""
    basis = tangent_basis(plane.n)
    s = plane.signed_distance(points)
    along_n = direction @ plane.n
    tilt = -2.0 * (((points - centre) @ basis.T) * along_n[:, None] + s[:, None] * (direction @ basis.T))
    return np.column_stack([tilt, -2.0 * along_n])


def shift_at(before: Plane, after: Plane, point) -> float:
    """How far (metres) the plane moved at `point`, along its normal, > 0 away from the camera."""
    return offset_at(after, point) - offset_at(before, point)


# --------------------------------------------------------------------------------------------- residuals
@dataclass(frozen=True)
class _Residuals:
    """All comparisons of one iteration: jacobian (m, 3k) over the refined mirrors' steps, residual, sigma (m,)
    metres, pair (m, 2) int: the views compared (source, target; 0 = the camera)."""

    jacobian: np.ndarray
    residual: np.ndarray
    sigma: np.ndarray
    pair: np.ndarray

    def weights(self) -> np.ndarray:
        """Cauchy weights over each residual's variance."""
        return 1.0 / (1.0 + (self.residual / self.sigma / CAUCHY) ** 2) / self.sigma ** 2

    def involving(self, j: int, camera_only: bool = False) -> np.ndarray:
        """(m,) bool: the comparisons of view j's readings with another view's, both ways (with the camera's only,
        `camera_only`)."""
        pick = (self.pair[:, 0] == j) | (self.pair[:, 1] == j)
        return pick & ((self.pair[:, 0] == 0) | (self.pair[:, 1] == 0)) if camera_only else pick

    def with_camera(self, j: int) -> int:
        """How many comparisons are between mirror j's readings and the camera's (both ways)."""
        return int(np.count_nonzero(self.involving(j, camera_only=True)))


def residuals(frames: list[FrameViews], planes: dict[int, Plane], refined: list[int], centre: np.ndarray,
              gate: float = 0.0) -> _Residuals:
    """Compare, in each frame, every view's points (a mirror's reflected through its plane) with every other view.
    planes : {mirror j (1-based): plane} of every mirror with a view; refined : the mirrors whose steps are the
    jacobian's columns (three each, in this order)."""
    columns = {j: 3 * i for i, j in enumerate(refined)}
    parts = []
    for frame in frames:
        views = [j for j in frame.targets if j == 0 or j in planes]
        real = {j: in_view(frame.points(j), planes.get(j)) for j in views}     # mirrors' points reflected
        for b in views:
            for a in views:
                if a == b:
                    continue
                found = frame.targets[b].compare(in_view(real[a], planes.get(b)), gate)
                rows = np.zeros((len(found), 3 * len(refined)))
                if a in columns:                          # the gradient pulled back to the real space first
                    pulled = reflect_directions(planes[b], found.direction) if b else found.direction
                    rows[:, columns[a]:columns[a] + 3] = reflection_jacobian(
                        planes[a], centre, frame.points(a).points[found.index], pulled)
                if b in columns:
                    rows[:, columns[b]:columns[b] + 3] += reflection_jacobian(
                        planes[b], centre, real[a].points[found.index], found.direction)
                parts.append((rows, found.residual, found.sigma, np.tile((a, b), (len(found), 1))))
    if not parts:
        return _Residuals(np.zeros((0, 3 * len(refined))), np.zeros(0), np.ones(0), np.zeros((0, 2), int))
    return _Residuals(*(np.concatenate(p) for p in zip(*parts)))


# --------------------------------------------------------------------------------------------- the refinement
@dataclass(frozen=True)
class Leash:
    """How far a refinement trusts the planes it starts from: `gate`, metres added at the start to what counts as
    the same surface (halved at every iteration); `max_change` (metres at the object, degrees), the most a plane may
    move, beyond which it has not settled; `max_disagreement`, the most a refined view may disagree with the others,
    in units of what the depth noise explains; `held_only`: each mirror must be fixed by the views not refined (the
    camera's, and those of the mirrors held as they are), not through other refined mirrors (_fixed_by). The default
    suits planes from markers; a search's guesses, which it scored against those views, are held tighter
    (search.FROM_SEARCH)."""

    gate: float = 0.0
    max_change: tuple[float, float] = MAX_CHANGE
    max_disagreement: float = np.inf
    held_only: bool = False


def refine_planes(rig: Rig, depths: np.ndarray, masks: np.ndarray, indices=None, progress: Progress | None = None,
                  cancel=None, with_: str = "auto", leash: Leash = Leash()) -> Refinement:
    """Refine the planes of the rig's mirrors at `indices` (0-based; default every mirror with a plane) from frames.

    depths : (F, H, W) float metres as measured; masks : (F, H, W) bool, each frame's object (prepare_frame's)
    with_ : what is compared (REFINE_WITH): "auto" the sphere's centres when the object is a round sphere
    (SCATTER_AUTO) every view sees in every frame, else the surfaces; leash : how far the start is trusted (Leash).
    Mirrors not refined keep their planes and still take part.
    Raises CalibrationError naming the mirror when it has no plane or boundary, when its views overlap too little to
    determine its plane (MIN_AGREEMENTS, MAX_SHIFT_STD, MAX_TILT_STD_DEG), when it does not settle (the leash's
    max_change) or when its refined view disagrees more than the leash's max_disagreement allows; NotASphere (naming
    the frame and the view) with "sphere" when the object is not one; Cancelled when `cancel` asks; progress(fraction)
    as it goes.
    """
    indices = [i for i, m in enumerate(rig.mirrors) if m.plane is not None] if indices is None else list(indices)
    for i in indices:
        if rig.mirrors[i].plane is None or rig.mirrors[i].boundary is None:
            missing = "plane (calibrate it first)" if rig.mirrors[i].plane is None else "boundary (draw its outline)"
            raise CalibrationError(f"{rig.mirrors[i].name}: no {missing}; the refinement starts from a plane and "
                                   "needs the mirror's boundary", (rig.mirrors[i].name,))
    if not indices:
        raise CalibrationError("no mirror to refine: calibrate at least one first")
    if with_ not in REFINE_WITH:
        raise CalibrationError(f"refine with {with_!r}: one of {', '.join(REFINE_WITH)}")
    depths, masks = np.asarray(depths), np.asarray(masks, bool)
    if depths.ndim == 2:
        depths, masks = depths[None], masks[None]
    refined = [i + 1 for i in indices]
    bar = Ratchet(progress)
    sphere = _sphere(rig, depths, masks, refined, with_, bar, cancel)
    if sphere is not None:
        return _from_sphere(rig, depths, masks, refined, sphere, leash, bar, cancel)
    start = {j: m.plane for j, m in enumerate(rig.mirrors, start=1) if m.plane is not None}
    planes, iterations, labelled, gate = dict(start), 0, rig, leash.gate
    for _ in range(2):                                   # once more when the planes moved enough to relabel pixels
        views_end = _fraction(iterations + RELABEL_ITERATIONS) if iterations else _fraction(0)
        frames = _views(labelled, depths, masks, cancel, bar.part(_fraction(iterations, 0.0), views_end))
        centre = np.mean([f.centre for f in frames], axis=0)
        planes, iterations, final, fixing = _iterate(frames, planes, refined, centre, gate, bar, cancel,
                                                     iterations, [rig.mirrors[j - 1].name for j in refined],
                                                     leash.held_only)
        gate = 0.0
        if all(abs(shift_at(labelled.mirrors[j - 1].plane, planes[j], centre)) < RELABEL for j in refined):
            break
        labelled = _with_planes(rig, planes)
    shown = []
    for k, p in enumerate((start, planes)):              # the agreement before and after: each as an iteration
        shown.append(residuals(frames, p, refined, centre, SHOWN_GATE))
        bar(_fraction(iterations + k + 1))               # (the bar had held through them, and the first frame's
                                                         # own planes: 1.7 of 8.6 s on the arc, 8 s loaded)
    scatter = _frames_scatter(frames, planes, refined, centre, bar, cancel, _fraction(iterations + 2))
    reports = tuple(_report(rig, j, start[j], planes[j], centre, tuple(shown),
                            _determined(final, refined, j, rig.mirrors[j - 1].name, scatter.get(j)),
                            (fixing[j], final.with_camera(j)), leash) for j in refined)
    bar(1.0)
    return Refinement(reports, len(depths), iterations, tuple(float(x) for x in centre))


def _sphere(rig: Rig, depths: np.ndarray, masks: np.ndarray, refined: list[int], with_: str, bar: Ratchet, cancel
            ) -> SpherePlanes | None:
    """The planes from the sphere's centres (spheretarget.sphere_planes, over the first SPHERE_PART of the progress), or
    None: with "surfaces", and with "auto" when the object is not a sphere, or not a round one (SCATTER_AUTO)."""
    if with_ == "surfaces":
        return None
    part = bar.part(0.0, SPHERE_PART)
    scatter = SCATTER_AUTO if with_ == "auto" else np.inf
    try:
        return sphere_planes(rig, depths, masks, refined, np.random.default_rng(0), part, cancel, scatter)
    except NotASphere:
        if with_ == "sphere":
            raise
        return None


def _from_sphere(rig: Rig, depths: np.ndarray, masks: np.ndarray, refined: list[int], sphere: SpherePlanes,
                 leash: Leash, bar: Ratchet, cancel) -> Refinement:
    """The Refinement of the planes the sphere gave: the views' agreement before and after as the surfaces'
    refinement reports it, how well the centres fix each plane, the same refusals (the leash's limits; its
    held_only plays no part: the centres fix each plane alone)."""
    start = {j: m.plane for j, m in enumerate(rig.mirrors, start=1) if m.plane is not None}
    planes = {**start, **sphere.planes}
    frames = _views(_with_planes(rig, planes), depths, masks, cancel, bar.part(SPHERE_PART, 0.97))
    shown = tuple(residuals(frames, p, refined, sphere.centre, SHOWN_GATE) for p in (start, planes))
    reports = tuple(replace(_report(rig, j, start[j], planes[j], sphere.centre, shown,
                                    (sphere.shift_std[j], sphere.tilt_std[j]), (shown[1].with_camera(j),) * 2, leash),
                            sphere_radius_mm=1e3 * sphere.radius) for j in refined)
    bar(1.0)
    return Refinement(reports, len(depths), 0, tuple(float(x) for x in sphere.centre), "sphere")


def _views(rig: Rig, depths: np.ndarray, masks: np.ndarray, cancel, progress: Progress | None) -> list[FrameViews]:
    """Each frame's views (agreement.frame_views); progress(share of the frames done) after each."""
    frames = []
    for k, (depth, mask) in enumerate(zip(depths, masks)):
        if cancel_requested(cancel):
            raise Cancelled("refinement cancelled")
        frames.append(frame_views(rig, depth, mask))
        if progress is not None:
            progress((k + 1) / len(depths))
    return frames


def _fraction(iterations: int, within: float = 1.0) -> float:
    """Progress: the frames' views take a fifth; the iterations the next 55 %, ever slower but never standing still
    (most settle in under 15; a second pass after relabelling the pixels goes on counting); each frame's own planes
    (_frames_scatter) the rest (a bar that stood at 99 % through them looked stuck)."""
    return 0.2 * within if iterations == 0 else 0.2 + 0.55 * (1.0 - float(np.exp(-iterations / 8.0)))


def _iterate(frames, planes, refined, centre, gate, progress, cancel, iterations, names, held_only):
    """Gauss-Newton until no step exceeds SETTLED of its std -> (planes, iterations so far, final _Residuals, the
    agreements that fix each mirror); CalibrationError when a mirror's views overlap too little (_fixed_by)."""
    planes, iterations = _solve(frames, planes, refined, centre, gate, progress, cancel, iterations)
    final = residuals(frames, planes, refined, centre)
    return planes, iterations, final, _fixed_by(final, refined, names, len(frames), held_only)


def _solve(frames, planes, refined, centre, gate, progress, cancel, iterations) -> tuple[dict[int, Plane], int]:
    """Gauss-Newton until no step exceeds SETTLED of its std (at most MAX_ITERATIONS) -> (planes, iterations so
    far); `progress` (or None) after each iteration."""
    planes = dict(planes)
    for _ in range(MAX_ITERATIONS):
        if cancel_requested(cancel):
            raise Cancelled("refinement cancelled")
        found = residuals(frames, planes, refined, centre, gate)
        weights = found.weights()
        hessian = found.jacobian.T @ (weights[:, None] * found.jacobian)
        hessian += np.eye(len(hessian)) * 1e-9 * max(np.trace(hessian), 1.0)     # no view may see a mirror yet
        step = -np.linalg.solve(hessian, found.jacobian.T @ (weights * found.residual))
        for i, j in enumerate(refined):
            planes[j] = moved_plane(planes[j], centre, step[3 * i:3 * i + 3])
        iterations, gate = iterations + 1, gate / 2
        if progress is not None:
            progress(_fraction(iterations))
        if np.all(np.abs(step) <= SETTLED * np.sqrt(np.diag(np.linalg.inv(hessian)))):
            break
    return planes, iterations


def _frames_scatter(frames, planes, refined, centre, progress, cancel, done: float) -> dict[int, tuple[float, float]]:
    """With SCATTER_FRAMES frames or more: {mirror j: (metres, degrees)}, the spread of the planes that each frame
    alone gives, refined from `planes`, over the square root of the number of frames: along the normal at `centre`
    and in tilt (the larger of its two axes), each a robust standard deviation (_spread: a frame that sees too little
    to give a plane of its own does not count). Fewer frames: {}. `done`: the progress so far."""
    if len(frames) < SCATTER_FRAMES:
        return {}
    shifts, tilts = [], []
    for k, frame in enumerate(frames):
        alone = _solve([frame], planes, refined, centre, 0.0, None, cancel, 0)[0]
        shifts.append([shift_at(planes[j], alone[j], centre) for j in refined])
        tilts.append([tangent_basis(planes[j].n) @ alone[j].n for j in refined])
        if progress is not None:
            progress(done + (0.99 - done) * (k + 1) / len(frames))
    shifts, tilts, root = np.asarray(shifts), np.asarray(tilts), np.sqrt(len(frames))
    return {j: (float(_spread(shifts[:, i]) / root),
                float(np.degrees(max(_spread(tilts[:, i, 0]), _spread(tilts[:, i, 1]))) / root))
            for i, j in enumerate(refined)}


def _spread(values: np.ndarray) -> float:
    """A standard deviation of `values` (n,) robust to a few wild ones: 1.4826 times their median absolute
    deviation (the standard deviation itself for Gaussian values)."""
    return float(1.4826 * np.median(np.abs(values - np.median(values))))


def _fixed_by(found: _Residuals, refined: list[int], names: list[str], frames: int,
              held_only: bool = False) -> dict[int, int]:
    """{mirror j: how many of its readings agree with those of the views that fix it} (both ways, all frames): the
    camera's and the mirrors' not refined, then, in turn, those of the mirrors these fixed: at least MIN_AGREEMENTS
    fix a mirror (on an arc of three, the middle mirror faces the camera and sees a person's back, the camera the
    front: the mirrors beside it see the sides it shares). With `held_only`, the views not refined alone: a search's
    guess is scored against those (search.search_plane); scored against the camera alone, it had put an arc's middle
    mirror 22 degrees off, where the mirrors beside it, refined with it, still agreed with it within 1.3 times the
    noise. CalibrationError naming every mirror nothing fixes: its plane would be left free (a box facing the camera:
    the mirrors see only its sides and back)."""
    held = {0} | (set(np.unique(found.pair)) - set(refined))
    fixing, counts = set(held), {}
    while True:
        more = {j: _shared(found, j, fixing) for j in refined if j not in counts}
        more = {j: n for j, n in more.items() if n >= MIN_AGREEMENTS}
        if not more:
            break
        counts.update(more)
        if not held_only:
            fixing |= set(more)
    free = [(j, name) for j, name in zip(refined, names) if j not in counts]
    if free:
        raise CalibrationError(_free_refusal(found, free, held, frames, held_only), tuple(name for _, name in free))
    return counts


def _free_refusal(found: _Residuals, free: list[tuple[int, str]], held: set[int], frames: int,
                  held_only: bool) -> str:
    """The refusal of the mirrors nothing fixes (free: (j, name) pairs, in session order), one line naming each."""
    one = len(free) == 1
    names = listed([name for _, name in free])
    agree = listed([f"{_shared(found, j, held):,}" if one else f"{name}: {_shared(found, j, held):,}"
                     for j, name in free])
    what = ("the mirror see too little of the same surface to determine its plane" if one else
            "the mirrors see too little of the same surface to determine their planes")
    if held_only:
        mirrors = "; a plane found without markers must be fixed by the camera or by mirrors calibrated before it"
        advice = f"click markers on {'it' if one else 'them'} and fit {'it' if one else 'them'}, then refine from " \
                 "the object"
    else:
        shared = [(name, _shared(found, j, set(np.unique(found.pair)) - {0, j})) for j, name in free]
        mirrors = ""                            # (one mirror sharing that many with the others would be fixed)
        if any(n >= MIN_AGREEMENTS for _, n in shared):
            counts = listed([f"{name}: {n:,}" for name, n in shared])
            mirrors = (f"; the readings they share with one another ({counts}) fix nothing, as the camera fixes "
                       "none of them")
        advice = ("refine on an object that both see from the side (a person, a sphere), not a flat face, or "
                  "on more frames of one that moves")
    return (f"{names}: the camera and {what} ({agree} readings agree over {frames} frame(s), {MIN_AGREEMENTS} are "
            f"needed{mirrors}); {advice}")


def _shared(found: _Residuals, j: int, views: set[int]) -> int:
    """How many comparisons are between mirror j's readings and those of `views` (both ways)."""
    other = np.where(found.pair[:, 0] == j, found.pair[:, 1], np.where(found.pair[:, 1] == j, found.pair[:, 0], j))
    return int(np.count_nonzero(np.isin(other, list(views - {j}))))


def _with_planes(rig: Rig, planes: dict[int, Plane]) -> Rig:
    return Rig(rig.intrinsics, tuple(Mirror(m.name, planes.get(j, m.plane), m.boundary)
                                     for j, m in enumerate(rig.mirrors, start=1)))


def _determined(final: _Residuals, refined: list[int], j: int, name: str, scatter: tuple[float, float] | None
                ) -> tuple[float, float]:
    """How well the comparisons that settled the planes (`final`) determine mirror j's: (metres along its normal at
    the object, degrees), 1 sigma, the larger of the fit's own and the frames' `scatter` (_frames_scatter, or None).
    CalibrationError when the fit's own says the views overlap too little (MAX_SHIFT_STD, MAX_TILT_STD_DEG)."""
    weights = final.weights()
    hessian = final.jacobian.T @ (weights[:, None] * final.jacobian)
    scale = np.sum(weights * final.residual ** 2) / max(len(final.residual) - hessian.shape[0], 1)
    cov = scale * np.linalg.inv(hessian)
    i = 3 * refined.index(j)
    shift_std = float(np.sqrt(cov[i + 2, i + 2]))
    tilt_std = float(np.degrees(np.sqrt(np.linalg.eigvalsh(cov[i:i + 2, i:i + 2]).max())))
    if shift_std > MAX_SHIFT_STD or tilt_std > MAX_TILT_STD_DEG:       # the overlap's geometry, not the frames' noise
        raise CalibrationError(f"{name}: the views overlap too little to determine its plane (known only to "
                               f"±{1e3 * shift_std:.1f} mm and ±{tilt_std:.2f}°); use more frames, or move the "
                               "object so that both the camera and the mirror see its sides", (name,))
    if scatter is not None:
        shift_std, tilt_std = max(shift_std, scatter[0]), max(tilt_std, scatter[1])
    return shift_std, tilt_std


def _report(rig: Rig, j: int, before: Plane, after: Plane, centre: np.ndarray, shown: tuple[_Residuals, _Residuals],
            determined: tuple[float, float], agreements: tuple[int, int], leash: Leash) -> MirrorRefinement:
    """One mirror's report, or CalibrationError when it did not settle or it disagrees (the leash's max_change and
    max_disagreement).
    shown : the comparisons before and after with SHOWN_GATE (the agreement reported); determined : (metres,
    degrees), how well the plane is known (1 sigma); agreements : its readings compared with those of the views that
    fix it, and with the camera's."""
    name = rig.mirrors[j - 1].name
    shift, tilt = shift_at(before, after, centre), before.angle_to(after)
    if abs(shift) > leash.max_change[0] or tilt > leash.max_change[1]:
        raise CalibrationError(f"{name}: the refinement did not settle (the plane would move {1e3 * shift:+.0f} mm "
                               f"and {tilt:.1f}°); check its boundary and its first calibration", (name,))
    rms_before, mean_before = _agreement(shown[0], j)
    rms_after, mean_after = _agreement(shown[1], j)
    noise = _noise_mm(shown[1], j)
    if rms_after > leash.max_disagreement * noise:
        raise CalibrationError(f"{name}: even refined, its view disagrees with the others ({rms_after:.1f} mm RMS "
                               f"where the depth noise explains {noise:.1f} mm): its plane was not found; check its "
                               "boundary, or click markers on it and fit it first", (name,))
    return MirrorRefinement(j - 1, name, before, after, rms_before, rms_after, mean_before, mean_after, 1e3 * shift,
                            tilt, 1e3 * determined[0], determined[1], *agreements, noise)


def _agreement(found: _Residuals, j: int, camera_only: bool = False) -> tuple[float, float]:
    """(RMS, mean) mm of the comparisons involving mirror j (and the camera, with `camera_only`), signed so that > 0
    means its points lie outside the other views' surfaces."""
    pick = found.involving(j, camera_only)
    signed = np.where(found.pair[pick, 0] == j, 1.0, -1.0) * found.residual[pick]
    if not len(signed):
        return float("nan"), float("nan")
    return float(1e3 * np.sqrt(np.mean(signed ** 2))), float(1e3 * np.mean(signed))


class ViewAgreement(NamedTuple):
    """How one mirror's view agrees with the others: RMS and mean (mm, as in MirrorRefinement) over `points`
    comparisons of its readings with the other views' that agree (both ways), and `noise_mm`, the RMS that the depth
    noise of the readings compared would give alone (their sigma along the surface's normal); `camera_rms_mm`,
    `camera_mean_mm`, `camera_noise_mm` and `camera_points` of its comparisons with the camera alone (a mirror that
    agrees with the camera but not with another mirror puts the other one in doubt); `frames`, over how many frames.
    All NaN without agreement."""

    rms_mm: float
    mean_mm: float
    points: int
    noise_mm: float
    camera_rms_mm: float = float("nan")
    camera_mean_mm: float = float("nan")
    camera_noise_mm: float = float("nan")
    camera_points: int = 0
    frames: int = 1


def view_agreement(rig: Rig, depths: np.ndarray, masks: np.ndarray) -> dict[int, ViewAgreement]:
    """How well each calibrated mirror's view agrees with the others now, without changing anything (for the report
    after a markers fit): {mirror index (0-based): ViewAgreement}. depths, masks as for refine_planes."""
    depths, masks = np.asarray(depths), np.asarray(masks, bool)
    if depths.ndim == 2:
        depths, masks = depths[None], masks[None]
    frames = [frame_views(rig, d, m) for d, m in zip(depths, masks)]
    planes = {j: m.plane for j, m in enumerate(rig.mirrors, start=1) if m.plane is not None}
    centre = np.mean([f.centre for f in frames], axis=0)
    found = residuals(frames, planes, [], centre, SHOWN_GATE)
    out = {}
    for j in planes:
        out[j - 1] = ViewAgreement(*_agreement(found, j), int(np.count_nonzero(found.involving(j))),
                                   _noise_mm(found, j), *_agreement(found, j, camera_only=True),
                                   _noise_mm(found, j, camera_only=True), found.with_camera(j), len(frames))
    return out


def _noise_mm(found: _Residuals, j: int, camera_only: bool = False) -> float:
    """The RMS (mm) that the depth noise of the readings compared would give alone, over the comparisons involving
    mirror j (and the camera, with `camera_only`; NaN without any)."""
    sigma = found.sigma[found.involving(j, camera_only)]
    return float(1e3 * np.sqrt(np.mean(sigma ** 2))) if len(sigma) else float("nan")


# --------------------------------------------------------------------------------------------- sessions
def refine_session(session: Session, depths: np.ndarray, masks: np.ndarray, indices=None,
                   progress: Progress | None = None, cancel=None, with_: str = "auto",
                   leash: Leash = Leash()) -> tuple[Session, Refinement]:
    """Refine the planes of a session's mirrors (all with a plane, or those at `indices`, 0-based) from frames
    (refine_planes: depths (F, H, W) float metres as measured, masks (F, H, W) bool, the object's pixels of each;
    with_ and leash as there); all or nothing. Each refined mirror with usable markers also
    gets its marker_offset: how far its markers' faces stand in front of the refined plane (their readings' robust
    mean over the frames, marker_offset), with how well that is known, unless its glass was typed in
    (SessionMirror.glass_typed: it stays, and the report gives the reading beside it).
    Returns the session with the new planes and marker offsets, and the Refinement (its reports carry the offsets)."""
    rig = Rig.from_session(session)
    result = refine_planes(rig, depths, masks, indices, progress, cancel, with_, leash)
    reports = []
    for report in result.mirrors:
        mirror = replace(session.mirrors[report.index], plane=report.after)
        glass = marker_offset(session.camera, np.asarray(depths), mirror.markers, report.after)
        if glass is not None:
            report = replace(report, marker_offset=glass.offset,
                             marker_offset_std=_glass_std(report, glass, result.centre),
                             glass_typed=mirror.marker_offset if mirror.glass_typed else None)
            if not mirror.glass_typed:
                mirror = replace(mirror, marker_offset=glass.offset, marker_offset_std=report.marker_offset_std)
        session = session.with_mirror(report.index, mirror)
        reports.append(report)
    return session, replace(result, mirrors=tuple(reports))


class Glass(NamedTuple):
    """How far markers' faces stand in front of a plane (marker_offset): `offset` metres, `spread` metres (the
    spread of the markers' own medians over the square root of their number) and the `centroid` (3,) metres of
    their readings."""

    offset: float
    spread: float
    centroid: np.ndarray


def marker_offset(intr: Intrinsics, depth: np.ndarray, markers, plane: Plane) -> Glass | None:
    """How far (metres) markers' faces stand in front of `plane` (towards the camera): the mean signed distance of
    their readings (calibration.marker_points) in depth (H, W) or frames (k, H, W) float metres (reduced inside the
    markers' windows to their robust mean: a median snaps to the camera's disparity steps) within MEAN_SIGMAS of the
    depth noise of their median, 0 when that is negative (markers cannot stand behind the silver: that is the
    readings' noise, and the browser's glass takes 0 to 50 mm); see Glass. A marker that reads more than
    MAX_MARKER_OFFSET off the plane (something in front of it: the person walking past) is left out. None with fewer
    than 3 usable markers or an answer beyond MAX_MARKER_OFFSET (not markers on this mirror's glass)."""
    groups = [marker_points(intr, depth, m).astype(np.float64) for m in markers]
    groups = [g for g in groups if len(g) >= MIN_MARKER_PIXELS]
    pairs = [(g, _trimmed_mean(plane.signed_distance(g), g[:, 2])) for g in groups]
    pairs = [(g, offset) for g, offset in pairs if abs(offset) <= MAX_MARKER_OFFSET]    # not hidden behind the object
    if len(pairs) < 3:
        return None
    usable, each = [g for g, _ in pairs], [offset for _, offset in pairs]
    readings = np.concatenate(usable)
    offset = _trimmed_mean(plane.signed_distance(readings), readings[:, 2])
    if abs(offset) > MAX_MARKER_OFFSET:
        return None
    return Glass(max(offset, 0.0), float(np.std(each, ddof=1) / np.sqrt(len(each))), readings.mean(axis=0))


def _trimmed_mean(distances: np.ndarray, z: np.ndarray) -> float:
    """The mean of `distances` (n,) metres within MEAN_SIGMAS of the depth noise at depths z (n,) of their median."""
    keep = np.abs(distances - np.median(distances)) <= MEAN_SIGMAS * axial_sigma(z)
    return float(np.mean(distances[keep]))


def _glass_std(report: MirrorRefinement, glass: Glass, centre) -> float:
    """Metres, 1 sigma of a mirror's glass: its markers' spread, the refined plane's own uncertainty where they are
    (its offset's at the object, `centre` (3,) metres, and its tilt's over the way there) and, likewise, what the
    method may add (METHOD_BIAS: the planes' own 1 sigma left a sphere's glass at 3.7 +- 0.2 mm for 3.0, a
    helper)."""
    along = glass.centroid - np.asarray(centre)
    away = np.linalg.norm(along - (along @ report.after.n) * report.after.n)
    bias = METHOD_BIAS["sphere" if report.sphere_radius_mm is not None else "surfaces"]
    plane = np.hypot(1e-3 * report.shift_std_mm, np.radians(report.tilt_std_deg) * away)
    method = np.hypot(bias.shift, np.radians(bias.tilt_deg) * away)
    return float(np.sqrt(glass.spread ** 2 + plane ** 2 + method ** 2))
