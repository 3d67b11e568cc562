"""Fitted shapes (sphere, cylinder) and the paper's error measures of a cloud against them (eq. 4
and 5, mean error).

The deviation of a point P is signed: dist(P, centre) - R for a sphere (eq. 4), dist(P, axis line) -
R for a cylinder (eq. 5); > 0 outside the surface, < 0 inside. Metres everywhere; millimetres only
in the reported JSON figures (`*_mm`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirrorcore.base.palette import source_name


def _as_points(points: np.ndarray) -> np.ndarray:
    """(n, 3) float64 view of any (..., 3) point array."""
    return np.asarray(points, dtype=np.float64).reshape(-1, 3)


@dataclass(frozen=True)
class Sphere:
    """A fitted sphere.

    Attributes
    ----------
    centre : (float, float, float)
        Metres, camera frame.
    radius : float
        Metres.
    """

    centre: tuple[float, float, float]
    radius: float

    kind = "sphere"

    def deviations(self, points: np.ndarray) -> np.ndarray:
        """Return the terms of paper eq. 4: the signed dist(P, centre) - R.

        Parameters
        ----------
        points : (n, 3) array
            Metres, camera frame.

        Returns
        -------
        (n,) float64 array
            Metres, > 0 outside the surface.
        """
        return np.linalg.norm(_as_points(points) - np.array(self.centre), axis=1) - self.radius

    def to_json(self) -> dict:
        """{'shape', 'radius_mm', 'center'} (the centre in metres, camera frame)."""
        return {"shape": self.kind, "radius_mm": 1e3 * self.radius, "center": list(self.centre)}


@dataclass(frozen=True)
class Cylinder:
    """A fitted cylinder.

    Attributes
    ----------
    axis_point : (float, float, float)
        A point of the axis, metres, camera frame.
    axis_direction : (float, float, float)
        Unit vector.
    radius : float
        Metres.
    """

    axis_point: tuple[float, float, float]
    axis_direction: tuple[float, float, float]
    radius: float

    kind = "cylinder"

    def deviations(self, points: np.ndarray) -> np.ndarray:
        """Return the terms of paper eq. 5: the signed dist(P, axis line) - R.

        Parameters
        ----------
        points : (n, 3) array
            Metres, camera frame.

        Returns
        -------
        (n,) float64 array
            Metres, > 0 outside the surface.
        """
        q = _as_points(points) - np.array(self.axis_point)
        direction = np.array(self.axis_direction)
        return np.linalg.norm(q - np.outer(q @ direction, direction), axis=1) - self.radius

    def to_json(self) -> dict:
        """{'shape', 'radius_mm', 'axis_point', 'axis_direction'} (metres, camera frame)."""
        return {"shape": self.kind, "radius_mm": 1e3 * self.radius,
                "axis_point": list(self.axis_point),
                "axis_direction": list(self.axis_direction)}


@dataclass(frozen=True)
class FitErrors:
    """The error figures of a set of points against a fitted shape, metres; NaN for an empty set.

    Attributes
    ----------
    points : int
        How many points.
    rmse : float
        Paper eq. 4 / 5, sqrt(mean(dev^2)).
    mean_error : float
        The paper's "mean error", mean(dev); signed: > 0 when the points lie outside the fitted
        surface on average.
    mean_abs_error : float
        mean(|dev|).
    """

    points: int
    rmse: float
    mean_error: float
    mean_abs_error: float

    @classmethod
    def from_deviations(cls, deviations: np.ndarray) -> "FitErrors":
        """Measure signed deviations.

        Parameters
        ----------
        deviations : (n,) array
            Signed metres (Sphere.deviations, Cylinder.deviations).

        Returns
        -------
        FitErrors
        """
        return per_source_errors(deviations, np.zeros(np.shape(deviations), dtype=np.int64)).get(
            0, cls(0, float("nan"), float("nan"), float("nan")))

    def to_json(self) -> dict:
        """{"points", "rmse_mm", "mean_error_mm", "mean_abs_error_mm"} (NaN becomes null)."""
        mm = [None if np.isnan(x) else 1e3 * x
              for x in (self.rmse, self.mean_error, self.mean_abs_error)]
        return {"points": self.points, "rmse_mm": mm[0], "mean_error_mm": mm[1],
                "mean_abs_error_mm": mm[2]}


def per_source_errors(deviations: np.ndarray, sources: np.ndarray) -> dict[int, FitErrors]:
    """Measure the deviations of each source present.

    Parameters
    ----------
    deviations : (n,) array
        Signed metres.
    sources : (n,) integer array
        Labels (0 direct, j mirror j).

    Returns
    -------
    dict of int to FitErrors
        {source: FitErrors}, sorted by source.

    Raises
    ------
    ValueError
        The lengths differ, or a label is negative.
    """
    deviations = np.asarray(deviations, dtype=np.float64).reshape(-1)
    sources = np.asarray(sources).reshape(-1).astype(np.int64)
    if len(sources) != len(deviations):
        raise ValueError(f"{len(deviations)} deviations but {len(sources)} source labels")
    if len(sources) and sources.min() < 0:
        raise ValueError("source labels must be >= 0")
    counts = np.bincount(sources)
    sq, total, absolute = (np.bincount(sources, weights=w)
                           for w in (deviations ** 2, deviations, np.abs(deviations)))
    return {int(s): FitErrors(int(counts[s]), float(np.sqrt(sq[s] / counts[s])),
                              float(total[s] / counts[s]),
                              float(absolute[s] / counts[s]))
            for s in np.flatnonzero(counts)}


@dataclass(frozen=True, eq=False)
class ShapeFit:
    """A fitted shape and how the cloud deviates from it.

    Attributes
    ----------
    shape : Sphere or Cylinder
        The fitted shape.
    inliers : (n,) bool array
        Points within the RANSAC threshold of the final shape.
    deviations : (n,) float64 array
        Signed metres of ALL points (eq. 4 / 5 terms).
    sources : (n,) uint8 array or None
        Source labels.
    threshold : float
        The inlier distance used, metres.
    """

    shape: Sphere | Cylinder
    inliers: np.ndarray
    deviations: np.ndarray
    sources: np.ndarray | None
    threshold: float

    @property
    def errors(self) -> FitErrors:
        """Over ALL points, outliers included, as the paper measures a reconstruction."""
        return FitErrors.from_deviations(self.deviations)

    @property
    def inlier_errors(self) -> FitErrors:
        """Over the inliers only."""
        return FitErrors.from_deviations(self.deviations[self.inliers])

    @property
    def per_source(self) -> dict[int, FitErrors]:
        """Over all points of each source ({} when the cloud has no source labels)."""
        return {} if self.sources is None else per_source_errors(self.deviations, self.sources)

    def to_json(self) -> dict:
        """Return the fit as JSON.

        The shape (radius_mm; "center" (the centre), or axis_point and axis_direction, in metres,
        camera frame), the figures over all points (points, rmse_mm, mean_error_mm,
        mean_abs_error_mm), inliers, threshold_mm, inlier_errors and per_source {"direct": {...},
        "mirror 1": {...}}.
        """
        return {**self.shape.to_json(), **self.errors.to_json(),
                "inliers": int(np.count_nonzero(self.inliers)),
                "threshold_mm": 1e3 * self.threshold, "inlier_errors": self.inlier_errors.to_json(),
                "per_source": {source_name(s): e.to_json() for s, e in self.per_source.items()}}
