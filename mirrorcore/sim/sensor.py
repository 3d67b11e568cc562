"""Kinect v1 sensor model applied to an ideal depth image (range, IR shadow, lateral and axial
noise, 1/8-pixel disparity quantisation).

Axial noise: Khoshelham & Elberink (2012) give a total depth std sigma_z = k Z^2 with k = 1.425e-3 /
m. In disparity D = f b / Z (f = fx pixels, b = baseline) that is a constant sigma_D = k f b pixels,
so the model adds Gaussian noise in disparity with variance sigma_D^2 - q^2 / 12 and then rounds to
the step q = 1/8 pixel: noise + quantisation together give sigma_z = k Z^2 (Sheppard's correction;
checked at 1, 2 and 3 m in the tests). The quantisation is applied even without the noise when
`quantise` is set: `SensorModel.kinect_v1(noise=False)` shows the depth steps (f b / (n q)).

The Gaussian draws come from a table of its 65536 equiprobable quantiles (`standard_normal`): every
probability is within 1/65536 of the exact Gaussian's (tails stop at 4.33 std), and drawing is about
five times faster than with rng.standard_normal.

IR shadow (an image-space approximation, exact for a rectified horizontal baseline): the projector
sits `baseline` metres along +x. A point at pixel column u with disparity D lies on the projector
ray x_p = u - D; along an image row that ray passes in front of a pixel u' > u whose x_p(u') <
x_p(u), so pixel u is in shadow when the smallest x_p to its right is smaller (by `shadow_tolerance`
px). Unfolded (virtual) points work the same way, because the projector's light reaches a point
through the same mirror the camera sees it by (paper section 2); the approximation ignores light
that would pass beside a mirror's edge.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from math import erfc
from statistics import NormalDist

import cv2
import numpy as np

from mirrorcore.geometry.camera import Intrinsics


@dataclass(frozen=True)
class SensorModel:
    """What the sensor does to the ideal depth; every stage can be switched off.

    Attributes
    ----------
    axial_k : float
        Total axial std = axial_k * Z^2 (1/m); 0 = no noise.
    quantise : bool
        Round disparity to `disparity_step`.
    disparity_step : float
        Pixels.
    baseline : float
        Projector-camera distance along +x, metres.
    lateral_sigma : float
        Std of the lateral jitter in pixels (each pixel reads the depth of a neighbour at a rounded
        Gaussian offset); 0 = none.
    min_range, max_range : float
        Metres; pixels whose true depth is outside read 0.
    shadow : bool
        Zero the IR shadow.
    shadow_tolerance : float
        Pixels (see `ir_shadow`).
    colour_sigma : float
        Std of the colour camera's noise, 8-bit levels per channel, added before rounding; 0 =
        none (mirrorcore.sim.albedo).
    """

    axial_k: float = 1.425e-3
    quantise: bool = True
    disparity_step: float = 1.0 / 8.0
    baseline: float = 0.075
    lateral_sigma: float = 0.5
    min_range: float = 0.5
    max_range: float = 4.5
    shadow: bool = True
    shadow_tolerance: float = 0.1
    colour_sigma: float = 2.0

    @classmethod
    def ideal(cls) -> "SensorModel":
        """The exact ideal depth: no noise, no quantisation, no range limits, no shadow."""
        return cls(axial_k=0.0, quantise=False, lateral_sigma=0.0, min_range=0.0, max_range=np.inf,
                   shadow=False, colour_sigma=0.0)

    @classmethod
    def kinect_v1(cls, noise: bool = True) -> "SensorModel":
        """Return the Kinect v1 model.

        Parameters
        ----------
        noise : bool
            False keeps the range, the shadow and the disparity quantisation but adds no noise
            (to the depth or the colour).

        Returns
        -------
        SensorModel
        """
        return cls() if noise else cls(axial_k=0.0, lateral_sigma=0.0, colour_sigma=0.0)

    @classmethod
    def from_name(cls, name: str) -> "SensorModel":
        """Return a model by name.

        Parameters
        ----------
        name : str
            'none' -> ideal(), 'kinect' -> kinect_v1(), 'kinect-noiseless' ->
            kinect_v1(noise=False).

        Returns
        -------
        SensorModel
        """
        return {"none": cls.ideal, "kinect": cls.kinect_v1,
                "kinect-noiseless": lambda: cls.kinect_v1(False)}[name]()

    def disparity_noise_std(self, fx: float) -> float:
        """Return the std of the Gaussian added to the disparity, before quantisation.

        Parameters
        ----------
        fx : float
            Focal length, pixels.

        Returns
        -------
        float
            Pixels.
        """
        total = self.axial_k * fx * self.baseline
        quant = self.disparity_step ** 2 / 12 if self.quantise else 0.0
        return float(np.sqrt(max(total ** 2 - quant, 0.0)))

    def apply(self, camera: Intrinsics, depth: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Measure an ideal depth image.

        Parameters
        ----------
        camera : Intrinsics
        depth : (H, W) float32 array
            Ideal metres, 0 = nothing.
        rng : numpy.random.Generator
            The noise's source.

        Returns
        -------
        (H, W) float32 array
            Measured metres, 0 = no reading.
        """
        depth = np.asarray(depth, dtype=np.float32)
        fb = np.float32(camera.fx * self.baseline)
        valid = (depth >= self.min_range) & (depth <= self.max_range)
        if self.shadow:
            valid &= ~ir_shadow(depth, fb, self.shadow_tolerance)
        out = np.where(valid, depth, np.float32(0))
        if self.lateral_sigma > 0:
            out = lateral_jitter(out, self.lateral_sigma, rng)
        sigma = self.disparity_noise_std(camera.fx)
        if sigma == 0 and not self.quantise:
            return out
        with np.errstate(divide="ignore"):
            # inf where there is no reading
            disparity = np.divide(fb, out)
        if sigma > 0:
            disparity += np.float32(sigma) * standard_normal(rng, out.shape)
        if self.quantise:
            step = np.float32(self.disparity_step)
            np.round(np.divide(disparity, step, out=disparity), out=disparity)
            disparity *= step
        z = np.divide(fb, disparity, out=np.zeros_like(disparity), where=disparity > 0)
        return np.where((z >= self.min_range) & (z <= self.max_range), z, np.float32(0))


@cache
def _normal_quantiles() -> np.ndarray:
    """(65536,) float32 quantiles of N(0, 1) at probabilities (i + 0.5) / 65536: from -4.33 to 4.33,
    std 0.99999."""
    inv_cdf = NormalDist().inv_cdf
    return np.array([inv_cdf((i + 0.5) / 65536) for i in range(65536)], dtype=np.float32)


def standard_normal(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Draw float32 samples of N(0, 1) as quantiles of 16-bit uniform integers.

    The probability of any interval is within 1/65536 of the Gaussian's (see
    `_normal_quantiles`); tails stop at 4.33 std.

    Parameters
    ----------
    rng : numpy.random.Generator
    shape : tuple of int

    Returns
    -------
    float32 array of `shape`
    """
    return np.take(_normal_quantiles(), rng.integers(0, 65536, shape, dtype=np.uint16))


def ir_shadow(depth: np.ndarray, fb: float, tolerance: float = 0.1) -> np.ndarray:
    """Find the pixels the projector cannot light (see the module docstring).

    A pixel u can only be shadowed by a pixel u' < u + D_max (D_max = the largest disparity f b / z
    in the image), since x_p(u') >= u' - D_max and x_p(u) < u: a running minimum over that window
    (an erosion) is enough.

    Parameters
    ----------
    depth : (H, W) float32 array
        Metres, 0 = nothing there (never an occluder).
    fb : float
        f * b of the projector at +x, pixel-metres.
    tolerance : float
        Pixels, >= 0.

    Returns
    -------
    (H, W) bool array
    """
    depth = np.asarray(depth, dtype=np.float32)
    cols = np.arange(depth.shape[1], dtype=np.float32)
    with np.errstate(divide="ignore"):
        disparity = np.divide(np.float32(fb), depth)
    disparity[depth <= 0] = -np.inf                                  # x_p = +inf: never an occluder
    d_max = disparity.max()
    if not np.isfinite(d_max):
        return np.zeros(depth.shape, bool)
    xp = cols - disparity
    # u' in [u, u + D_max + 1]
    window = np.ones((1, min(int(np.ceil(d_max)) + 2, depth.shape[1])), np.uint8)
    right_min = cv2.erode(xp, window, anchor=(0, 0), borderType=cv2.BORDER_CONSTANT,
                          borderValue=np.inf)
    # u' = u itself never passes (tolerance >= 0)
    return (depth > 0) & (right_min < xp - tolerance)


def lateral_jitter(depth: np.ndarray, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """Make each pixel read the pixel at a Gaussian offset rounded to -1, 0 or +1 per axis.

    Probabilities to 1/256; offsets of 2 px (0.3 % at sigma = 0.5) are left out.

    Parameters
    ----------
    depth : (H, W) float32 array
    sigma : float
        The offset's std, pixels.
    rng : numpy.random.Generator

    Returns
    -------
    (H, W) float32 array
        Outside the image reads 0.
    """
    h, w = depth.shape
    # 256 * P(N(0, sigma) > 0.5): rounds to +1
    k = round(256 * 0.5 * erfc(0.5 / (sigma * np.sqrt(2.0))))
    # random byte -> offset -1, 0 or +1
    step = np.zeros(256, np.int16)
    step[:k], step[256 - k:] = -1, 1
    # (u, v) offsets, probabilities to 1/256
    offset = cv2.LUT(rng.integers(0, 256, (h, w, 2), dtype=np.uint8), step)
    offset += _pixel_grid(h, w)
    return cv2.remap(depth, offset, None, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT,
                     borderValue=0)


@cache
def _pixel_grid(h: int, w: int) -> np.ndarray:
    """(h, w, 2) int16 read-only (u, v) of every pixel: an OpenCV CV_16SC2 map."""
    grid = np.stack(np.meshgrid(np.arange(w, dtype=np.int16), np.arange(h, dtype=np.int16)),
                    axis=-1)
    grid.flags.writeable = False
    return grid
