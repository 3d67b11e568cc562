"""The readings of one view of a frame (the camera's real points, or a mirror's virtual points),
ready to be compared with another view: each reading as measured, the surface that its neighbours'
readings give around it, its normal and its noise.

The surface around a reading comes from its neighbours only (leave-one-out: a least-squares
quadratic in the pixel offsets, fitted to the disparity 1/z of the view's readings within
NEIGHBOURS_RADIUS pixels, which is exactly linear on a plane). It is where the reading is looked up
in another view and what the other views' points are compared with, so that which comparison applies
never depends on the reading's own noise (a Kinect's, 6 to 10 mm here, is larger than the 3 to 5 mm
between readings); the comparison itself uses the reading as measured (smoothing moves the points on
an object's steep sides by millimetres).
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mirrorcore.depth.ops import bounding_window
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.depth.noise import axial_sigma

# pixels: a reading's surface is fitted to its (2 r + 1)^2 - 1 neighbours...
NEIGHBOURS_RADIUS = 3
MIN_NEIGHBOURS = 16          # ... of which at least this many must be the same view's readings
# readings near two neighbours whose depths differ by more than this share of the depth (a depth
# edge within a view: an arm in front of the body) are left out
DEPTH_JUMP = 0.03
# readings seen more obliquely than this (ray to surface normal) are left out
MAX_INCIDENCE_DEG = 80.0
# pixels: the lateral uncertainty of a reading (the Kinect v1's lateral jitter)...
LATERAL_PX = 0.5
# ... and of a reading on the rim of the object (next to a pixel of no object), which may be a
# neighbour's depth seen one pixel beside it: with the usual uncertainty, the rims moved the planes
# of the simulated sphere by +1 mm; excluded, by -0.5 to -5 mm on the walking figure, whose views
# overlap mostly near their rims
RIM_LATERAL_PX = 1.5


_OFFSETS = np.array([(du, dv) for dv in range(-NEIGHBOURS_RADIUS, NEIGHBOURS_RADIUS + 1)
                     # (48, 2) pixels
                     for du in range(-NEIGHBOURS_RADIUS, NEIGHBOURS_RADIUS + 1) if du or dv])
_BASIS = np.column_stack([np.ones(len(_OFFSETS)), _OFFSETS[:, 0], _OFFSETS[:, 1],
                          _OFFSETS[:, 0] ** 2,
                          # (48, 6)
                          _OFFSETS[:, 0] * _OFFSETS[:, 1], _OFFSETS[:, 1] ** 2]).astype(np.float64)
# (48, 36): each offset's part
_OUTER = np.einsum("ki,kj->kij", _BASIS, _BASIS).reshape(len(_OFFSETS), -1)
# which neighbours are readings, as the bits of one number
_PATTERN_BITS = 2.0 ** np.arange(len(_OFFSETS))


@dataclass(frozen=True, eq=False)
class ViewPoints:
    """Readings of one view of one frame; metres in the camera frame unless said otherwise.

    Attributes
    ----------
    points : (n, 3) float64 array
        As measured (a mirror's are virtual, behind its glass, until `reflected`).
    anchors : (n, 3) float64 array
        On the surface of each reading's neighbours, on the reading's ray.
    normals : (n, 3) float64 array
        Unit normals of that surface, towards the camera that measured the reading.
    rays : (n, 3) float64 array
        Unit directions of the readings' rays (from that camera).
    sigma : (n,) float64 array
        Metres, each reading's depth noise (noise.axial_sigma of the anchor's depth).
    anchor_var : (n,) float64 array
        Square metres, the variance of each anchor's error along its ray (from the scatter of its
        neighbours about their surface: agreement.py removes the bias it brings through the
        surface's curvature).
    lateral : (n,) float64 array
        Metres, each reading's lateral uncertainty (LATERAL_PX or RIM_LATERAL_PX at its depth).
    rim : (n,) bool array
        The readings on the rim of the object (next to a pixel of no object).
    pixels : (n,) int64 array
        Flat index v * width + u of each reading's pixel.
    surface : (n, 6) float64 array
        The neighbours' surface: its disparity (1/metres) as the quadratic
        [1, du, dv, du^2, du dv, dv^2] . surface in the pixel offsets (du, dv) from the reading's
        pixel.
    """

    points: np.ndarray
    anchors: np.ndarray
    normals: np.ndarray
    rays: np.ndarray
    sigma: np.ndarray
    anchor_var: np.ndarray
    lateral: np.ndarray
    rim: np.ndarray
    pixels: np.ndarray
    surface: np.ndarray

    def __len__(self) -> int:
        return len(self.points)

    def reflected(self, plane: Plane) -> "ViewPoints":
        """Reflect the readings through a plane (paper eq. 3).

        A mirror's virtual readings become real points, with normals towards the mirror's virtual
        camera (still out of the object). `surface` stays in the view's own image.

        Parameters
        ----------
        plane : Plane

        Returns
        -------
        ViewPoints
        """
        return ViewPoints(plane.reflect(self.points), plane.reflect(self.anchors),
                          reflect_directions(plane, self.normals),
                          reflect_directions(plane, self.rays), self.sigma,
                          self.anchor_var, self.lateral, self.rim, self.pixels, self.surface)

    def surface_points(self, intr: Intrinsics, index: np.ndarray, uv: np.ndarray) -> np.ndarray:
        """Find where rays through pixel positions meet the neighbours' surface of readings.

        Parameters
        ----------
        intr : Intrinsics
        index : (m,) integer array
            The readings.
        uv : (m, 2) array
            Pixel positions, within a pixel or so of those readings' pixels.

        Returns
        -------
        (m, 3) array
            Metres, in the view's own space.
        """
        v0, u0 = np.divmod(self.pixels[index], intr.width)
        du, dv = uv[:, 0] - u0, uv[:, 1] - v0
        c = self.surface[index]
        w = c[:, 0] + c[:, 1] * du + c[:, 2] * dv + c[:, 3] * du * du + c[:, 4] * du * dv + c[
            :, 5] * dv * dv
        z = 1.0 / np.maximum(w, 1e-6)
        return np.column_stack([(uv[:, 0] - intr.cx) / intr.fx * z,
                                (uv[:, 1] - intr.cy) / intr.fy * z, z])


def reflect_directions(plane: Plane, vectors: np.ndarray) -> np.ndarray:
    """Reflect directions through the plane's normal (the linear part of the reflection).

    Parameters
    ----------
    plane : Plane
    vectors : (n, 3) array

    Returns
    -------
    (n, 3) array
    """
    return vectors - 2 * (vectors @ plane.n)[:, None] * plane.n


def view_points(intr: Intrinsics, depth: np.ndarray, pixels: np.ndarray,
                rim: np.ndarray) -> ViewPoints:
    """Return the readings of one view.

    Only the readings whose neighbours give a surface (enough of them, no depth edge near) seen at
    most MAX_INCIDENCE_DEG from the view are kept.

    Parameters
    ----------
    intr : Intrinsics
    depth : (H, W) float array
        Metres as measured (a mirror's pixels hold virtual depths).
    pixels : (n,) int64 array
        Flat indices of the view's pixels.
    rim : (H, W) bool array
        Pixels next to no object (their readings are less sure laterally).

    Returns
    -------
    ViewPoints
        In row-major pixel order.
    """
    mine = np.zeros(intr.shape, bool)
    mine.reshape(-1)[pixels] = True
    win = bounding_window(mine, NEIGHBOURS_RADIUS)
    z = np.where(mine[win], depth[win], 0).astype(np.float64)
    rays = np.stack([intr.rays[0][win], intr.rays[1][win],
                     np.ones(z.shape, np.float32)]).astype(np.float64)
    coef, variance, normals, ok = _neighbour_surfaces(z, rays, intr)
    unit = rays / np.linalg.norm(rays, axis=0)
    ok &= mine[win] & _no_depth_edge(z.astype(np.float32))
    ok &= -np.einsum("khw,khw->hw", normals, unit) > np.cos(np.radians(MAX_INCIDENCE_DEG))
    v, u = np.nonzero(ok)
    ray, anchor, measured, on_rim = rays[:, v, u].T, 1.0 / coef[v, u, 0], z[v, u], rim[win][v, u]
    lateral = np.where(on_rim, RIM_LATERAL_PX, LATERAL_PX) * anchor / intr.fx
    # (dz/dw)^2 |ray|^2 var(w)
    anchor_var = variance[v, u] * anchor ** 4 * np.einsum("ij,ij->i", ray, ray)
    return ViewPoints(ray * measured[:, None], ray * anchor[:, None], normals[:, v, u].T,
                      unit[:, v, u].T,
                      axial_sigma(anchor), anchor_var, lateral, on_rim,
                      (v + win[0].start) * intr.width + u + win[1].start, coef[v, u])


def _neighbour_surfaces(z: np.ndarray, rays: np.ndarray, intr: Intrinsics) -> tuple[
    np.ndarray, ...]:
    """The surface through each reading's neighbours (see the module docstring), for every reading
    at once.

    z : (h, w) float64 metres, 0 = not the view's; rays : (3, h, w) (x/z, y/z, 1) of the pixels ->
    coefficients (h, w, 6) (ViewPoints.surface), the variance (h, w) (1/m^2) of the surface's
    disparity at the pixel (the neighbours' scatter about it, so whatever the sensor), the surface's
    unit normal at the pixel (3, h, w) towards the camera, and (h, w) bool where the view has a
    reading and at least MIN_NEIGHBOURS neighbours determine the fit. The least-squares matrix
    depends only on which neighbours are readings: it is inverted once per such pattern (a fifth as
    many as the readings on the walking figure), not once per reading.
    """
    valid = (z > 0).astype(np.float64)
    w = np.divide(1.0, z, out=np.zeros_like(z), where=z > 0)
    # exact: distinct powers of two below 2^48
    pattern = _window_sum(valid, _PATTERN_BITS)
    ok = (z > 0) & (_window_sum(valid, np.ones(len(_OFFSETS))) >= MIN_NEIGHBOURS)
    patterns, which = np.unique(pattern[ok].astype(np.int64), return_inverse=True)
    # (p, 48)
    present = ((patterns[:, None] >> np.arange(len(_OFFSETS))) & 1).astype(np.float64)
    # (p, 6, 6)
    matrices = (present @ _OUTER).reshape(-1, len(_BASIS.T), len(_BASIS.T))
    # ascending: neighbours on a line have a zero
    spread = np.linalg.eigvalsh(matrices)
    solvable = spread[:, 0] > 1e-6 * spread[:, -1]
    inverse = np.zeros_like(matrices)
    inverse[solvable] = np.linalg.inv(matrices[solvable])
    which = which.ravel()
    ok[ok] = solvable[which]
    which = which[solvable[which]]                               # each solvable reading's pattern
    # (n, 6)
    rhs = np.stack([_window_sum(w, column) for column in _BASIS.T], -1)[ok]
    coef, variance = np.zeros(z.shape + (len(_BASIS.T),)), np.zeros(z.shape)
    coef[ok] = np.einsum("nij,nj->ni", inverse[which], rhs)
    # residual sum
    squares = _window_sum(w * w, np.ones(len(_OFFSETS)))[ok] - np.einsum("ij,ij->i", coef[ok], rhs)
    count = present[which].sum(axis=1)
    variance[ok] = np.maximum(squares, 0.0) / np.maximum(count - len(_BASIS.T),
                                                         1.0) * inverse[which, 0, 0]
    ok &= coef[..., 0] > 0
    # w = a + b du + c dv on the plane n.P + d = 0 gives n ~ (b fx, c fy, a - b fx x' - c fy y')
    # with x' = x/z
    a, b, c = coef[..., 0], coef[..., 1] * intr.fx, coef[..., 2] * intr.fy
    normals = np.stack([b, c, a - b * rays[0] - c * rays[1]])
    # towards the camera: the surface is in front of it
    normals *= -np.sign(normals[2])[None]
    normals /= np.maximum(np.linalg.norm(normals, axis=0), 1e-12)
    return coef, variance, normals, ok


def _window_sum(image: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Sum over each pixel's neighbours (_OFFSETS, not itself) of image * weights (one per offset):
    (h, w) float64 (filter2D correlates: offset (du, dv) reads the pixel du columns right and dv
    rows down)."""
    kernel = np.zeros((2 * NEIGHBOURS_RADIUS + 1,) * 2)
    kernel[_OFFSETS[:, 1] + NEIGHBOURS_RADIUS, _OFFSETS[:, 0] + NEIGHBOURS_RADIUS] = weights
    return cv2.filter2D(image, cv2.CV_64F, kernel, borderType=cv2.BORDER_CONSTANT)


def _no_depth_edge(z: np.ndarray) -> np.ndarray:
    """(h, w) bool: no two neighbouring readings (z > 0, metres) within NEIGHBOURS_RADIUS pixels
    differ by more than DEPTH_JUMP of their depth."""
    edge = np.zeros(z.shape, bool)
    for axis in (0, 1):
        a, b = np.swapaxes(z, 0, axis)[:-1], np.swapaxes(z, 0, axis)[1:]
        jump = (a > 0) & (b > 0) & (np.abs(a - b) > DEPTH_JUMP * np.minimum(a, b))
        np.swapaxes(edge, 0, axis)[:-1] |= jump
        np.swapaxes(edge, 0, axis)[1:] |= jump
    size = 2 * NEIGHBOURS_RADIUS + 1
    return ~cv2.dilate(edge.view(np.uint8), np.ones((size, size), np.uint8)).astype(bool)
