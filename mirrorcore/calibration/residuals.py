"""The comparisons of every view with every other as residuals of the mirror planes (the
refinement's Gauss-Newton rows), and how well each mirror's view agrees with the others."""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from mirrorcore.calibration.agreement import SHOWN_GATE, FrameViews, frame_views, in_view
from mirrorcore.calibration.planestep import moved_plane, reflection_jacobian, shift_at
from mirrorcore.calibration.readings import reflect_directions
from mirrorcore.geometry.plane import Plane
from mirrorcore.rig.model import Rig

# The Cauchy weight's scale, in standard deviations (95 % efficient on Gaussian noise).
CAUCHY = 2.385
# What reads as glass in front of the silver under the markers (reads_as_glass): one refinement
# step would move every plane from markers away from the camera by GLASS_STEP (metres, from..to),
# together within GLASS_APART (metres) and each tilted by at most GLASS_TILT_DEG. On the sphere
# (Kinect noise, 5 frames) the step reads +2.8 to +2.9 mm for planes 3 mm too near, +0.2 to +0.3 mm
# and at most 0.04 degrees for true planes, 1.1 degrees for a plane tilted by 1, and +3.7 and
# -0.2 mm for one plane 4 mm too near. On the walking figure it cannot tell a glass (true planes
# read -1.3 mm, 3 mm of glass -0.1 mm: the surfaces' bias, decision 0002).
GLASS_STEP = (1.5e-3, 10e-3)
GLASS_APART = 1.5e-3
GLASS_TILT_DEG = 0.2


@dataclass(frozen=True)
class Residuals:
    """All comparisons of one iteration.

    Attributes
    ----------
    jacobian : (m, 3k) float
        Derivatives over the k refined mirrors' steps (planestep.moved_plane).
    residual, sigma : (m,) float
        Metres: signed distance of each reading to the other view's surface, and its noise.
    pair : (m, 2) int
        The views compared (source, target; 0 = the camera, j >= 1 = mirror j).
    """

    jacobian: np.ndarray
    residual: np.ndarray
    sigma: np.ndarray
    pair: np.ndarray

    def weights(self) -> np.ndarray:
        """(m,) Cauchy weights over each residual's variance."""
        return 1.0 / (1.0 + (self.residual / self.sigma / CAUCHY) ** 2) / self.sigma ** 2

    def step(self) -> tuple[np.ndarray, np.ndarray]:
        """One Gauss-Newton step of the refined mirrors' planes (planestep.moved_plane's steps).

        Returns
        -------
        step : (3k,) float
            Radians, radians, metres for each refined mirror in turn.
        hessian : (3k, 3k) float
            The weighted normal equations' matrix (a tiny ridge keeps it invertible while no view
            sees a mirror yet).
        """
        weights = self.weights()
        hessian = self.jacobian.T @ (weights[:, None] * self.jacobian)
        hessian += np.eye(len(hessian)) * 1e-9 * max(np.trace(hessian), 1.0)
        return -np.linalg.solve(hessian, self.jacobian.T @ (weights * self.residual)), hessian

    def involving(self, j: int, camera_only: bool = False) -> np.ndarray:
        """Select the comparisons of view j's readings with another view's, both ways.

        Parameters
        ----------
        j : int
            The view (0 the camera, j mirror j).
        camera_only : bool
            Only those with the camera's.

        Returns
        -------
        (m,) bool array
        """
        pick = (self.pair[:, 0] == j) | (self.pair[:, 1] == j)
        return pick & ((self.pair[:, 0] == 0) | (self.pair[:, 1] == 0)) if camera_only else pick

    def with_camera(self, j: int) -> int:
        """Count the comparisons between mirror j's readings and the camera's (both ways).

        Parameters
        ----------
        j : int
            1-based.

        Returns
        -------
        int
        """
        return int(np.count_nonzero(self.involving(j, camera_only=True)))

    def shared(self, j: int, views: set[int]) -> int:
        """Count the comparisons between mirror j's readings and those of `views` (both ways).

        Parameters
        ----------
        j : int
            1-based.
        views : set of int

        Returns
        -------
        int
        """
        pair = self.pair
        other = np.where(pair[:, 0] == j, pair[:, 1], np.where(pair[:, 1] == j, pair[:, 0], j))
        return int(np.count_nonzero(np.isin(other, list(views - {j}))))


def residuals(frames: list[FrameViews], planes: dict[int, Plane], refined: list[int],
              centre: np.ndarray, gate: float = 0.0) -> Residuals:
    """Compare, in each frame, every view's points with every other view.

    A mirror's points are reflected through its plane.

    Parameters
    ----------
    frames : list of FrameViews
        Each frame's views (agreement.frame_views).
    planes : dict
        {mirror j (1-based): Plane} of every mirror with a view.
    refined : list of int
        The mirrors whose steps are the jacobian's columns (three each, in this order).
    centre : (3,) float
        Metres, where the steps' offsets are measured.
    gate : float
        Metres added to what counts as the same surface.

    Returns
    -------
    Residuals
    """
    columns = {j: 3 * i for i, j in enumerate(refined)}
    parts = []
    for frame in frames:
        views = [j for j in frame.targets if j == 0 or j in planes]
        # the mirrors' points reflected into the real space
        real = {j: in_view(frame.points(j), planes.get(j)) for j in views}
        for b in views:
            for a in views:
                if a == b:
                    continue
                found = frame.targets[b].compare(in_view(real[a], planes.get(b)), gate)
                rows = np.zeros((len(found), 3 * len(refined)))
                if a in columns:
                    # the gradient pulled back to the real space first
                    pulled = found.direction
                    if b:
                        pulled = reflect_directions(planes[b], found.direction)
                    rows[:, columns[a]:columns[a] + 3] = reflection_jacobian(
                        planes[a], centre, frame.points(a).points[found.index], pulled)
                if b in columns:
                    rows[:, columns[b]:columns[b] + 3] += reflection_jacobian(
                        planes[b], centre, real[a].points[found.index], found.direction)
                pair = np.tile((a, b), (len(found), 1))
                parts.append((rows, found.residual, found.sigma, pair))
    if not parts:
        return Residuals(np.zeros((0, 3 * len(refined))), np.zeros(0), np.ones(0),
                         np.zeros((0, 2), int))
    return Residuals(*(np.concatenate(p) for p in zip(*parts)))


def agreement_mm(found: Residuals, j: int, camera_only: bool = False) -> tuple[float, float]:
    """Measure the comparisons involving mirror j.

    Parameters
    ----------
    found : Residuals
    j : int
        1-based.
    camera_only : bool
        Only those with the camera.

    Returns
    -------
    rms : float
        mm.
    mean : float
        mm, signed so that > 0 means its points lie outside the other views' surfaces.

    Notes
    -----
    Both are NaN without any comparison.
    """
    pick = found.involving(j, camera_only)
    signed = np.where(found.pair[pick, 0] == j, 1.0, -1.0) * found.residual[pick]
    if not len(signed):
        return float("nan"), float("nan")
    return float(1e3 * np.sqrt(np.mean(signed ** 2))), float(1e3 * np.mean(signed))


def noise_mm(found: Residuals, j: int, camera_only: bool = False) -> float:
    """Return the RMS (mm) that the depth noise of the readings compared would give alone.

    Over the comparisons involving mirror j.

    Parameters
    ----------
    found : Residuals
    j : int
        1-based.
    camera_only : bool
        Only those with the camera.

    Returns
    -------
    float
        mm; NaN without any comparison.
    """
    sigma = found.sigma[found.involving(j, camera_only)]
    return float(1e3 * np.sqrt(np.mean(sigma ** 2))) if len(sigma) else float("nan")


class ViewAgreement(NamedTuple):
    """How one mirror's view agrees with the others; all NaN without agreement.

    Attributes
    ----------
    rms_mm, mean_mm : float
        RMS and mean (mm, as in results.MirrorRefinement) over `points` comparisons of its
        readings with the other views' that agree (both ways).
    points : int
    noise_mm : float
        The RMS that the depth noise of the readings compared would give alone (their sigma
        along the surface's normal).
    camera_rms_mm, camera_mean_mm, camera_noise_mm, camera_points
        The same over its comparisons with the camera alone (a mirror that agrees with the
        camera but not with another mirror puts the other one in doubt).
    frames : int
        Over how many frames.
    step_shift_mm, step_tilt_deg : float
        How one refinement step of every plane would move this one: mm along its normal at the
        object (> 0 away from the camera) and degrees (what the disagreement points to).
    """

    rms_mm: float
    mean_mm: float
    points: int
    noise_mm: float
    camera_rms_mm: float = float("nan")
    camera_mean_mm: float = float("nan")
    camera_noise_mm: float = float("nan")
    camera_points: int = 0
    frames: int = 1
    step_shift_mm: float = float("nan")
    step_tilt_deg: float = float("nan")


def view_agreement(rig: Rig, depths: np.ndarray, masks: np.ndarray) -> dict[int, ViewAgreement]:
    """Measure how well each calibrated mirror's view agrees with the others now.

    Without changing anything (the report after a markers fit); with how one Gauss-Newton step of
    the refinement, all planes together, would move each plane.

    Parameters
    ----------
    rig : Rig
    depths, masks : (F, H, W) or (H, W) float metres and bool
        The frames as measured and their object pixels, as for refine.refine_planes.

    Returns
    -------
    dict
        {mirror index (0-based): ViewAgreement} for every mirror with a plane.
    """
    depths, masks = np.asarray(depths), np.asarray(masks, bool)
    if depths.ndim == 2:
        depths, masks = depths[None], masks[None]
    frames = [frame_views(rig, d, m) for d, m in zip(depths, masks)]
    planes = {j: m.plane for j, m in enumerate(rig.mirrors, start=1) if m.plane is not None}
    centre = np.mean([f.centre for f in frames], axis=0)
    refined = sorted(planes)
    found = residuals(frames, planes, refined, centre, SHOWN_GATE)
    step = found.step()[0] if len(found.residual) else np.zeros(3 * len(refined))
    out = {}
    for i, j in enumerate(refined):
        moved = moved_plane(planes[j], centre, step[3 * i:3 * i + 3])
        out[j - 1] = ViewAgreement(
            *agreement_mm(found, j), int(np.count_nonzero(found.involving(j))),
            noise_mm(found, j), *agreement_mm(found, j, camera_only=True),
            noise_mm(found, j, camera_only=True), found.with_camera(j), len(frames),
            1e3 * shift_at(planes[j], moved, centre), planes[j].angle_to(moved))
    return out


def reads_as_glass(from_markers: list[ViewAgreement], others: list[ViewAgreement]) -> bool:
    """Whether the views' disagreement is that of glass over the markers of every markers fit.

    Glass puts every plane fitted to markers on it nearer the camera by its thickness: a step of
    the refinement then moves them all away from the camera, by about as much (GLASS_STEP,
    GLASS_APART), without turning them (GLASS_TILT_DEG); the planes not from markers stay
    (their steps under GLASS_STEP's lower end).

    Parameters
    ----------
    from_markers : list of ViewAgreement
        The mirrors whose planes come from their markers without a glass.
    others : list of ViewAgreement
        The other mirrors with a plane.

    Returns
    -------
    bool
        False without a plane from markers, or while a step is unknown (NaN).
    """
    if not from_markers:
        return False
    shifts = 1e-3 * np.array([f.step_shift_mm for f in from_markers])
    tilts = np.array([f.step_tilt_deg for f in from_markers])
    still = 1e-3 * np.abs([f.step_shift_mm for f in others])
    return bool(np.all((shifts >= GLASS_STEP[0]) & (shifts <= GLASS_STEP[1]))
                and np.ptp(shifts) <= GLASS_APART and np.all(tilts <= GLASS_TILT_DEG)
                and np.all(still < GLASS_STEP[0]))
