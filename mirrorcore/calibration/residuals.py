"""The comparisons of every view with every other as residuals of the mirror planes (the
refinement's Gauss-Newton rows), and how well each mirror's view agrees with the others."""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from mirrorcore.calibration.agreement import SHOWN_GATE, FrameViews, frame_views, in_view
from mirrorcore.calibration.planestep import reflection_jacobian
from mirrorcore.calibration.readings import reflect_directions
from mirrorcore.geometry.plane import Plane
from mirrorcore.rig.model import Rig

# The Cauchy weight's scale, in standard deviations (95 % efficient on Gaussian noise).
CAUCHY = 2.385


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


def view_agreement(rig: Rig, depths: np.ndarray, masks: np.ndarray) -> dict[int, ViewAgreement]:
    """Measure how well each calibrated mirror's view agrees with the others now.

    Without changing anything (the report after a markers fit).

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
    found = residuals(frames, planes, [], centre, SHOWN_GATE)
    out = {}
    for j in planes:
        out[j - 1] = ViewAgreement(
            *agreement_mm(found, j), int(np.count_nonzero(found.involving(j))),
            noise_mm(found, j), *agreement_mm(found, j, camera_only=True),
            noise_mm(found, j, camera_only=True), found.with_camera(j), len(frames))
    return out
