"""What a refinement of the mirror planes returns: one MirrorRefinement per mirror and the
Refinement around them, with the thresholds its verdicts use."""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from mirrorcore.geometry.plane import Plane
from mirrorcore.io.session import Session

# A refinement that moves no plane more than SAME_PLANE (mm at the object, degrees) nor any glass
# more than SAME_GLASS_MM changes nothing (Refinement.changed).
SAME_PLANE = (0.05, 0.005)
SAME_GLASS_MM = 0.05

# A view's agreement RMS up to NOISE_EXPLAINS times what the depth noise explains is as good as the
# noise allows, beyond it flagged. On the simulator (Kinect noise; the sphere at 2 m, the walking
# figure at 2 and 3 m) the true planes give 0.66 to 0.87 times; a plane tilted by 1 degree 0.75 to
# 1.3 times, by 2 degrees 0.9 to 1.7; moved by 10 mm, 0.75 to 1.1 (an offset moves the points along
# the surface where the views overlap: the mean shows it, the refinement measures it).
NOISE_EXPLAINS = 1.0
# ... and its mean up to MEAN_EXPLAINS times it. True planes: at most 0.1 times (the same scenes,
# one frame at a time; the demo's planes from markers 0.08 to 0.21); a plane moved by 10 mm 0.7 to
# 1.4 times, and the other mirror, right, as much (their comparisons with each other); tilted by
# 0.5 degree 0.15 to 0.35 times (the camera's comparisons show that).
MEAN_EXPLAINS = 0.3
# ... and the mean of its comparisons with the camera alone up to CAMERA_MEAN_EXPLAINS times their
# noise (the same scenes): true planes at most 0.18 times (the demo's 0.27), a plane tilted by 0.5
# degree 0.55 to 1.25 times, moved by 10 mm 0.1 to 0.5; the other mirror, right, stays as true
# planes do.
CAMERA_MEAN_EXPLAINS = 0.4


class MethodBias(NamedTuple):
    """What a way of comparing may leave on the planes beyond the 1 sigma it reports.

    See the README: the walking figure, and the sphere at 1.2 to 3 m.

    Attributes
    ----------
    shift_low, shift : float
        Metres at the object: what the method may add, from shift_low up to shift (the glass's
        1 sigma takes in `shift`: glass.glass_std).
    tilt_deg : float
        Degrees: at most this much tilt.
    """

    shift_low: float
    shift: float
    tilt_deg: float


METHOD_BIAS = {"surfaces": MethodBias(1e-3, 2e-3, 0.05),
               "sphere": MethodBias(0.3e-3, 0.3e-3, 0.04)}


@dataclass(frozen=True)
class MirrorRefinement:
    """What the refinement did to one mirror (what the command line and the browser tool report).

    Attributes
    ----------
    index : int
        The mirror's position in the session (0-based).
    name : str
    before, after : Plane
        Its plane before and after.
    agreement_before_mm, agreement_after_mm : float
        RMS distance (mm) of its points to the other views' surfaces where they see the same
        surface (and of theirs to its), before and after.
    offset_before_mm, offset_after_mm : float
        The mean signed distance (mm) of its points to those surfaces, > 0 when its points lie
        outside them.
    shift_mm : float
        How far the plane moved at the object, along its normal (mm, > 0 away from the camera).
    tilt_deg : float
        The angle between the planes before and after (degrees).
    shift_std_mm, tilt_std_deg : float
        How well the data determined the plane (1 sigma): the fit's own estimate, or with
        SCATTER_FRAMES frames or more the spread of the planes each frame alone gives over the
        square root of their number, whichever is larger (the fit's own misses that the
        comparisons themselves change with the noise); from the surfaces, with the object's
        pose's part added in quadrature (fixing.POSE_SHIFT, POSE_TILT_DEG), so that a refinement on
        other frames moves the plane within 2 sigma.
    agreements : int
        Comparisons of its readings that agree with those of the views that fix it (both ways,
        all frames: the camera's, or on an arc the mirrors' beside it; fixing.fixed_by).
    camera_agreements : int
        Those with the camera's.
    noise_mm : float
        The RMS (mm) that the depth noise of the readings compared after would give alone.
    marker_offset : float or None
        Metres from its markers' faces to the refined plane (the glass), or None (no usable
        markers).
    marker_offset_std : float or None
        Metres, how well that is known (1 sigma: the spread of its markers and the plane's own
        uncertainty where they are), or None.
    sphere_radius_mm : float or None
        The sphere's radius (mm) when the plane came from its centres (spheretarget.py).
    glass_typed : float or None
        Metres, the glass typed in for the mirror, which the refinement kept (refine_session).
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


@dataclass(frozen=True)
class Refinement:
    """The result of a refinement.

    Attributes
    ----------
    mirrors : tuple of MirrorRefinement
        The refined mirrors, in session order.
    frames : int
        The frames used.
    iterations : int
        Gauss-Newton iterations (0 from a sphere).
    centre : (3,) float
        Metres, camera frame: where offsets are measured (the object's centre).
    compared : str
        "surfaces" or "sphere" (refine.REFINE_WITH).
    refused : tuple of (int, str)
        The mirrors a calibration without markers could not calibrate while it did the others
        (scene.calibrate_scene): (session index, the one-line refusal), in session order.
    """

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
        """Tell whether it moved a plane or a glass by more than nothing.

        More than SAME_PLANE for a plane, SAME_GLASS_MM for a glass.

        A refinement that changes nothing is neither an undo step nor a save.

        Parameters
        ----------
        before, after : Session
            The session before and after.

        Returns
        -------
        bool
        """
        def glass_mm(r: MirrorRefinement) -> float:
            return abs(after.mirrors[r.index].marker_offset
                       - before.mirrors[r.index].marker_offset) * 1e3

        return any(abs(r.shift_mm) >= SAME_PLANE[0] or r.tilt_deg >= SAME_PLANE[1]
                   or glass_mm(r) >= SAME_GLASS_MM for r in self.mirrors)
