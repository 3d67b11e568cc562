"""Planes, signed distances and reflection through a mirror plane (paper eq. 2 and 3), plane fitting
by SVD and RANSAC.

Convention (docs/DESIGN.md): a plane is (a, b, c, d) with a unit normal n = (a, b, c) pointing to
the camera's side, so that n.P + d > 0 in front of the mirror (the camera's side; d > 0 because the
camera is at the origin) and < 0 behind it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirrorcore.base.errors import CalibrationError
from mirrorcore.geometry.ransac import ransac_iterations


@dataclass(frozen=True)
class Plane:
    """An oriented plane n.P + d = 0, |n| = 1, the camera (origin) on the positive side (d > 0).

    Attributes
    ----------
    normal : (float, float, float)
        The unit normal n, towards the camera.
    d : float
        Metres, > 0.
    """

    normal: tuple[float, float, float]
    d: float

    @classmethod
    def from_abcd(cls, abcd, where: str = "plane", orient: bool = True) -> "Plane":
        """Build a plane from (a, b, c, d), normalised.

        Parameters
        ----------
        abcd : array_like
            4 finite numbers [a, b, c, d].
        where : str
            What the plane is, for the messages.
        orient : bool
            True flips a plane given with d < 0 to the camera's side; False refuses it (the
            convention says the camera is in front, d > 0: a stored plane with d < 0 would put the
            camera behind the mirror).

        Returns
        -------
        Plane

        Raises
        ------
        CalibrationError
            Not 4 finite numbers, a zero normal, a plane through the camera (d = 0), or d < 0 with
            `orient` False.
        """
        try:
            p = np.asarray(abcd, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError, OverflowError):
            p = np.full(0, np.nan)
        if p.shape != (4,) or not np.all(np.isfinite(p)):
            raise CalibrationError(
                f"{where}: a plane needs 4 finite numbers [a, b, c, d], got {str(abcd)[:80]}")
        # components near the float limit would overflow the norm
        p = p / max(1.0, np.abs(p[:3]).max())
        norm = np.linalg.norm(p[:3])
        if norm < 1e-12:
            raise CalibrationError(f"{where}: the plane's normal (a, b, c) is zero")
        if abs(norm - 1.0) > 1e-12:     # a stored unit normal loads bit for bit
            p = p / norm
        if abs(p[3]) < 1e-9:
            raise CalibrationError(f"{where}: the plane passes through the camera")
        if p[3] < 0:
            if not orient:
                raise CalibrationError(
                    f"{where}: d < 0 puts the camera behind the mirror; a plane's normal must "
                                       "point to the camera's side (d > 0)")
            p = -p
        return cls((float(p[0]), float(p[1]), float(p[2])), float(p[3]))

    @classmethod
    def from_point_normal(cls, point, normal) -> "Plane":
        """Return the plane through a point with a normal, oriented to the camera's side.

        Parameters
        ----------
        point : (3,) array
            Metres, camera frame.
        normal : (3,) array
            Any length > 0, any sign.

        Returns
        -------
        Plane

        Raises
        ------
        CalibrationError
            A zero normal, or a plane through the camera.
        """
        n = np.asarray(normal, dtype=np.float64)
        return cls.from_abcd([*n, -float(np.dot(n, point))])

    @property
    def n(self) -> np.ndarray:
        """(3,) float64 unit normal, towards the camera."""
        return np.array(self.normal)

    @property
    def abcd(self) -> np.ndarray:
        """(4,) float64 [a, b, c, d]."""
        return np.array([*self.normal, self.d])

    def to_list(self) -> list[float]:
        """[a, b, c, d] as floats."""
        return [float(x) for x in self.abcd]

    def signed_distance(self, points: np.ndarray) -> np.ndarray:
        """Return the signed distances of points to the plane.

        Parameters
        ----------
        points : (..., 3) array
            Metres, camera frame.

        Returns
        -------
        (...,) array
            Metres, > 0 on the camera's side, < 0 behind the mirror; float32 for float32 points,
            else float64.
        """
        points = np.asarray(points)
        return points @ self.n.astype(points.dtype if points.dtype == np.float32
                                      else np.float64) + self.d

    def reflect(self, points: np.ndarray) -> np.ndarray:
        """Reflect points through the plane (paper eq. 3): P_r = P - 2 (n.P + d) n.

        Parameters
        ----------
        points : (..., 3) array
            Metres, camera frame.

        Returns
        -------
        (..., 3) array
            Same float dtype (float32 stays float32; other dtypes give float64).
        """
        points = np.asarray(points)
        dtype = points.dtype if points.dtype in (np.float32, np.float64) else np.float64
        points = points.astype(dtype, copy=False)
        n = self.n.astype(dtype)
        return points - (2 * (points @ n + dtype.type(self.d)))[..., None] * n

    def reflection_matrix(self) -> np.ndarray:
        """(4, 4) float64 homogeneous reflection: [I - 2 n n^T, -2 d n; 0, 1].

        It is its own inverse, det = -1.
        """
        n = self.n
        M = np.eye(4)
        M[:3, :3] -= 2.0 * np.outer(n, n)
        M[:3, 3] = -2.0 * self.d * n
        return M

    def virtual_camera_pose(self) -> np.ndarray:
        """(4, 4) float64 pose (camera frame <- virtual camera frame) of the camera's mirror image.

        A proper rigid transform: the reflection of the camera's axes with its x axis flipped back
        (images seen through a mirror are flipped left-right). Its origin is the camera reflected
        through the plane, -2 d n.
        """
        M = self.reflection_matrix()
        M[:3, 0] = -M[:3, 0]
        return M

    def project(self, points: np.ndarray) -> np.ndarray:
        """Project points orthogonally onto the plane.

        Parameters
        ----------
        points : (..., 3) array
            Metres, camera frame.

        Returns
        -------
        (..., 3) float64 array
        """
        points = np.asarray(points, dtype=np.float64)
        return points - self.signed_distance(points)[..., None] * self.n

    def angle_to(self, other: "Plane") -> float:
        """Return the angle between the two normals, degrees.

        Computed as atan2 of the cross and dot products: exact near 0 and 180.

        Parameters
        ----------
        other : Plane

        Returns
        -------
        float
            Degrees, 0 to 180.
        """
        return float(np.degrees(np.arctan2(np.linalg.norm(np.cross(self.n, other.n)),
                                           np.dot(self.n, other.n))))


def fit_plane_svd(points: np.ndarray, where: str = "plane") -> Plane:
    """Fit a least-squares plane (paper eq. 2) by SVD of the centred points.

    Parameters
    ----------
    points : (n, 3) array
        Metres, camera frame; n >= 3, not collinear.
    where : str
        What the points are, for the messages.

    Returns
    -------
    Plane

    Raises
    ------
    CalibrationError
        Fewer than 3 points, or collinear points.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(points) < 3:
        raise CalibrationError(
            f"{where}: at least 3 points are needed to fit a plane, got {len(points)}")
    centroid = points.mean(axis=0)
    _, s, vt = np.linalg.svd(points - centroid, full_matrices=False)
    if s[1] <= 1e-6 * max(s[0], 1e-12) or s[1] < 1e-9:
        raise CalibrationError(
            f"{where}: the points are collinear; a plane needs points spread in two directions")
    return Plane.from_point_normal(centroid, vt[2])


@dataclass(frozen=True)
class PlaneFit:
    """A RANSAC + SVD plane fit.

    Attributes
    ----------
    plane : Plane
        The fitted plane.
    inliers : (n,) bool array
        Which points are inliers.
    residuals : (n,) float64 array
        Signed distances of all points to the plane, metres.
    """

    plane: Plane
    inliers: np.ndarray
    residuals: np.ndarray

    @property
    def rms(self) -> float:
        """RMS distance of the inliers to the plane, metres."""
        return float(np.sqrt(np.mean(self.residuals[self.inliers] ** 2)))


def fit_plane_ransac(points: np.ndarray, threshold: float | np.ndarray, rng: np.random.Generator,
                     confidence: float = 0.999, max_iterations: int = 2000,
                     where: str = "plane") -> PlaneFit:
    """Fit a plane by RANSAC on 3-point samples, then an SVD refit on the inliers until they settle.

    Samples are scored by MSAC (squared distances in units of each point's threshold, capped at 1,
    summed: every outlier costs the same wherever it lies, and among planes with as many inliers the
    closest wins). Degenerate (collinear) samples are skipped.

    Parameters
    ----------
    points : (n, 3) array
        Metres, camera frame.
    threshold : float or (n,) array
        Inlier distance, metres (per point for depth-dependent noise).
    rng : numpy.random.Generator
        The only source of randomness.
    confidence : float
        RANSAC's probability of drawing one all-inlier sample.
    max_iterations : int
        The most samples drawn.
    where : str
        What the points are, for the messages.

    Returns
    -------
    PlaneFit

    Raises
    ------
    CalibrationError
        Fewer than 3 points, collinear points, or no plane can be fitted.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    fit_plane_svd(points, where)  # refuses fewer than 3 or collinear points with a clear message
    threshold = np.broadcast_to(np.asarray(threshold, dtype=np.float64), (len(points),))
    cap = threshold[:, None] ** 2
    best, best_cost, needed, it, batch = None, np.inf, max_iterations, 0, 64
    while it < min(needed, max_iterations):
        samples = rng.integers(0, len(points), size=(batch, 3))
        a, b, c = points[samples[:, 0]], points[samples[:, 1]], points[samples[:, 2]]
        normals = np.cross(b - a, c - a)
        norms = np.linalg.norm(normals, axis=1)
        ok = norms > 1e-12
        normals = normals[ok] / norms[ok, None]
        ds = -np.einsum("ij,ij->i", normals, a[ok])
        if len(normals):
            sq = (points @ normals.T + ds) ** 2                     # (n, k)
            # a far (noisy) outlier weighs no more than a near one
            costs = np.minimum(sq / cap, 1.0).sum(axis=0)
            k = int(np.argmin(costs))
            if costs[k] < best_cost:
                best_cost, best = costs[k], (normals[k], ds[k])
                needed = ransac_iterations(float(np.mean(sq[:, k] < cap[:, 0])), 3, confidence)
        it += batch
    if best is None:
        raise CalibrationError(f"{where}: no three points define a plane")
    inliers = np.abs(points @ best[0] + best[1]) < threshold
    plane = fit_plane_svd(points[inliers],
                          where) if inliers.sum() >= 3 else Plane.from_point_normal(
        -best[1] * best[0], best[0])
    for _ in range(5):
        refit = np.abs(plane.signed_distance(points)) < threshold
        if refit.sum() < 3 or np.array_equal(refit, inliers):
            break
        inliers = refit
        plane = fit_plane_svd(points[inliers], where)
    return PlaneFit(plane, inliers, plane.signed_distance(points))
