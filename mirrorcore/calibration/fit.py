"""Mirror calibration, the three ways of the paper's section 3: from markers on the glass, from the
mirror's frame (a region), and from pairs of real and virtual points of a calibration object."""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mirrorcore.depth.files import require_readings
from mirrorcore.depth.ops import median_depth, without_occluders
from mirrorcore.base.errors import CalibrationError
from mirrorcore.geometry.camera import Intrinsics, check_depth_shape, reproject_pixels
from mirrorcore.geometry.plane import Plane, fit_plane_ransac
from mirrorcore.geometry.polygon import polygon_mask, validate_polygon
from mirrorcore.calibration.markers import (MARKER_WINDOW, MIN_MARKER_PIXELS,
                                            MarkerResiduals, marker_points, marker_residuals)
from mirrorcore.depth.noise import axial_sigma
from mirrorcore.io.session import Session, SessionMirror

MIN_MARKER_SPREAD = 0.03   # metres: marker centres closer than this to one line are collinear
MIN_REGION_PIXELS = 50     # a region calibration needs at least this many valid pixels
# RANSAC inlier threshold in standard deviations of the depth noise at each point
INLIER_SIGMAS = 3.0
# metres: a mirror plane passing closer to the camera than this is refused
MIN_CAMERA_DISTANCE = 0.05
# a session's markers and regions are read on its background and up to this many of its frames,
# evenly spaced (per pixel, the regions on their median, the markers on their robust mean:
# markers.marker_points)
MAX_MARKER_FRAMES = 30


@dataclass(frozen=True)
class Calibration:
    """A fitted mirror plane and how well the data support it.

    Attributes
    ----------
    plane : Plane
    rms_mm : float
        RMS distance of the inlier points to the plane, mm.
    n_points, n_inliers : int
        Points used / kept by RANSAC.
    markers : MarkerResiduals or None
        For a markers fit, how far each marker's centre lies from the plane against the noise there
        (None for region and pair calibrations).
    centre : (float, float, float)
        Metres, the middle of the points used (where a change of the plane is measured).
    marker_offset : float
        Metres, the glass the markers fit put between its markers and the plane.
    """

    plane: Plane
    rms_mm: float
    n_points: int
    n_inliers: int
    markers: MarkerResiduals | None = None
    centre: tuple[float, float, float] = (0.0, 0.0, 0.0)
    marker_offset: float = 0.0


def calibrate_from_markers(intr: Intrinsics, depth: np.ndarray, markers, rng: np.random.Generator,
                           name: str = "mirror", window: int = MARKER_WINDOW,
                           marker_offset: float = 0.0) -> Calibration:
    """Fit a mirror plane to the markers stuck on its glass (RANSAC, then SVD on the inliers).

    The inlier threshold is INLIER_SIGMAS times the depth noise at each point.

    Parameters
    ----------
    intr : Intrinsics
    depth : (H, W) or (k, H, W) float
        Metres; several frames are reduced to their per-pixel robust mean, inside the markers'
        windows only (markers.marker_points).
    markers : (m, 2) float
        Clicked pixels (u, v); each contributes the valid pixels within `window` pixels.
    rng : numpy.random.Generator
        RANSAC's only source of randomness.
    name : str
        The mirror, named in errors.
    window : int
        Pixels.
    marker_offset : float
        Metres from the markers' faces to the reflecting surface (the silver behind the glass):
        the plane fitted to the markers is moved this far away from the camera, along its normal.
        The residuals stay those of the markers' own plane.

    Returns
    -------
    Calibration

    Raises
    ------
    CalibrationError
        Naming the mirror and the markers when fewer than 3 markers have depth, the markers are
        collinear, or the plane passes through the camera.
    """
    depth = np.asarray(depth)
    check_depth_shape(intr, depth[-1] if depth.ndim == 3 else depth, f"{name}: depth image")
    markers = np.asarray(markers, dtype=np.float64).reshape(-1, 2)
    groups = [marker_points(intr, depth, m, window) for m in markers]
    usable = [len(g) >= MIN_MARKER_PIXELS for g in groups]
    if sum(usable) < 3:
        dead = [i + 1 for i, ok in enumerate(usable) if not ok]
        detail = (f"; marker(s) {', '.join(map(str, dead))} have no depth reading within "
                  f"{window} px" if dead else "")
        raise CalibrationError(
            f"{name}: {sum(usable)} usable marker(s) of {len(markers)}, 3 are needed{detail}")
    centres = np.array([np.median(g, axis=0) for g, ok in zip(groups, usable) if ok])
    spread = _distance_to_best_line(centres).max()
    if spread < MIN_MARKER_SPREAD:
        used = [i + 1 for i, ok in enumerate(usable) if ok]
        raise CalibrationError(
            f"{name}: markers {', '.join(map(str, used))} are (nearly) collinear "
                               f"(all within {spread * 1000:.0f} mm of one line); place one off "
                               "that line")
    points = np.concatenate([g for g, ok in zip(groups, usable) if ok])
    fit = fit_plane_ransac(points, INLIER_SIGMAS * axial_sigma(points[:, 2]), rng, where=name)
    _check_camera_side(fit.plane, name)
    silver = Plane(fit.plane.normal, fit.plane.d + float(marker_offset))
    _check_camera_side(silver, name)
    return Calibration(silver, fit.rms * 1e3, len(points), int(fit.inliers.sum()),
                       marker_residuals(intr, depth, markers, fit.plane, window),
                       _centre(points[fit.inliers]),
                       float(marker_offset))


def calibrate_from_region(intr: Intrinsics, depth: np.ndarray, polygon, rng: np.random.Generator,
                          name: str = "mirror") -> Calibration:
    """Fit a mirror plane to all valid pixels inside a polygon drawn on the mirror's frame.

    The paper's region calibration ("if it is large enough").

    Parameters
    ----------
    intr : Intrinsics
    depth : (H, W) or (k, H, W) float array
        Metres.
    polygon : (b, 2) array
        Pixels (u, v).
    rng : numpy.random.Generator
        RANSAC's only source of randomness.
    name : str
        The mirror, named in errors.

    Returns
    -------
    Calibration

    Raises
    ------
    CalibrationError
        The region has fewer than MIN_REGION_PIXELS readings or is too thin for a plane.
    """
    depth = check_depth_shape(intr, median_depth(depth), f"{name}: depth image")
    polygon = validate_polygon(polygon, intr.shape, f"{name}: region")
    inside = polygon_mask(polygon, intr.shape) & (depth > 0)
    v, u = np.nonzero(inside)
    if len(u) < MIN_REGION_PIXELS:
        raise CalibrationError(
            f"{name}: the region has {len(u)} pixels with depth, {MIN_REGION_PIXELS} are needed")
    points = reproject_pixels(intr, u, v, depth[v, u])
    if _distance_to_best_line(points).max() < MIN_MARKER_SPREAD:
        raise CalibrationError(f"{name}: the region is too thin to define a plane")
    fit = fit_plane_ransac(points, INLIER_SIGMAS * axial_sigma(points[:, 2]), rng, where=name)
    _check_camera_side(fit.plane, name)
    return Calibration(fit.plane, fit.rms * 1e3, len(points), int(fit.inliers.sum()),
                       centre=_centre(points))


def calibrate_from_pairs(real_points, virtual_points, name: str = "mirror") -> Calibration:
    """Fit the mirror plane as the least-squares perpendicular bisector of pairs (real, virtual).

    The normal is the mean of the unit directions virtual -> real (towards the camera's side); d
    makes the plane pass through the pairs' midpoints on average. rms_mm reports the RMS of
    |reflect(virtual) - real| / 2, the distance of each virtual point's reflection to where the
    plane puts it.

    Parameters
    ----------
    real_points, virtual_points : (k, 3) array
        Metres, camera frame, k >= 1; pair i is one feature of a calibration object seen directly
        and behind the mirror.
    name : str
        The mirror, named in errors.

    Returns
    -------
    Calibration

    Raises
    ------
    CalibrationError
        No pairs, coincident pairs, or a camera behind the resulting plane.
    """
    real = np.asarray(real_points, dtype=np.float64).reshape(-1, 3)
    virtual = np.asarray(virtual_points, dtype=np.float64).reshape(-1, 3)
    if len(real) == 0 or real.shape != virtual.shape:
        raise CalibrationError(
            f"{name}: pairs need as many real points as virtual ones, at least one "
                               f"(got {len(real)} and {len(virtual)})")
    diff = real - virtual
    length = np.linalg.norm(diff, axis=1)
    if np.any(length < 1e-6):
        raise CalibrationError(
            f"{name}: pair(s) {', '.join(str(i + 1) for i in np.nonzero(length < 1e-6)[0])} "
                               "have the real and virtual point in the same place")
    n = (diff / length[:, None]).mean(axis=0)
    n /= np.linalg.norm(n)
    d = -float(np.mean((real + virtual) / 2 @ n))
    if d <= 0:
        raise CalibrationError(
            f"{name}: these pairs put the camera behind the mirror; are the real and virtual "
                               "points swapped?")
    plane = Plane.from_abcd([*n, d])
    _check_camera_side(plane, name)
    err = np.linalg.norm(plane.reflect(virtual) - real, axis=1) / 2
    return Calibration(plane, float(np.sqrt(np.mean(err ** 2))) * 1e3, len(real), len(real),
                       centre=_centre((real + virtual) / 2))


def calibrate_session(session: Session, depth: np.ndarray, rng: np.random.Generator, indices=None,
                      method: str = "markers") -> tuple[Session, list[tuple[int, Calibration]]]:
    """Fit the planes of a session's mirrors; all or nothing.

    From their markers (moved back by each mirror's marker_offset), or with method 'region' from
    each mirror's region polygon. The first refusal raises and nothing is returned.

    Parameters
    ----------
    session : Session
    depth : (H, W) or (k, H, W) float array
        Metres.
    rng : numpy.random.Generator
    indices : iterable of int, optional
        The mirrors to fit (0-based); default all.
    method : str
        'markers' or 'region'.

    Returns
    -------
    session : Session
        With the new planes.
    calibrations : list of (int, Calibration)
        (index, Calibration) for each mirror calibrated.

    Raises
    ------
    CalibrationError
    """
    indices = range(len(session.mirrors)) if indices is None else list(indices)
    if not len(indices):
        raise CalibrationError(f"{session.path}: the session has no mirrors")
    results = [(i, _calibrate_mirror(session, session.mirrors[i], depth, method, rng))
               for i in indices]
    for i, result in results:
        session = session.with_mirror(i, replace(session.mirrors[i], plane=result.plane))
    return session, results


def _calibrate_mirror(session: Session, mirror: SessionMirror, depth: np.ndarray, method: str,
                      rng: np.random.Generator) -> Calibration:
    """Fit one session mirror's plane from its markers or, with 'region', its region."""
    if method == "region":
        if not mirror.region:
            raise CalibrationError(f"{mirror.name}: no 'region' polygon in the session")
        return calibrate_from_region(session.camera, depth, mirror.region, rng, mirror.name)
    return calibrate_from_markers(session.camera, depth, mirror.markers, rng, mirror.name,
                                  marker_offset=mirror.marker_offset)


def _centre(points: np.ndarray) -> tuple[float, float, float]:
    """The mean of points (n, 3) as a tuple of floats, metres."""
    return tuple(float(c) for c in np.mean(points, axis=0))


def _distance_to_best_line(points: np.ndarray) -> np.ndarray:
    """(n,) distances (metres) of points (n, 3) to their least-squares line."""
    centred = points - points.mean(axis=0)
    if len(points) < 2:
        return np.zeros(len(points))
    direction = np.linalg.svd(centred, full_matrices=False)[2][0]
    return np.linalg.norm(centred - np.outer(centred @ direction, direction), axis=1)


def _check_camera_side(plane: Plane, name: str) -> None:
    """Refuse a plane that passes nearer than MIN_CAMERA_DISTANCE to the camera."""
    if plane.d < MIN_CAMERA_DISTANCE:
        raise CalibrationError(
            f"{name}: the fitted plane passes {plane.d * 1000:.0f} mm from the camera; the camera "
                               "must face the mirror, not lie in its plane")


def calibration_depth(session: Session, frame: int | None = None) -> np.ndarray:
    """Return the depth a session's planes are fitted on (markers, region).

    The frame asked for, or its background and up to MAX_MARKER_FRAMES evenly spaced frames,
    without what passes in front of the background in them (`static_frames`).

    Parameters
    ----------
    session : Session
    frame : int, optional
        The frame (0-based).

    Returns
    -------
    (k, H, W) float32 array
        Metres.

    Raises
    ------
    CalibrationError
        Without any frame or background.
    MirrorscanError
        Naming them, when no pixel of theirs has a reading.
    """
    if frame is not None:
        return require_readings(session.read_frame(frame)[None],
                                str(Path(session.root) / session.frames[frame]))
    frames = [session.read_frame(int(i)) for i in session.spread_frames(MAX_MARKER_FRAMES)]
    stack = static_frames(np.stack(frames) if frames else None, session.read_background())
    if stack is None:
        raise CalibrationError(f"{session.path}: no frames and no background to calibrate from")
    return require_readings(stack, f"{session.path}: the frames and the background")


def static_frames(frames: np.ndarray | None, background: np.ndarray | None) -> np.ndarray | None:
    """Return what markers and regions are read on.

    The frames less what passes in front of the background in them (depth.ops.without_occluders),
    then the background itself; either alone when the other is None.

    Parameters
    ----------
    frames : (k, H, W) float array or None
        Metres.
    background : (H, W) float array or None
        Metres.

    Returns
    -------
    (k + 1, H, W) float32 array or None
        None without both.
    """
    if background is None:
        return None if frames is None else np.asarray(frames, dtype=np.float32)
    background = np.asarray(background, dtype=np.float32)[None]
    return background if frames is None else np.concatenate([without_occluders(frames, background[
        0]), background])
