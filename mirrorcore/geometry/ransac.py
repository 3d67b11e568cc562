"""RANSAC's stopping rule, shared by the plane, sphere and cylinder fits."""
from __future__ import annotations

import math


def ransac_iterations(inlier_ratio: float, sample_size: int, confidence: float = 0.999) -> int:
    """Return the number of random samples needed to draw one all-inlier sample.

    Parameters
    ----------
    inlier_ratio : float
        In [0, 1] (clipped).
    sample_size : int
        Points per sample.
    confidence : float
        The probability of drawing one all-inlier sample.

    Returns
    -------
    int
        At least 1 (inlier_ratio 1), and a large number (up to 10**9) for inlier_ratio near 0.
    """
    w = min(max(inlier_ratio, 0.0), 1.0) ** sample_size
    if w >= 1.0:
        return 1
    if w <= 0.0:
        return 10**9
    return max(1, math.ceil(math.log(1.0 - confidence) / math.log(1.0 - w)))
