"""Operations on depth images (metres, 0 = no reading): median and robust mean of several frames,
edge-aware smoothing, and local quadratic fits of chosen pixels."""
from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import cv2
import numpy as np
from threadpoolctl import ThreadpoolController

from mirrorcore.depth.noise import KINECT_AXIAL_COEF, axial_sigma

QUADRATIC_RADIUS = 4        # pixels: local_quadratic_depth fits the 9 x 9 pixels around each pixel
QUADRATIC_SIGMA = 3.0       # pixels: the spatial Gaussian's sigma
# the range Gaussian's sigma, in units of the sensor's disparity noise (1.425e-3 / m)
QUADRATIC_STRENGTH = 2.0
QUADRATIC_CHUNK = 16384     # pixels fitted at once: 16384 x 81 neighbours, about 5 MB an array
# a ridge of RIDGE x the total weight keeps a fit on a strip of pixels solvable
RIDGE = 1e-4
# the disparity (1/m) given to pixels that must not count: its range weight is 0
NO_READING = np.float32(1e3)
# robust_mean_depth averages the readings within this many depth-noise sigmas of the median
MEAN_SIGMAS = 3.0
# without_occluders leaves out readings this many depth-noise sigmas in front of the background's
OCCLUDER_SIGMAS = 5.0


def median_depth(frames: np.ndarray) -> np.ndarray:
    """Return the per-pixel median of several frames, ignoring frames with no reading there.

    Parameters
    ----------
    frames : (k, H, W) or (H, W) float array
        Metres, 0 = no reading.

    Returns
    -------
    (H, W) float32 array
        Metres, 0 where no frame has a reading.
    """
    frames = np.asarray(frames, dtype=np.float32)
    if frames.ndim == 2:
        return frames
    stack = np.where(frames > 0, frames, np.nan)
    valid = np.any(frames > 0, axis=0)
    out = np.zeros(frames.shape[1:], dtype=np.float32)
    out[valid] = np.nanmedian(stack[:, valid], axis=0)
    return out


def robust_mean_depth(frames: np.ndarray) -> np.ndarray:
    """Return the per-pixel mean of the readings within MEAN_SIGMAS of the noise of their median.

    The noise is `noise.axial_sigma`. What passed in front in a few frames is left out as by the
    median, and the mean of the rest averages the camera's disparity steps (11 mm apart at 2 m),
    where the median snaps to one of them.

    Parameters
    ----------
    frames : (k, H, W) or (H, W) float array
        Metres, 0 = no reading.

    Returns
    -------
    (H, W) float32 array
        Metres, 0 where no frame has a reading.
    """
    frames = np.asarray(frames, dtype=np.float32)
    if frames.ndim == 2:
        return frames
    median = median_depth(frames)
    keep = (frames > 0) & (np.abs(frames - median) <= np.float32(MEAN_SIGMAS) * axial_sigma(median))
    count = keep.sum(axis=0)
    return np.where(count > 0, np.where(keep, frames, 0).sum(axis=0) / np.maximum(count, 1),
                    0).astype(np.float32)


def without_occluders(frames: np.ndarray, background: np.ndarray) -> np.ndarray:
    """Remove from frames what passes in front of a static background.

    A reading more than OCCLUDER_SIGMAS depth-noise sigmas in front of the background's reading
    becomes no reading (0), such as a person walking past a mirror's markers. Pixels where the
    background has no reading keep theirs.

    Parameters
    ----------
    frames : (k, H, W) float array
        Metres, 0 = no reading.
    background : (H, W) float array
        Metres, 0 = no reading.

    Returns
    -------
    (k, H, W) float32 array
        Metres.
    """
    frames, background = np.asarray(frames, dtype=np.float32), np.asarray(background,
                                                                          dtype=np.float32)
    nearest = background - np.float32(OCCLUDER_SIGMAS) * axial_sigma(background)
    front = (background > 0) & (frames < nearest)
    return np.where(front, np.float32(0), frames)


def bounding_window(mask: np.ndarray, pad: int = 0) -> tuple[slice, slice]:
    """Return the smallest box holding every True pixel of a mask, grown by `pad` pixels.

    Parameters
    ----------
    mask : (H, W) bool array
        The pixels.
    pad : int
        Pixels added on each side, within the image.

    Returns
    -------
    (slice, slice)
        (rows, columns); empty slices when the mask is empty.
    """
    u, v, w, h = cv2.boundingRect(mask.view(np.uint8))
    if w == 0:
        return slice(0, 0), slice(0, 0)
    rows, cols = mask.shape
    return slice(max(v - pad, 0), min(v + h + pad, rows)), slice(max(u - pad, 0),
                                                                 min(u + w + pad, cols))


def smooth_depth(depth: np.ndarray, mask: np.ndarray, radius: int = 2,
                 strength: float = 3.0) -> np.ndarray:
    """Smooth the masked pixels of a depth image, edge-aware, in inverse depth (disparity).

    A structured-light camera's noise is constant in disparity (sigma_z = 1.425e-3 z^2 is
    sigma_w = 1.425e-3 in w = 1/z), so a bilateral filter on w with a range sigma of `strength` *
    1.425e-3 averages a pixel with neighbours of the same surface and ignores those across a depth
    edge, at every depth. Pixels outside `mask` neither change nor contribute.

    Parameters
    ----------
    depth : (H, W) float array
        Metres.
    mask : (H, W) bool array
        The pixels smoothed.
    radius : int
        Pixels, the filter's half-width and its spatial sigma.
    strength : float
        The range sigma in units of the disparity noise 1.425e-3 / m.

    Returns
    -------
    (H, W) float32 array
        Metres; unmasked pixels as they were.
    """
    depth = np.asarray(depth, dtype=np.float32)
    out = depth.copy()
    # the filter only needs the masked pixels and their neighbours
    win = bounding_window(mask, radius)
    use = mask[win] & (depth[win] > 0)
    if not use.size:
        return out
    # Pixels outside the mask get w = -1: a range difference of > 1 m^-1 gives them zero weight.
    w = np.full(use.shape, -1.0, np.float32)
    masked_copy(inverse(depth[win]), use, w)
    filtered = cv2.bilateralFilter(w, 2 * radius + 1, strength * KINECT_AXIAL_COEF, radius)
    masked_copy(inverse(filtered), use & (filtered > 0), out[win])
    return out


def local_quadratic_depth(depth: np.ndarray, reference: np.ndarray, pixels: np.ndarray,
                          labels: np.ndarray,
                          radius: int = QUADRATIC_RADIUS, sigma: float = QUADRATIC_SIGMA,
                          strength: float = QUADRATIC_STRENGTH) -> np.ndarray:
    """Smooth depth along the surface's curvature by local quadratic fits in disparity.

    At each of `pixels`, a weighted least-squares quadratic surface in disparity w = 1/z (six
    coefficients in the pixel offsets; a plane's disparity is linear in them, so planes are fitted
    exactly and curved surfaces to second order) goes through the readings of the
    (2 radius + 1)^2 pixels around it that carry the same label, and is evaluated at the pixel.

    The weights are a spatial Gaussian (`sigma` pixels) times a range Gaussian of the neighbour's
    disparity against the pixel's `reference` (sigma `strength` * 1.425e-3 / m, the sensor's
    disparity noise): readings of another surface across a depth edge drop out, as in
    `smooth_depth`. Unlike an average (`smooth_depth`), the fit does not sag on a curved surface,
    so it can span more pixels. A pixel with less neighbours' weight than coefficients, or whose fit
    lands more than one range sigma from its reference, keeps its reference; a small ridge keeps the
    fit on a strip one or two pixels wide solvable (it then tends to a fit of lower degree).

    Parameters
    ----------
    depth : (H, W) float array
        Metres, the readings (0 = none).
    reference : (H, W) float array
        Metres, e.g. `smooth_depth`'s result; > 0 at `pixels`.
    pixels : (n,) integer array
        Flat indices v * W + u.
    labels : (H, W) integer array
        Neighbours count only where equal to the pixel's.
    radius : int
        Pixels, the window's half-width.
    sigma : float
        Pixels, the spatial Gaussian's sigma.
    strength : float
        The range sigma in units of the disparity noise 1.425e-3 / m.

    Returns
    -------
    (H, W) float32 array
        Metres: `reference` with `pixels` replaced by their fits.
    """
    out = np.asarray(reference, np.float32).copy()
    pixels = np.asarray(pixels, np.int64)
    window = _QuadraticWindow.of(radius, sigma, strength)
    flat, pixel_labels = out.reshape(-1), np.asarray(labels).reshape(-1)[pixels]
    with _blas().limit(limits=1, user_api="blas"):       # see _blas
        _fit_labels(depth, labels, pixels, pixel_labels, window, flat)
    return out


def _fit_labels(depth: np.ndarray, labels: np.ndarray, pixels: np.ndarray, pixel_labels: np.ndarray,
                window: _QuadraticWindow, flat: np.ndarray) -> None:
    """local_quadratic_depth's fits, label by label and in chunks, written into `flat` (H * W,)
    float32 metres."""
    for label in np.unique(pixel_labels):
        chosen = pixels[pixel_labels == label]
        rows, cols = np.divmod(chosen, np.shape(depth)[1])
        box = (slice(rows.min(), rows.max() + 1), slice(cols.min(), cols.max() + 1))
        neighbours = window.neighbours(depth, labels == label, box)
        for start in range(0, len(chosen), QUADRATIC_CHUNK):
            part = slice(start, start + QUADRATIC_CHUNK)
            at = chosen[part]
            readings = neighbours[rows[part] - box[0].start,
                                  cols[part] - box[1].start].reshape(len(at), -1)
            flat[at] = window.fit(readings, flat[at])


@cache
def _blas() -> ThreadpoolController:
    """The process's BLAS thread pools. The fits' matrix products are tall and thin (n x 81 by 81 x
    21), and after a multi-threaded product OpenBLAS's idle threads spin: a live loop fitting 13,600
    pixels took a whole core more at 10 frames a second with no tab open (1.2 cores against 0.25),
    for products 0.5 ms faster."""
    return ThreadpoolController()


@dataclass(frozen=True)
class _QuadraticWindow:
    """local_quadratic_depth's window of k = (2 radius + 1)^2 pixels: its design matrix (k, 6) in
    the pixel offsets (x, y, x^2, xy, y^2, 1: the constant last, which elimination then leaves for
    last), the products of its columns (k, 21, the upper triangle), the spatial weights (k,) and the
    range sigma (1/m)."""

    radius: int
    design: np.ndarray
    products: np.ndarray
    spatial: np.ndarray
    range_sigma: float

    @classmethod
    def of(cls, radius: int, sigma: float, strength: float) -> _QuadraticWindow:
        """Build the window of `radius` with spatial `sigma` (pixels) and range `strength`."""
        offsets = np.arange(-radius, radius + 1, dtype=np.float32)
        dy, dx = (a.ravel() for a in np.meshgrid(offsets, offsets, indexing="ij"))
        design = np.stack([dx, dy, dx * dx, dx * dy, dy * dy, np.ones_like(dx)], axis=1)
        upper = np.triu_indices(6)
        return cls(radius, design, design[:, upper[0]] * design[:, upper[1]],
                   np.exp(-(dx * dx + dy * dy) / np.float32(2 * sigma * sigma)),
                   strength * KINECT_AXIAL_COEF)

    def neighbours(self, depth: np.ndarray, same: np.ndarray,
                   box: tuple[slice, slice]) -> np.ndarray:
        """Return a view of the disparities in the windows around the pixels of `box` (h, w).

        depth (H, W) metres and same (H, W) bool, the pixels whose readings count -> (h, w, 2 radius
        + 1, 2 radius + 1) float32, NO_READING where a reading does not count or is missing or lies
        outside the image.
        """
        r, (height, width) = self.radius, np.shape(depth)
        grow = (slice(max(box[0].start - r, 0), min(box[0].stop + r, height)),
                slice(max(box[1].start - r, 0), min(box[1].stop + r, width)))
        w = np.full((box[0].stop - box[0].start + 2 * r, box[1].stop - box[1].start + 2 * r),
                    NO_READING, np.float32)
        inside = w[grow[0].start - box[0].start + r:grow[0].stop - box[0].start + r,
                   grow[1].start - box[1].start + r:grow[1].stop - box[1].start + r]
        values = np.asarray(depth[grow], np.float32)
        use = same[grow] & (values > 0)
        inside[use] = inverse(values[use])
        return np.lib.stride_tricks.sliding_window_view(w, (2 * r + 1, 2 * r + 1))

    def fit(self, readings: np.ndarray, reference: np.ndarray) -> np.ndarray:
        """Fit the pixels' windows and return the fitted depths, (n,) float32 metres.

        readings : (n, k) float32 disparities (1/m) of the pixels' windows; reference : (n,) float32
        metres, returned where the fit is not determined or lands more than a range sigma from it.
        """
        ref_w = inverse(reference)
        residual = readings - ref_w[:, None]
        # exp(-80) is 2e-35, no weight; the clamp keeps cv2.exp off its slow path for arguments
        # below float32's range
        weight = cv2.exp(cv2.max(cv2.multiply(residual, residual,
                                              scale=-0.5 / self.range_sigma ** 2), -80.0))
        weight *= self.spatial
        total = weight.sum(axis=1)
        offset = _eliminate(weight @ self.products, (weight * residual) @ self.design,
                            RIDGE * total)
        ok = (total >= self.design.shape[1]) & (np.abs(offset) <= self.range_sigma)
        return np.where(ok, inverse(ref_w + offset), reference)


def _eliminate(products: np.ndarray, rhs: np.ndarray, ridge: np.ndarray) -> np.ndarray:
    """The last unknown of n symmetric positive 6 x 6 systems (M + ridge I) x = rhs, by Gaussian
    elimination vectorised over the systems (5 steps; numpy's batched solve takes 10 times as long
    for 6 x 6 systems).
    products : (n, 21) the upper triangle of M, row by row; rhs : (n, 6); ridge : (n,) -> (n,)
    float32."""
    upper = np.triu_indices(6)
    # systems last: each step is a few whole-array operations
    system = np.empty((6, 7, len(rhs)), np.float32)
    system[upper[0], upper[1]] = system[upper[1], upper[0]] = products.T
    system[:, 6] = rhs.T
    system[np.arange(6), np.arange(6)] += ridge
    for k in range(5):
        factor = system[k + 1:, k] / system[k, k]
        system[k + 1:, k:] -= factor[:, None, :] * system[k, None, k:]
    return system[5, 6] / system[5, 5]


def inverse(values: np.ndarray) -> np.ndarray:
    """Return 1 / values, elementwise (inf where 0).

    Parameters
    ----------
    values : array
        Float32 values stay float32.

    Returns
    -------
    array
        Same shape and float dtype.
    """
    with np.errstate(divide="ignore"):
        return np.divide(np.float32(1), values)


def masked_copy(source: np.ndarray, mask: np.ndarray, target: np.ndarray) -> None:
    """Copy ``target[mask] = source[mask]`` in place, with OpenCV's masked copy.

    It writes the same values as numpy's ``where=``, faster on the live loop's windows.

    Parameters
    ----------
    source : (H, W) array
        The values copied.
    mask : (H, W) bool array
        The pixels copied.
    target : (H, W) array
        Of `source`'s dtype; may be a window of a larger image (rows apart, pixels contiguous).
    """
    cv2.copyTo(source, mask.view(np.uint8), target)
