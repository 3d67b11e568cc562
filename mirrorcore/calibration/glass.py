"""A mirror's glass: how far its markers' faces stand in front of the refined plane (the silver),
and how well that is known."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from mirrorcore.calibration.fit import MIN_MARKER_PIXELS, marker_points
from mirrorcore.calibration.results import METHOD_BIAS, MirrorRefinement
from mirrorcore.depth.noise import axial_sigma
from mirrorcore.depth.ops import MEAN_SIGMAS
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.session import MAX_MARKER_OFFSET


class Glass(NamedTuple):
    """How far markers' faces stand in front of a plane (marker_offset).

    Attributes
    ----------
    offset : float
        Metres.
    spread : float
        Metres: the spread of the markers' own offsets over the square root of their number.
    centroid : (3,) float
        Metres, camera frame: the mean of their readings.
    """

    offset: float
    spread: float
    centroid: np.ndarray


def marker_offset(intr: Intrinsics, depth: np.ndarray, markers, plane: Plane) -> Glass | None:
    """How far (metres) markers' faces stand in front of `plane` (towards the camera).

    The mean signed distance of their readings (fit.marker_points; reduced inside the markers'
    windows to their robust mean, as a median snaps to the camera's disparity steps) within
    MEAN_SIGMAS of the depth noise of their median; 0 when that is negative (markers cannot stand
    behind the silver: that is the readings' noise). A marker that reads more than
    MAX_MARKER_OFFSET off the plane (something in front of it, such as a person walking past) is
    left out.

    Parameters
    ----------
    intr : Intrinsics
    depth : (H, W) or (k, H, W) float
        Metres: one depth image or frames.
    markers : sequence of (u, v)
        Pixels.
    plane : Plane

    Returns
    -------
    Glass or None
        None with fewer than 3 usable markers or an answer beyond MAX_MARKER_OFFSET (not markers
        on this mirror's glass).
    """
    groups = [marker_points(intr, depth, m).astype(np.float64) for m in markers]
    groups = [g for g in groups if len(g) >= MIN_MARKER_PIXELS]
    pairs = [(g, _trimmed_mean(plane.signed_distance(g), g[:, 2])) for g in groups]
    # not hidden behind the object
    pairs = [(g, offset) for g, offset in pairs if abs(offset) <= MAX_MARKER_OFFSET]
    if len(pairs) < 3:
        return None
    usable, each = [g for g, _ in pairs], [offset for _, offset in pairs]
    readings = np.concatenate(usable)
    offset = _trimmed_mean(plane.signed_distance(readings), readings[:, 2])
    if abs(offset) > MAX_MARKER_OFFSET:
        return None
    spread = float(np.std(each, ddof=1) / np.sqrt(len(each)))
    return Glass(max(offset, 0.0), spread, readings.mean(axis=0))


def _trimmed_mean(distances: np.ndarray, z: np.ndarray) -> float:
    """The mean of `distances` (n,) metres within MEAN_SIGMAS of the depth noise at depths z (n,)
    of their median."""
    keep = np.abs(distances - np.median(distances)) <= MEAN_SIGMAS * axial_sigma(z)
    return float(np.mean(distances[keep]))


def glass_std(report: MirrorRefinement, glass: Glass, centre) -> float:
    """Return the 1 sigma of a mirror's glass, metres.

    Its markers' spread, the refined plane's own uncertainty where they are (its offset's at the
    object and its tilt's over the way there) and, likewise, what the method may add (METHOD_BIAS),
    since the planes' own 1 sigma alone understates it.

    Parameters
    ----------
    report : MirrorRefinement
    glass : Glass
    centre : (3,) array
        Metres, the object.

    Returns
    -------
    float
        Metres.
    """
    along = glass.centroid - np.asarray(centre)
    away = np.linalg.norm(along - (along @ report.after.n) * report.after.n)
    bias = METHOD_BIAS["sphere" if report.sphere_radius_mm is not None else "surfaces"]
    plane = np.hypot(1e-3 * report.shift_std_mm, np.radians(report.tilt_std_deg) * away)
    method = np.hypot(bias.shift, np.radians(bias.tilt_deg) * away)
    return float(np.sqrt(glass.spread ** 2 + plane ** 2 + method ** 2))
