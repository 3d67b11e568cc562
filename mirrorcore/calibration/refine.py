"""Refinement of the mirror planes from the agreement of the views, the calibration's last step.

From any planes (markers, a region, pairs, a search), adjust each mirror's tilt and offset so that
its reflected points lie on the surface the camera sees directly and on the other mirrors'
surfaces where they see the same part of the object, over one or more frames of any object.

This is multi-view ICP with three parameters per mirror (a reflection is fixed by its plane): in
each frame, every view's points are compared with every other view (residuals.py), residuals
normalised by their noise, Cauchy weights, Gauss-Newton on all mirrors at once, comparisons found
again at every iteration. The normal equations also say how well the data determine each plane; a
mirror whose views overlap too little is refused by name and nothing changes (fixing.py). A
plane's step is a tilt and an offset at the object's centre (planestep.py).

When the object is a round sphere that every view sees (a calibration ball), its centres say more
than the surfaces do (spheretarget.py: each plane from the sphere's centre seen directly and in the
mirror, within 0.35 mm of the truth on the simulator where the surfaces leave up to 1.1 mm);
`with_` chooses: "auto" (the sphere when there is one), "sphere" or "surfaces".
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from mirrorcore.base.errors import CalibrationError, Cancelled
from mirrorcore.base.progress import Progress, Ratchet, cancel_requested
from mirrorcore.calibration.agreement import SHOWN_GATE, FrameViews, frame_views
from mirrorcore.calibration.fixing import determined, fixed_by
from mirrorcore.calibration.gaussnewton import frames_scatter, progress_fraction, solve
from mirrorcore.calibration.glass import glass_std, marker_offset
from mirrorcore.calibration.planestep import shift_at
from mirrorcore.calibration.residuals import Residuals, agreement_mm, noise_mm, residuals
from mirrorcore.calibration.results import MirrorRefinement, Refinement
from mirrorcore.calibration.spheretarget import (SCATTER_AUTO, NotASphere, SpherePlanes,
                                                 sphere_planes)
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.session import Session
from mirrorcore.rig.model import Mirror, Rig

# Metres at the object, degrees: a plane moving more has not settled, and is refused.
MAX_CHANGE = (0.05, 5.0)
# What the refinement compares (refine_planes' `with_`).
REFINE_WITH = ("auto", "sphere", "surfaces")
# The frames of a recording a calibration from the object uses, evenly spaced over it.
REFINE_FRAMES = 10
# Of the progress: the sphere's centres, then the views' agreement for the report.
SPHERE_PART = 0.8
# Metres at the object: planes that moved more label the frames' pixels again, and those views
# move the bar as far as RELABEL_ITERATIONS iterations; it then holds until the iterations catch up
# (progress.Ratchet).
RELABEL = 0.005
RELABEL_ITERATIONS = 2
# A plane found by a search whose view, refined, still disagrees this many times more than the
# depth noise explains is refused: the search locked on a wrong plane (true planes read 0.7 to 0.9
# times with Kinect v1 noise; one 50 degrees off, 2 times). Only searched planes: markers tie a
# plane down, and a sensor noisier than noise.py's model would read above it with its planes right.
MAX_DISAGREEMENT = 1.5


@dataclass(frozen=True)
class Leash:
    """How far a refinement trusts the planes it starts from.

    The default suits planes from markers; a search's guesses, which it scored against the views
    not refined, are held tighter (scene.FROM_SEARCH).

    Attributes
    ----------
    gate : float
        Metres added at the start to what counts as the same surface (halved at every iteration).
    max_change : (float, float)
        Metres at the object, degrees: the most a plane may move, beyond which it has not settled.
    max_disagreement : float
        The most a refined view may disagree with the others, in units of what the depth noise
        explains.
    held_only : bool
        Each mirror must be fixed by the views not refined (the camera's, and those of the mirrors
        held as they are), not through other refined mirrors (fixing.fixed_by).
    """

    gate: float = 0.0
    max_change: tuple[float, float] = MAX_CHANGE
    max_disagreement: float = np.inf
    held_only: bool = False


def refine_planes(rig: Rig, depths: np.ndarray, masks: np.ndarray, indices=None,
                  progress: Progress | None = None, cancel=None, with_: str = "auto",
                  leash: Leash = Leash()) -> Refinement:
    """Refine the planes of the rig's mirrors from frames.

    Mirrors not refined keep their planes and still take part.

    Parameters
    ----------
    rig : Rig
    depths : (F, H, W) or (H, W) float
        Metres, as measured.
    masks : (F, H, W) or (H, W) bool
        Each frame's object (rig.pipeline.prepare_frame's).
    indices : iterable of int, optional
        The mirrors to refine (0-based); default every mirror with a plane.
    progress : callable, optional
        progress(fraction) as it goes.
    cancel : optional
        Checked between steps (base.progress.cancel_requested).
    with_ : str
        What is compared (REFINE_WITH): "auto" the sphere's centres when the object is a round
        sphere (SCATTER_AUTO) every view sees in every frame, else the surfaces.
    leash : Leash
        How far the start is trusted.

    Returns
    -------
    Refinement

    Raises
    ------
    CalibrationError
        Naming the mirror when it has no plane or boundary, when its views overlap too little to
        determine its plane (fixing.MIN_AGREEMENTS, MAX_SHIFT_STD, MAX_TILT_STD_DEG), when it does
        not settle (the leash's max_change) or when its refined view disagrees more than the
        leash's max_disagreement allows.
    NotASphere
        With "sphere" when the object is not one (naming the frame and the view).
    Cancelled
        When `cancel` asks.
    """
    if indices is None:
        indices = [i for i, m in enumerate(rig.mirrors) if m.plane is not None]
    indices = list(indices)
    for i in indices:
        mirror = rig.mirrors[i]
        if mirror.plane is None or mirror.boundary is None:
            missing = ("plane (calibrate it first)" if mirror.plane is None
                       else "boundary (draw its outline)")
            raise CalibrationError(f"{mirror.name}: no {missing}; the refinement starts from a "
                                   "plane and needs the mirror's boundary", (mirror.name,))
    if not indices:
        raise CalibrationError("no mirror to refine: calibrate at least one first")
    if with_ not in REFINE_WITH:
        raise CalibrationError(f"refine with {with_!r}: one of {', '.join(REFINE_WITH)}")
    depths, masks = np.asarray(depths), np.asarray(masks, bool)
    if depths.ndim == 2:
        depths, masks = depths[None], masks[None]
    refined = [i + 1 for i in indices]
    names = [rig.mirrors[j - 1].name for j in refined]
    bar = Ratchet(progress)
    sphere = _sphere(rig, depths, masks, refined, with_, bar, cancel)
    if sphere is not None:
        return _from_sphere(rig, depths, masks, refined, sphere, leash, bar, cancel)
    start = {j: m.plane for j, m in enumerate(rig.mirrors, start=1) if m.plane is not None}
    planes, iterations, labelled, gate = dict(start), 0, rig, leash.gate
    # once more when the planes moved enough to relabel the pixels
    for _ in range(2):
        views_end = progress_fraction(iterations + RELABEL_ITERATIONS if iterations else 0)
        views_bar = bar.part(progress_fraction(iterations, 0.0), views_end)
        frames = _views(labelled, depths, masks, cancel, views_bar)
        centre = np.mean([f.centre for f in frames], axis=0)
        planes, iterations = solve(frames, planes, refined, centre, gate, bar, cancel, iterations)
        final = residuals(frames, planes, refined, centre)
        fixing = fixed_by(final, refined, names, len(frames), leash.held_only)
        gate = 0.0
        if all(abs(shift_at(labelled.mirrors[j - 1].plane, planes[j], centre)) < RELABEL
               for j in refined):
            break
        labelled = _with_planes(rig, planes)
    # the agreement before and after, each counted on the bar as an iteration
    shown = []
    for k, p in enumerate((start, planes)):
        shown.append(residuals(frames, p, refined, centre, SHOWN_GATE))
        bar(progress_fraction(iterations + k + 1))
    scatter = frames_scatter(frames, planes, refined, centre, bar, cancel,
                             progress_fraction(iterations + 2))
    reports = tuple(
        _report(rig, j, start[j], planes[j], centre, tuple(shown),
                determined(final, refined, j, names[refined.index(j)], scatter.get(j)),
                (fixing[j], final.with_camera(j)), leash)
        for j in refined)
    bar(1.0)
    return Refinement(reports, len(depths), iterations, tuple(float(x) for x in centre))


def _sphere(rig: Rig, depths: np.ndarray, masks: np.ndarray, refined: list[int], with_: str,
            bar: Ratchet, cancel) -> SpherePlanes | None:
    """The planes from the sphere's centres (spheretarget.sphere_planes, over the first
    SPHERE_PART of the progress), or None: with "surfaces", and with "auto" when the object is not
    a sphere, or not a round one (SCATTER_AUTO)."""
    if with_ == "surfaces":
        return None
    part = bar.part(0.0, SPHERE_PART)
    scatter = SCATTER_AUTO if with_ == "auto" else np.inf
    try:
        return sphere_planes(rig, depths, masks, refined, np.random.default_rng(0), part, cancel,
                             scatter)
    except NotASphere:
        if with_ == "sphere":
            raise
        return None


def _from_sphere(rig: Rig, depths: np.ndarray, masks: np.ndarray, refined: list[int],
                 sphere: SpherePlanes, leash: Leash, bar: Ratchet, cancel) -> Refinement:
    """The Refinement of the planes the sphere gave: the views' agreement before and after as the
    surfaces' refinement reports it, how well the centres fix each plane, the same refusals (the
    leash's limits; its held_only plays no part: the centres fix each plane alone)."""
    start = {j: m.plane for j, m in enumerate(rig.mirrors, start=1) if m.plane is not None}
    planes = {**start, **sphere.planes}
    frames = _views(_with_planes(rig, planes), depths, masks, cancel, bar.part(SPHERE_PART, 0.97))
    shown = tuple(residuals(frames, p, refined, sphere.centre, SHOWN_GATE)
                  for p in (start, planes))
    reports = []
    for j in refined:
        report = _report(rig, j, start[j], planes[j], sphere.centre, shown,
                         (sphere.shift_std[j], sphere.tilt_std[j]),
                         (shown[1].with_camera(j),) * 2, leash)
        reports.append(replace(report, sphere_radius_mm=1e3 * sphere.radius))
    bar(1.0)
    centre = tuple(float(x) for x in sphere.centre)
    return Refinement(tuple(reports), len(depths), 0, centre, "sphere")


def _views(rig: Rig, depths: np.ndarray, masks: np.ndarray, cancel,
           progress: Progress | None) -> list[FrameViews]:
    """Each frame's views (agreement.frame_views); progress(share of the frames done) after
    each."""
    frames = []
    for k, (depth, mask) in enumerate(zip(depths, masks)):
        if cancel_requested(cancel):
            raise Cancelled("refinement cancelled")
        frames.append(frame_views(rig, depth, mask))
        if progress is not None:
            progress((k + 1) / len(depths))
    return frames


def _with_planes(rig: Rig, planes: dict[int, Plane]) -> Rig:
    """The rig with mirror j's plane replaced by planes[j] (1-based) where given."""
    return Rig(rig.intrinsics, tuple(Mirror(m.name, planes.get(j, m.plane), m.boundary)
                                     for j, m in enumerate(rig.mirrors, start=1)))


def _report(rig: Rig, j: int, before: Plane, after: Plane, centre: np.ndarray,
            shown: tuple[Residuals, Residuals], known: tuple[float, float],
            agreements: tuple[int, int], leash: Leash) -> MirrorRefinement:
    """One mirror's report.

    Parameters
    ----------
    shown : (Residuals, Residuals)
        The comparisons before and after with SHOWN_GATE (the agreement reported).
    known : (float, float)
        Metres, degrees: how well the plane is known (1 sigma).
    agreements : (int, int)
        Its readings compared with those of the views that fix it, and with the camera's.

    Raises
    ------
    CalibrationError
        When it did not settle or it disagrees (the leash's max_change and max_disagreement).
    """
    name = rig.mirrors[j - 1].name
    shift, tilt = shift_at(before, after, centre), before.angle_to(after)
    if abs(shift) > leash.max_change[0] or tilt > leash.max_change[1]:
        raise CalibrationError(f"{name}: the refinement did not settle (the plane would move "
                               f"{1e3 * shift:+.0f} mm and {tilt:.1f}°); check its boundary and "
                               "its first calibration", (name,))
    rms_before, mean_before = agreement_mm(shown[0], j)
    rms_after, mean_after = agreement_mm(shown[1], j)
    noise = noise_mm(shown[1], j)
    if rms_after > leash.max_disagreement * noise:
        raise CalibrationError(f"{name}: even refined, its view disagrees with the others "
                               f"({rms_after:.1f} mm RMS where the depth noise explains "
                               f"{noise:.1f} mm): its plane was not found; check its boundary, or "
                               "click markers on it and fit it first", (name,))
    return MirrorRefinement(j - 1, name, before, after, rms_before, rms_after, mean_before,
                            mean_after, 1e3 * shift, tilt, 1e3 * known[0], known[1], *agreements,
                            noise)


def refine_session(session: Session, depths: np.ndarray, masks: np.ndarray, indices=None,
                   progress: Progress | None = None, cancel=None, with_: str = "auto",
                   leash: Leash = Leash()) -> tuple[Session, Refinement]:
    """Refine the planes of a session's mirrors from frames; all or nothing.

    Each refined mirror with usable markers also gets its marker_offset: how far its markers'
    faces stand in front of the refined plane (their readings' robust mean over the frames,
    glass.marker_offset), with how well that is known, unless its glass was typed in
    (SessionMirror.glass_typed: it stays, and the report gives the reading beside it).

    Parameters
    ----------
    session : Session
    depths, masks, progress, cancel, with_, leash
        As for refine_planes.
    indices : iterable of int, optional
        The mirrors to refine (0-based); default all with a plane.

    Returns
    -------
    (Session, Refinement)
        The session with the new planes and marker offsets, and the Refinement (its reports carry
        the offsets).

    Raises
    ------
    CalibrationError, NotASphere, Cancelled
        As refine_planes.
    """
    rig = Rig.from_session(session)
    result = refine_planes(rig, depths, masks, indices, progress, cancel, with_, leash)
    reports = []
    for report in result.mirrors:
        mirror = replace(session.mirrors[report.index], plane=report.after)
        glass = marker_offset(session.camera, np.asarray(depths), mirror.markers, report.after)
        if glass is not None:
            report = replace(report, marker_offset=glass.offset,
                             marker_offset_std=glass_std(report, glass, result.centre),
                             glass_typed=mirror.marker_offset if mirror.glass_typed else None)
            if not mirror.glass_typed:
                mirror = replace(mirror, marker_offset=glass.offset,
                                 marker_offset_std=report.marker_offset_std)
        session = session.with_mirror(report.index, mirror)
        reports.append(report)
    return session, replace(result, mirrors=tuple(reports))
