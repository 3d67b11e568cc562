"""Gauss-Newton on the mirror planes' steps, how much the planes of single frames scatter, and the
refinement's progress through its iterations."""
from __future__ import annotations

import numpy as np

from mirrorcore.base.errors import Cancelled
from mirrorcore.base.progress import cancel_requested
from mirrorcore.calibration.planestep import moved_plane, shift_at, tangent_basis
from mirrorcore.calibration.residuals import residuals
from mirrorcore.calibration.spheretarget import SCATTER_FRAMES
from mirrorcore.geometry.plane import Plane

MAX_ITERATIONS = 30
# The iterations stop when no parameter moves by more than this share of its std.
SETTLED = 0.1


def progress_fraction(iterations: int, within: float = 1.0) -> float:
    """Progress: the frames' views take a fifth; the iterations the next 55 %, ever slower but
    never standing still (most settle in under 15; a second pass after relabelling the pixels goes
    on counting); each frame's own planes (frames_scatter) the rest, so that the bar moves through
    them."""
    if iterations == 0:
        return 0.2 * within
    return 0.2 + 0.55 * (1.0 - float(np.exp(-iterations / 8.0)))


def solve(frames, planes, refined, centre, gate, progress, cancel,
           iterations) -> tuple[dict[int, Plane], int]:
    """Gauss-Newton until no step exceeds SETTLED of its std (at most MAX_ITERATIONS) -> (planes,
    iterations so far); `progress` (or None) after each iteration."""
    planes = dict(planes)
    for _ in range(MAX_ITERATIONS):
        if cancel_requested(cancel):
            raise Cancelled("refinement cancelled")
        found = residuals(frames, planes, refined, centre, gate)
        weights = found.weights()
        hessian = found.jacobian.T @ (weights[:, None] * found.jacobian)
        # no view may see a mirror yet
        hessian += np.eye(len(hessian)) * 1e-9 * max(np.trace(hessian), 1.0)
        step = -np.linalg.solve(hessian, found.jacobian.T @ (weights * found.residual))
        for i, j in enumerate(refined):
            planes[j] = moved_plane(planes[j], centre, step[3 * i:3 * i + 3])
        iterations, gate = iterations + 1, gate / 2
        if progress is not None:
            progress(progress_fraction(iterations))
        if np.all(np.abs(step) <= SETTLED * np.sqrt(np.diag(np.linalg.inv(hessian)))):
            break
    return planes, iterations


def frames_scatter(frames, planes, refined, centre, progress, cancel,
                    done: float) -> dict[int, tuple[float, float]]:
    """How much the planes each frame alone gives scatter.

    With SCATTER_FRAMES frames or more: {mirror j: (metres, degrees)}, the spread of the planes
    that each frame alone gives, refined from `planes`, over the square root of the number of
    frames: along the normal at `centre` and in tilt (the larger of its two axes), each a robust
    standard deviation (_spread: a frame that sees too little to give a plane of its own does not
    count). Fewer frames: {}. `done`: the progress so far.
    """
    if len(frames) < SCATTER_FRAMES:
        return {}
    shifts, tilts = [], []
    for k, frame in enumerate(frames):
        alone = solve([frame], planes, refined, centre, 0.0, None, cancel, 0)[0]
        shifts.append([shift_at(planes[j], alone[j], centre) for j in refined])
        tilts.append([tangent_basis(planes[j].n) @ alone[j].n for j in refined])
        if progress is not None:
            progress(done + (0.99 - done) * (k + 1) / len(frames))
    shifts, tilts, root = np.asarray(shifts), np.asarray(tilts), np.sqrt(len(frames))
    return {j: (float(_spread(shifts[:, i]) / root),
                float(np.degrees(max(_spread(tilts[:, i, 0]), _spread(tilts[:, i, 1]))) / root))
            for i, j in enumerate(refined)}


def _spread(values: np.ndarray) -> float:
    """A standard deviation of `values` (n,) robust to a few wild ones: 1.4826 times their median
    absolute deviation (the standard deviation itself for Gaussian values)."""
    return float(1.4826 * np.median(np.abs(values - np.median(values))))
