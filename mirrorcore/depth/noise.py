"""Depth noise of a structured-light camera (Kinect v1 class), used for noise-aware thresholds.

Axial noise grows with the square of the depth (Khoshelham & Elberink 2012): sigma(z) = 1.425e-3 *
z^2 metres.
"""
from __future__ import annotations

import numpy as np

KINECT_AXIAL_COEF = 1.425e-3   # metres of axial standard deviation per metre^2 of depth
# a floor (metres) so that thresholds never collapse to zero near the camera
MIN_SIGMA = 0.5e-3


def axial_sigma(z: np.ndarray | float) -> np.ndarray:
    """Return the standard deviation of a depth reading, Kinect v1 model, floored at MIN_SIGMA.

    Parameters
    ----------
    z : float or array
        Depth, metres.

    Returns
    -------
    array
        Metres, shaped as `z`; float32 for float32 input (per-pixel images), float64 otherwise.
    """
    z = np.asarray(z)
    z = z if z.dtype == np.float32 else z.astype(np.float64)
    return np.maximum(z.dtype.type(KINECT_AXIAL_COEF) * np.square(z), z.dtype.type(MIN_SIGMA))
