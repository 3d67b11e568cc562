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
    """Return the progress of a refinement after some iterations.

    The frames' views take a fifth; the iterations the next 55 %, ever slower but never standing
    still (most settle in under 15; a second pass after relabelling the pixels goes on counting);
    each frame's own planes (`frames_scatter`) the rest, so that the bar moves through them.

    Parameters
    ----------
    iterations : int
        Iterations so far.
    within : float
        With 0 iterations, the fraction of the views done.

    Returns
    -------
    float
    """
    if iterations == 0:
        return 0.2 * within
    return 0.2 + 0.55 * (1.0 - float(np.exp(-iterations / 8.0)))


def solve(frames, planes, refined, centre, gate, progress, cancel,
           iterations) -> tuple[dict[int, Plane], int]:
    """Run Gauss-Newton until no step exceeds SETTLED of its std (at most MAX_ITERATIONS).

    Parameters
    ----------
    frames : list of FrameViews
    planes : dict of int to Plane
        {mirror j: plane} at the start.
    refined : list of int
        The mirrors moved (1-based).
    centre : (3,) array
        Metres, where the steps' offsets are measured.
    gate : float
        Metres added to what counts as the same surface, halved at every iteration.
    progress : Progress or None
        Called after each iteration.
    cancel : optional
        Checked before each iteration.
    iterations : int
        Iterations so far.

    Returns
    -------
    planes : dict of int to Plane
    iterations : int
        Iterations so far.

    Raises
    ------
    Cancelled
    """
    planes = dict(planes)
    for _ in range(MAX_ITERATIONS):
        if cancel_requested(cancel):
            raise Cancelled("refinement cancelled")
        step, hessian = residuals(frames, planes, refined, centre, gate).step()
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
    """Measure how much the planes each frame alone gives scatter.

    The planes of each frame alone are refined from `planes`; their spread, over the square root of
    the number of frames, is measured along the normal at `centre` and in tilt (the larger of its
    two axes), each a robust standard deviation (`_spread`: a frame that sees too little to give a
    plane of its own does not count).

    Parameters
    ----------
    frames : list of FrameViews
    planes : dict of int to Plane
    refined : list of int
        1-based.
    centre : (3,) array
        Metres.
    progress : Progress or None
    cancel : optional
    done : float
        The progress so far.

    Returns
    -------
    dict of int to (float, float)
        {mirror j: (metres, degrees)} with SCATTER_FRAMES frames or more; {} with fewer.
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
