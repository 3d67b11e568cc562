"""Temporal smoothing of depth frames for people in motion: each pixel is averaged with the same
pixel of its neighbouring frames where the scene is static there (motion-aware, edge-preserving), in
disparity.

A structured-light camera's noise is constant in disparity w = 1/z (sigma_w = 1.425e-3 per metre,
mirrorcore.depth.noise), so the difference of two readings of a static surface has the standard
deviation sqrt(2) sigma_w at every depth. A neighbour frame k is used at a pixel when (1) its own
difference to the centre frame is within `sigmas` of that, and (2) the mean difference over a
`patch` x `patch` window around the pixel (the pixels where both frames read) is within `sigmas` of
its own, smaller, standard deviation: a surface that moved by less than the noise of one reading,
but moved everywhere around the pixel, is still seen as moving. A limb crossing the pixel, the edge
of a moving arm or a surface sliding along its depth is left out; the static torso, head and
background are averaged over 2N + 1 frames. Pixels without a reading in the centre frame stay
without one (no hole is filled from another moment).
"""
from __future__ import annotations

import cv2
import numpy as np

from mirrorcore.base.budget import check_memory
from mirrorcore.depth.noise import KINECT_AXIAL_COEF

DEFAULT_SIGMAS = 3.0   # acceptance, in standard deviations of a difference of two readings
DEFAULT_PATCH = 5      # pixels: side of the window whose mean difference tells motion from noise
# bytes a pixel of each frame of a window takes while smoothed (the frames read, their stack and
# the temporaries): 17.4 measured for 41 frames of 640x480
WINDOW_PIXEL_BYTES = 24


def frame_window(index: int, radius: int, count: int) -> range:
    """Return the frames index - radius .. index + radius of a recording, clipped to 0 .. count - 1.

    Parameters
    ----------
    index : int
        The centre frame.
    radius : int
        Frames on each side.
    count : int
        Frames in the recording.

    Returns
    -------
    range
    """
    return range(max(index - radius, 0), min(index + radius + 1, count))


def check_window_memory(frames: int, shape: tuple[int, int], what: str) -> None:
    """Refuse a window of `frames` frames of `shape` whose smoothing would pass the memory budget.

    Parameters
    ----------
    frames : int
        Frames in the window (2N + 1, or fewer at a recording's ends).
    shape : (int, int)
        (H, W), pixels.
    what : str
        The option that asks for it, for the message ('--temporal 3000').

    Raises
    ------
    MemoryBudgetError
        Naming `what`, the need and the budget.
    """
    check_memory(float(frames) * shape[0] * shape[1] * WINDOW_PIXEL_BYTES,
                 f"{what}: {frames:,} frames of {shape[1]}x{shape[0]} at once")


def temporal_smooth(frames: np.ndarray, centre: int, sigmas: float = DEFAULT_SIGMAS,
                    patch: int = DEFAULT_PATCH) -> np.ndarray:
    """Filter the centre frame of a stack, each pixel averaged with the frames static there.

    The average is in disparity, over the neighbour frames that are static at the pixel (see the
    module docstring).

    Parameters
    ----------
    frames : (k, H, W) float array
        Metres, 0 (or not finite) = no reading; consecutive frames of one camera.
    centre : int
        The index in the stack of the frame to filter.
    sigmas : float
        Acceptance, in standard deviations of a difference of two readings.
    patch : int
        Pixels, the side of the window whose mean difference tells motion from noise.

    Returns
    -------
    (H, W) float32 array
        Metres, 0 where the centre frame has no reading.
    """
    frames = np.asarray(frames, dtype=np.float32)
    if frames.ndim != 3 or not 0 <= centre < len(frames):
        raise ValueError(
            f"temporal_smooth: expected (k, H, W) frames and 0 <= centre < k, got {frames.shape}, "
                         f"{centre}")
    valid = np.isfinite(frames) & (frames > 0)
    w = np.where(valid, 1.0 / np.where(valid, frames, 1.0), 0.0).astype(np.float32)
    w0, v0 = w[centre], valid[centre]
    # one pixel's difference, 1/metres
    tolerance = np.float32(sigmas * np.sqrt(2.0) * KINECT_AXIAL_COEF)
    total, count = w0.copy(), v0.astype(np.float32)
    for k in range(len(frames)):
        if k == centre:
            continue
        both = v0 & valid[k]
        diff = np.where(both, w[k] - w0, 0.0).astype(np.float32)
        pairs = cv2.boxFilter(both.astype(np.float32), -1, (patch, patch), normalize=False,
                              borderType=cv2.BORDER_CONSTANT)
        local = cv2.boxFilter(diff, -1, (patch, patch), normalize=False,
                              borderType=cv2.BORDER_CONSTANT)
        # the mean of n differences has 1/sqrt(n) of one difference's deviation: |sum| < tolerance *
        # sqrt(n)
        static = both & (np.abs(diff) <= tolerance) & (np.abs(local) <= tolerance * np.sqrt(
            np.maximum(pairs, 1.0)))
        total += np.where(static, w[k], 0.0)
        count += static
    out = np.zeros(w0.shape, np.float32)
    out[v0] = count[v0] / total[v0]
    return out
