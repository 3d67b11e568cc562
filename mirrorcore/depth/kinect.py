"""The Kinect v1's own depth units: 11-bit disparity counts and their conversion to metres (Nicolas
Burrus' calibration), shared by the Kinect driver (mirrorcore.sources.devices) and the tests that
feed it simulated frames."""
from __future__ import annotations

import numpy as np

# z = 1 / (disparity * A + B), metres (Nicolas Burrus' Kinect v1 calibration)
BURRUS_A = -0.0030711016
BURRUS_B = 3.3309495161
DISPARITY_INVALID = 2047     # the count a Kinect v1 reports for no reading
# 1085: from here on the formula gives no positive depth
DISPARITY_LIMIT = int(np.ceil(-BURRUS_B / BURRUS_A))


def depth_to_disparity(depth: np.ndarray) -> np.ndarray:
    """Convert metres to Kinect v1 11-bit disparity counts (the inverse of the Burrus formula).

    Counts 0..1084 hold depths from 0.30 m to about 530 m.

    Parameters
    ----------
    depth : (...) float array
        Metres.

    Returns
    -------
    (...) uint16 array
        Counts; DISPARITY_INVALID for 0 or out of range.
    """
    depth = np.asarray(depth, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        counts = np.round((1.0 / depth - BURRUS_B) / BURRUS_A)
    ok = (depth > 0) & np.isfinite(counts) & (counts >= 0) & (counts < DISPARITY_LIMIT)
    return np.where(ok, counts, DISPARITY_INVALID).astype(np.uint16)


def disparity_to_depth(counts: np.ndarray) -> np.ndarray:
    """Convert Kinect v1 11-bit disparity counts to metres (Burrus: z = 1 / (counts * A + B)).

    Parameters
    ----------
    counts : (...) integer array
        Disparity counts.

    Returns
    -------
    (...) float32 array
        Metres; 0 for DISPARITY_INVALID and counts with no positive depth (>= DISPARITY_LIMIT).
    """
    counts = np.asarray(counts, dtype=np.float64)
    ok = (counts < DISPARITY_LIMIT) & (counts >= 0)
    return np.where(ok, 1.0 / np.where(ok, counts * BURRUS_A + BURRUS_B, 1.0),
                    0.0).astype(np.float32)
