"""The loops the sphere and cylinder fits share: batched LO-RANSAC (each new best sample replaced
by its least-squares local optimum), the refit on the inliers, and Gauss-Newton. Models are flat
float64 vectors, radius last; metres."""
from __future__ import annotations

from typing import Callable

import numpy as np

from mirrorcore.base.errors import Cancelled
from mirrorcore.base.progress import Progress, cancel_requested
from mirrorcore.geometry.ransac import ransac_iterations

_SCORE_BUDGET = 4_000_000
"""Point-model distances evaluated per RANSAC batch (bounds memory to ~32 MB whatever the cloud
size)."""

Model = np.ndarray
"""(p,) float64: a sphere [cx, cy, cz, R]; a cylinder [ax, ay, az, dx, dy, dz, R] (axis point, unit
direction)."""


def lo_ransac(
    n: int,
    sample_size: int,
    min_inliers: int,
    propose: Callable[[np.ndarray], np.ndarray],
    distances: Callable[[np.ndarray], np.ndarray],
    optimise: Callable[[Model], tuple[Model, int]],
    threshold: float,
    rng: np.random.Generator,
    radius_range: tuple[float, float],
    confidence: float,
    max_iterations: int,
    tick: Callable[[float], None],
) -> Model | None:
    """Batched LO-RANSAC: `propose` maps samples (m, sample_size) int to models (m, p) (NaN rows =
    degenerate sample); `distances` maps models (m, p) to signed point-model deviations (n, m); each
    new best sample is replaced by its local optimum `optimise(model) -> (model, inlier count)` when
    that has as many inliers and a radius in range. Returns the model with most inliers (at least
    min_inliers), or None. Stops by ransac_iterations' rule or after max_iterations samples;
    tick(fraction of the samples it will draw) after each batch."""
    batch = int(np.clip(_SCORE_BUDGET // n, 1, 64))
    best, best_count, needed, drawn = None, min_inliers - 1, max_iterations, 0
    while drawn < min(needed, max_iterations):
        models = propose(rng.integers(0, n, size=(batch, sample_size)))
        models = models[np.all(np.isfinite(models), axis=1) & in_range(models[:, -1], radius_range)]
        if len(models):
            counts = np.count_nonzero(np.abs(distances(models)) < threshold, axis=0)
            k = int(np.argmax(counts))
            if counts[k] > best_count:
                best, best_count = models[k], int(counts[k])
                local, local_count = optimise(best)
                if local_count >= best_count and in_range(local[-1], radius_range):
                    best, best_count = local, local_count
                needed = ransac_iterations(best_count / n, sample_size, confidence)
        drawn += batch
        tick(min(drawn / min(needed, max_iterations), 1.0))
    return best


def ticker(progress: Progress | None, cancel, where: str) -> Callable[[float], None]:
    """tick(fraction): report the fraction done to `progress`, and raise Cancelled when `cancel`
    asks to stop."""

    def tick(fraction: float) -> None:
        if cancel_requested(cancel):
            raise Cancelled(f"{where}: the fit was cancelled")
        if progress is not None:
            progress(fraction)

    return tick


def in_range(radius: np.ndarray | float, radius_range: tuple[float, float]) -> np.ndarray | bool:
    """Whether each radius lies within radius_range (min, max), metres."""
    return (radius >= radius_range[0]) & (radius <= radius_range[1])


def local_optimum(
    points: np.ndarray,
    model: Model,
    threshold: float,
    distances: Callable[[np.ndarray], np.ndarray],
    refine: Callable[[np.ndarray, Model], Model],
    min_points: int,
) -> tuple[Model, int]:
    """Least-squares refit on the inliers, repeated with the refit's inliers until they stop
    changing (at most 10 refits) -> (model, its inlier count). Stops, keeping the last model, when
    fewer than min_points are inliers."""
    inliers = np.abs(distances(model[None])[:, 0]) < threshold
    for _ in range(10):
        if np.count_nonzero(inliers) < min_points:
            break
        model = refine(points[inliers], model)
        refit = np.abs(distances(model[None])[:, 0]) < threshold
        if np.array_equal(refit, inliers):
            break
        inliers = refit
    return model, int(np.count_nonzero(np.abs(distances(model[None])[:, 0]) < threshold))


def gauss_newton(
    model: Model,
    residuals_jacobian: Callable[[Model], tuple[np.ndarray, np.ndarray]],
    step: Callable[[Model, np.ndarray], Model],
    iterations: int = 100,
) -> Model:
    """Minimise sum(r^2) from `model`: residuals_jacobian(model) -> r (n,), J (n, k); step(model,
    delta (k,)) -> model. Halves a step that does not lower the cost; stops when the cost stops
    falling (relative 1e-15) or after `iterations` steps."""
    r, J = residuals_jacobian(model)
    cost = r @ r
    for _ in range(iterations):
        delta = np.linalg.lstsq(J, -r, rcond=None)[0]
        for scale in 0.5 ** np.arange(12):
            trial = step(model, scale * delta)
            r_trial, J_trial = residuals_jacobian(trial)
            if r_trial @ r_trial <= cost:
                break
        else:
            return model
        previous, (model, r, J, cost) = cost, (trial, r_trial, J_trial, r_trial @ r_trial)
        if previous - cost <= 1e-15 * previous:
            break
    return model
