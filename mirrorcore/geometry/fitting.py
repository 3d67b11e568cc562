"""Sphere and cylinder fitting to a cloud: RANSAC on minimal samples, then least squares on the
inliers (paper section 5).

Sphere: 4-point samples solved in closed form; refined by an algebraic then a geometric
(Gauss-Newton) least-squares fit. Cylinder: 2 points with normals (axis direction = n1 x n2, axis
through the closest points of the normal lines); refined by geometric least squares over axis
direction, axis point and radius. Both share one batched LO-RANSAC loop (each new best sample is
replaced by its least-squares local optimum) and one Gauss-Newton loop (loransac). Metres, camera
frame; models are flat float64 vectors internally, radius last.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import open3d as o3d

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.base.progress import Progress
from mirrorcore.geometry.loransac import (Model, gauss_newton, in_range, local_optimum, lo_ransac,
                                          ticker)
from mirrorcore.geometry.shapes import Cylinder, ShapeFit, Sphere

DEFAULT_THRESHOLD = 0.02
"""Inlier distance, metres: about 3 sigma of Kinect v1 depth noise at 2 m (5.7 mm axial noise and
11.5 mm depth steps: sigma ~ 6.6 mm). A threshold near 1 sigma truncates the noise and biases the
radius (TUM globe: 232.5 mm with 10 mm, 225.6 mm with 20 mm, same pixels)."""
DEFAULT_RADIUS_RANGE = (0.005, 5.0)
"""Radii (metres) outside which a RANSAC model is absurd for a depth-camera scene and is
rejected."""
_NORMAL_NEIGHBOURS = 24
_MIN_POINTS = {"sphere": 4, "cylinder": 5}


# -------------------------------------------------------------------------------------- public API
def fit_sphere(points: np.ndarray, rng: np.random.Generator, threshold: float = DEFAULT_THRESHOLD,
               sources: np.ndarray | None = None,
               radius_range: tuple[float, float] = DEFAULT_RADIUS_RANGE,
               confidence: float = 0.999, max_iterations: int = 20_000, where: str = "cloud",
               progress: Progress | None = None, cancel=None) -> ShapeFit:
    """Fit a sphere by RANSAC (4-point closed-form samples) and least squares on the inliers.

    Errors in the result are over ALL points (paper eq. 4) and also over the inliers only.

    Parameters
    ----------
    points : (n, 3) float array
        Metres, camera frame.
    rng : numpy.random.Generator
        The only source of randomness (same seed, same fit).
    threshold : float
        Inlier distance |dist(P, c) - R|, metres.
    sources : (n,) integer array, optional
        Labels (0 direct, j mirror j) for per-source errors.
    radius_range : (float, float)
        (min, max) radius, metres; samples outside are rejected, and so is a refined model.
    confidence : float
        RANSAC's probability of drawing one all-inlier sample.
    max_iterations : int
        The most samples drawn.
    where : str
        What the cloud is, for the messages.
    progress : Progress, optional
        progress(fraction) follows RANSAC's samples (up to `max_iterations` on a cloud that is not
        one sphere).
    cancel : threading.Event-like or callable, optional
        Stops the fit with Cancelled when it asks to (see `cancel_requested`).

    Returns
    -------
    ShapeFit

    Raises
    ------
    MirrorscanError
        Naming `where`: non-finite or too few points (< 4), or no sphere found.
    Cancelled
        `cancel` asked to stop.
    """
    return _fit("sphere", points, None, sources, rng, threshold, radius_range, confidence,
                max_iterations, where,
                ticker(progress, cancel, where))


def fit_cylinder(points: np.ndarray, rng: np.random.Generator, threshold: float = DEFAULT_THRESHOLD,
                 sources: np.ndarray | None = None, normals: np.ndarray | None = None,
                 radius_range: tuple[float, float] = DEFAULT_RADIUS_RANGE,
                 confidence: float = 0.999,
                 max_iterations: int = 20_000, where: str = "cloud",
                 progress: Progress | None = None,
                 cancel=None) -> ShapeFit:
    """Fit a cylinder by RANSAC (2 points with normals) and geometric least squares on the inliers.

    The axis point is the point of the axis closest to the inliers' centroid; the direction's
    largest component is positive. Estimated normals make rough 2-point samples: keep the threshold
    above a few mm (a few times the noise). Errors as in `fit_sphere` (paper eq. 5).

    Parameters
    ----------
    points : (n, 3) float array
        Metres, camera frame.
    rng : numpy.random.Generator
        The only source of randomness (same seed, same fit).
    threshold : float
        Inlier distance |dist(P, axis) - R|, metres.
    sources : (n,) integer array, optional
        Labels (0 direct, j mirror j) for per-source errors.
    normals : (n, 3) array, optional
        Any sign, any length > 0; estimated from the nearest neighbours with Open3D when None.
    radius_range : (float, float)
        (min, max) radius, metres; samples outside are rejected, and so is a refined model.
    confidence : float
        RANSAC's probability of drawing one all-inlier sample.
    max_iterations : int
        The most samples drawn.
    where : str
        What the cloud is, for the messages.
    progress : Progress, optional
        progress(fraction) follows RANSAC's samples.
    cancel : threading.Event-like or callable, optional
        Stops the fit with Cancelled when it asks to.

    Returns
    -------
    ShapeFit

    Raises
    ------
    MirrorscanError
        Naming `where`: non-finite or too few points (< 5), normals of the wrong shape, or no
        cylinder found.
    Cancelled
        `cancel` asked to stop.
    """
    return _fit("cylinder", points, normals, sources, rng, threshold, radius_range, confidence,
                max_iterations, where,
                ticker(progress, cancel, where))


def estimate_normals(points: np.ndarray, neighbours: int = _NORMAL_NEIGHBOURS) -> np.ndarray:
    """Estimate unit normals by PCA of each point's nearest neighbours.

    Parameters
    ----------
    points : (n, 3) array
        Metres.
    neighbours : int
        The number of nearest neighbours.

    Returns
    -------
    (n, 3) float64 array
        Unit normals, sign arbitrary.
    """
    xyz = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(xyz))
    cloud.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(neighbours))
    return np.asarray(cloud.normals)


# ----------------------------------------------------------------------------- the shared pipeline
def _fit(kind: str, points: np.ndarray, normals: np.ndarray | None, sources: np.ndarray | None,
         rng: np.random.Generator, threshold: float, radius_range: tuple[float, float],
         confidence: float,
         max_iterations: int, where: str, tick: Callable[[float], None]) -> ShapeFit:
    """Check the input, centre it (for conditioning), run RANSAC and the refinement, and measure the
    errors."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(points) < _MIN_POINTS[kind]:
        raise MirrorscanError(f"{where}: a {kind} fit needs at least {_MIN_POINTS[kind]} points, "
                              f"got {len(points)}")
    if not np.all(np.isfinite(points)):
        raise MirrorscanError(f"{where}: the cloud has non-finite coordinates")
    if not threshold > 0:
        raise MirrorscanError(f"{where}: the inlier threshold must be positive, got {threshold} m")
    if sources is not None and len(np.reshape(sources, -1)) != len(points):
        raise MirrorscanError(f"{where}: {len(points)} points but {len(np.reshape(sources, -1))} "
                              "source labels")
    origin = points.mean(axis=0)
    centred = points - origin
    if kind == "sphere":
        propose, distances = _sphere_propose(centred), _sphere_distances(centred)
        refine = _sphere_refine
        sample_size = 4
    else:
        normals = estimate_normals(points) if normals is None else np.asarray(normals,
                                                                              dtype=np.float64)
        if normals.shape != points.shape:
            raise MirrorscanError(f"{where}: {len(points)} points but normals of shape "
                                  f"{normals.shape}")
        propose, distances = _cylinder_propose(centred, normals), _cylinder_distances(centred)
        refine = _cylinder_refine
        sample_size = 2
    min_points = _MIN_POINTS[kind]
    radius_mm = f"{1e3 * radius_range[0]:g}-{1e3 * radius_range[1]:g} mm"

    def optimise(model: Model) -> tuple[Model, int]:
        return local_optimum(centred, model, threshold, distances, refine, min_points)
    model = lo_ransac(len(points), sample_size, min_points, propose, distances, optimise, threshold,
                    rng, radius_range,
                    confidence, max_iterations, tick)
    if model is None:
        raise MirrorscanError(f"{where}: no {kind} found (no {kind} of radius {radius_mm} has "
                              f"{min_points} points "
                              f"within {1e3 * threshold:g} mm)")
    # the least-squares fit on the inliers (unchanged if RANSAC's best was one)
    model, count = optimise(model)
    if count < min_points or not in_range(model[-1], radius_range):
        raise MirrorscanError(f"{where}: the least-squares {kind} (radius {1e3 * model[-1]:.1f} "
                              f"mm) has {count} points "
                              f"within {1e3 * threshold:g} mm or a radius outside {radius_mm} (is "
                              "the cloud one plane?)")
    shape = _sphere_shape(model, origin) if kind == "sphere" else _cylinder_shape(model, origin,
                                                                                  centred,
                                                                                   distances,
                                                                                   threshold)
    deviations = shape.deviations(points)
    return ShapeFit(shape, np.abs(deviations) < threshold, deviations,
                    None if sources is None else np.asarray(sources).reshape(-1).astype(np.uint8),
                    float(threshold))


# ------------------------------------------------------------------------------------------ sphere
def _sphere_propose(points: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """Closed-form sphere through 4 points: 2 (p_i - p_0).c = |p_i|^2 - |p_0|^2, i = 1..3, by
    Cramer's rule (rows of a 3x3 system, batched); NaN rows when the 4 points are (nearly)
    coplanar."""
    def propose(samples: np.ndarray) -> np.ndarray:
        p = points[samples]                                    # (m, 4, 3)
        rows = 2.0 * (p[:, 1:] - p[:, :1])                     # (m, 3, 3)
        rhs = np.sum(p[:, 1:] ** 2, axis=2) - np.sum(p[:, :1] ** 2, axis=2)   # (m, 3)
        cof = np.stack([np.cross(rows[:, 1], rows[:, 2]), np.cross(rows[:, 2], rows[:, 0]),
                        # (m, 3, 3), det = rows[0] . cof[0]
                        np.cross(rows[:, 0], rows[:, 1])], axis=1)
        det = np.einsum("ij,ij->i", rows[:, 0], cof[:, 0])
        scale = np.prod(np.linalg.norm(rows, axis=2), axis=1)
        det = np.where(np.abs(det) > 1e-9 * scale, det, np.nan)
        center = np.einsum("ik,ikj->ij", rhs, cof) / det[:, None]
        return np.column_stack([center, np.linalg.norm(p[:, 0] - center, axis=1)])
    return propose


def _sphere_distances(points: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """models (m, 4) -> (n, m) signed deviations |P - c| - R, via |P|^2 - 2 P.c + |c|^2 (one matrix
    product)."""
    sq = np.sum(points ** 2, axis=1)[:, None]

    def distances(models: np.ndarray) -> np.ndarray:
        c = models[:, :3]
        d2 = sq - 2.0 * points @ c.T + np.sum(c ** 2, axis=1)
        return np.sqrt(np.maximum(d2, 0.0)) - models[:, 3]
    return distances


def _sphere_refine(points: np.ndarray, model: Model) -> Model:
    """Algebraic least squares ([2P, 1] [c, R^2 - |c|^2] = |P|^2), then geometric least squares
    (Gauss-Newton on |P - c| - R) from it. The RANSAC model only chose the inliers."""
    solution = np.linalg.lstsq(np.column_stack([2.0 * points, np.ones(len(points))]),
                               np.sum(points ** 2, axis=1),
                               rcond=None)[0]
    center = solution[:3]
    start = np.append(center, np.sqrt(max(solution[3] + center @ center, 0.0)))

    def residuals_jacobian(m: Model) -> tuple[np.ndarray, np.ndarray]:
        q = points - m[:3]
        dist = np.linalg.norm(q, axis=1)
        return dist - m[3], np.column_stack([-q / np.maximum(dist, 1e-300)[:, None],
                                             -np.ones(len(points))])
    return gauss_newton(start, residuals_jacobian, lambda m, delta: m + delta)


def _sphere_shape(model: Model, origin: np.ndarray) -> Sphere:
    """The Sphere of a centred model [cx, cy, cz, R], moved back by `origin`."""
    return Sphere(tuple(float(x) for x in model[:3] + origin), float(model[3]))


# ---------------------------------------------------------------------------------------- cylinder
def _cylinder_propose(points: np.ndarray, normals: np.ndarray) -> Callable[[np.ndarray],
                                                                           np.ndarray]:
    """Cylinder from 2 points with normals: direction n1 x n2; axis point = midpoint of the closest
    points of the lines p_i + t n_i; radius = mean distance of the two points to that axis. NaN rows
    for (nearly) parallel normals."""
    def propose(samples: np.ndarray) -> np.ndarray:
        p1, p2 = points[samples[:, 0]], points[samples[:, 1]]
        n1, n2 = normals[samples[:, 0]], normals[samples[:, 1]]
        direction = np.cross(n1, n2)
        b, a, c = (np.einsum("ij,ij->i", x, y) for x, y in ((n1, n2), (n1, n1), (n2, n2)))
        denom = a * c - b * b                                  # = |n1 x n2|^2
        # normals within ~0.06 degrees: degenerate
        denom = np.where(denom > 1e-6 * a * c, denom, np.nan)
        w = p1 - p2
        d, e = np.einsum("ij,ij->i", n1, w), np.einsum("ij,ij->i", n2, w)
        t, s = (b * e - c * d) / denom, (a * e - b * d) / denom
        axis_point = 0.5 * (p1 + t[:, None] * n1 + p2 + s[:, None] * n2)
        direction /= np.sqrt(denom)[:, None]
        radius = 0.5 * (_line_distance(p1, axis_point, direction) + _line_distance(p2, axis_point,
                                                                                   direction))
        return np.column_stack([axis_point, direction, radius])
    return propose


def _line_distance(p: np.ndarray, point: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Row-wise distance of p (m, 3) to the lines (point (m, 3), unit direction (m, 3)) -> (m,)."""
    q = p - point
    return np.linalg.norm(q - np.einsum("ij,ij->i", q, direction)[:, None] * direction, axis=1)


def _cylinder_distances(points: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """models (m, 7) -> (n, m) signed deviations dist(P, axis) - R, via |P - a|^2 - ((P - a).d)^2 as
    matrix products."""
    sq = np.sum(points ** 2, axis=1)[:, None]

    def distances(models: np.ndarray) -> np.ndarray:
        a, d = models[:, :3], models[:, 3:6]
        along = points @ d.T - np.einsum("ij,ij->i", a, d)
        d2 = sq - 2.0 * points @ a.T + np.sum(a ** 2, axis=1) - along ** 2
        return np.sqrt(np.maximum(d2, 0.0)) - models[:, 6]
    return distances


def _perpendicular_basis(direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (3,) making a right-handed orthonormal basis with the unit `direction`
    (3,)."""
    helper = np.eye(3)[np.argmin(np.abs(direction))]
    u = np.cross(direction, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(direction, u)


def _cylinder_refine(points: np.ndarray, model: Model) -> Model:
    """Geometric least squares (Gauss-Newton) on dist(P, axis) - R over 5 parameters: the direction
    tilted by (alpha u + beta v), the axis point moved by (gamma u + delta v), the radius; u, v
    perpendicular to the direction."""
    def residuals_jacobian(m: Model) -> tuple[np.ndarray, np.ndarray]:
        d = m[3:6]
        u, v = _perpendicular_basis(d)
        q = points - m[:3]
        along = q @ d
        # perpendicular part, |w| = distance to the axis
        w = q - along[:, None] * d
        dist = np.linalg.norm(w, axis=1)
        e = w / np.maximum(dist, 1e-300)[:, None]
        eu, ev = e @ u, e @ v
        # d(dist)/d(tilt along u) = -(q.d)(e.u); d(dist)/d(shift along u) = -(e.u); same for v; d/dR
        # = -1
        J = np.column_stack([-along * eu, -along * ev, -eu, -ev, -np.ones(len(points))])
        return dist - m[6], J

    def step(m: Model, delta: np.ndarray) -> Model:
        u, v = _perpendicular_basis(m[3:6])
        d = m[3:6] + delta[0] * u + delta[1] * v
        return np.concatenate([m[:3] + delta[2] * u + delta[3] * v, d / np.linalg.norm(d),
                               [m[6] + delta[4]]])
    return gauss_newton(model, residuals_jacobian, step)


def _cylinder_shape(model: Model, origin: np.ndarray, points: np.ndarray,
                    distances: Callable[[np.ndarray], np.ndarray], threshold: float) -> Cylinder:
    """The canonical cylinder: axis point closest to the inliers' centroid, direction's largest
    component positive."""
    a, d = model[:3], model[3:6]
    d = d if d[np.argmax(np.abs(d))] > 0 else -d
    centroid = points[np.abs(distances(model[None])[:, 0]) < threshold].mean(axis=0)
    a = a + ((centroid - a) @ d) * d + origin
    return Cylinder(tuple(float(x) for x in a), tuple(float(x) for x in d), float(model[6]))

