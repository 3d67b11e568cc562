"""Image polygons (mirror boundaries, regions of interest): validation and rasterisation to pixel
masks."""
from __future__ import annotations

import cv2
import numpy as np

from mirrorcore.base.errors import MirrorscanError

MIN_VERTICES = 3             # a polygon's fewest corners (an outline, a region)
# a drawn outline has a handful of corners; the crossing test is quadratic in the worst case
MAX_VERTICES = 1000
PAIR_BLOCK = 1 << 18    # edge pairs tested at once by first_crossing (a few MB of temporaries)


def validate_polygon(points, shape: tuple[int, int] | None = None,
                     where: str = "polygon") -> np.ndarray:
    """Check a closed polygon of pixel coordinates.

    Parameters
    ----------
    points : array_like
        The vertices, [u, v] pairs, pixels.
    shape : (int, int), optional
        (H, W) of the image the vertices must lie in.
    where : str
        What the polygon is, for the messages.

    Returns
    -------
    (n, 2) float64 array
        The vertices (u, v).

    Raises
    ------
    MirrorscanError
        Naming `where`: fewer than MIN_VERTICES or more than MAX_VERTICES vertices, non-finite
        values, vertices outside the image, a polygon with no area, or a polygon whose edges cross
        each other.
    """
    try:
        poly = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise MirrorscanError(f"{where}: vertices must be [u, v] pairs of numbers") from None
    if poly.ndim != 2 or poly.shape[1] != 2:
        raise MirrorscanError(
            f"{where}: vertices must be [u, v] pairs, got an array of shape {poly.shape}")
    if len(poly) < MIN_VERTICES:
        raise MirrorscanError(
            f"{where}: a polygon needs at least {MIN_VERTICES} vertices, got {len(poly)}")
    if len(poly) > MAX_VERTICES:
        raise MirrorscanError(
            f"{where}: {len(poly):,} vertices, more than the {MAX_VERTICES:,} a polygon may have")
    if not np.all(np.isfinite(poly)):
        raise MirrorscanError(f"{where}: vertices must be finite numbers")
    if shape is not None:
        outside = np.nonzero((poly[:, 0] < -0.5) | (poly[:, 1] < -0.5) | (poly[:, 0] > shape[
            1] - 0.5)
                             | (poly[:, 1] > shape[0] - 0.5))[0]
        if len(outside):
            i = int(outside[0])
            raise MirrorscanError(
                f"{where}: vertex {i + 1} ({poly[i, 0]:g}, {poly[i, 1]:g}) is outside the "
                                  f"{shape[1]}x{shape[0]} image")
    crossing = first_crossing(poly)
    if crossing is not None:
        raise MirrorscanError(
            f"{where}: the polygon crosses itself (edges {crossing[0] + 1} and {crossing[1] + 1})")
    if abs(polygon_area(poly)) < 1e-9:
        raise MirrorscanError(f"{where}: the polygon has no area (its vertices are collinear)")
    return poly


def polygon_area(poly: np.ndarray) -> float:
    """Return the signed area (shoelace) of a polygon.

    Parameters
    ----------
    poly : (n, 2) array
        Vertices (u, v), pixels.

    Returns
    -------
    float
        Pixels^2.
    """
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def first_crossing(poly: np.ndarray) -> tuple[int, int] | None:
    """Find the first pair of non-adjacent edges of a polygon that intersect.

    Memory stays bounded whatever the polygon's size: the pairs are tested in blocks of rows of at
    most PAIR_BLOCK pairs, and only pairs whose bounding boxes overlap are tested exactly. Time is
    quadratic in the worst case, which is why polygons are limited to MAX_VERTICES.

    Parameters
    ----------
    poly : (n, 2) array
        Vertices (u, v); edge i runs from vertex i to i+1.

    Returns
    -------
    (int, int) or None
        The first pair (i, j), i < j, in row-major order, or None.
    """
    a = np.asarray(poly, dtype=np.float64)
    b = np.roll(a, -1, axis=0)
    n = len(a)
    lo, hi = np.minimum(a, b), np.maximum(a, b)                    # (n, 2) each edge's bounding box
    rows = max(1, PAIR_BLOCK // max(n, 1))
    for start in range(0, n, rows):
        i = np.arange(start, min(start + rows, n))[:, None]
        j = np.arange(n)[None, :]
        pair = (j >= i + 2) & ~((i == 0) & (j == n - 1))            # non-adjacent, each pair once
        pair &= np.all((lo[i] <= hi[j]) & (lo[j] <= hi[i]), axis=2)   # bounding boxes overlap
        ii, jj = np.nonzero(pair)
        hit = _segments_meet(a[ii + start], b[ii + start], a[jj], b[jj])
        if hit.any():
            # row-major: the first pair in (i, j) order
            k = int(np.argmax(hit))
            return int(ii[k] + start), int(jj[k])
    return None


def _segments_meet(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """(k,) bool: segment p1-q1 meets segment p2-q2 (touching included); all inputs (k, 2) float."""
    def orient(p, q, r):
        return np.sign((q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (r[
            :, 0] - p[:, 0]))

    def on_segment(p, q, r):  # r collinear with p-q lies within its bounding box
        return ((np.minimum(p[:, 0], q[:, 0]) <= r[:, 0]) & (r[:, 0] <= np.maximum(p[:, 0], q[
            :, 0]))
                & (np.minimum(p[:, 1], q[:, 1]) <= r[:, 1]) & (r[:, 1] <= np.maximum(p[:, 1], q[
                    :, 1])))

    o1, o2, o3, o4 = orient(p1, q1, p2), orient(p1, q1, q2), orient(p2, q2, p1), orient(p2, q2, q1)
    hit = (o1 != o2) & (o3 != o4) & (o1 != 0) & (o2 != 0) & (o3 != 0) & (o4 != 0)
    hit |= (o1 == 0) & on_segment(p1, q1, p2)
    hit |= (o2 == 0) & on_segment(p1, q1, q2)
    hit |= (o3 == 0) & on_segment(p2, q2, p1)
    hit |= (o4 == 0) & on_segment(p2, q2, q1)
    return hit


def edge_distance(poly, uv: tuple[float, float]) -> float:
    """Return the signed distance from a pixel to a polygon's edge.

    Parameters
    ----------
    poly : (n, 2) array
        Vertices (u, v), pixels.
    uv : (float, float)
        The pixel.

    Returns
    -------
    float
        Pixels, > 0 inside, < 0 outside; -inf for fewer than MIN_VERTICES vertices (no polygon:
        nothing is inside).
    """
    if len(poly) < MIN_VERTICES:
        return -np.inf
    contour = np.asarray(poly, np.float32).reshape(-1, 1, 2)
    return float(cv2.pointPolygonTest(contour, (float(uv[0]), float(uv[1])), True))


def polygon_mask(poly: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Rasterise a polygon to a pixel mask with OpenCV.

    Vertices snap to the nearest pixel centre. A pixel is in the mask when its centre is inside the
    snapped polygon or on an edge (and, as OpenCV rasterises, within half a pixel outside an edge):
    every pixel a user sees under the drawn outline counts as inside.

    Parameters
    ----------
    poly : (n, 2) array
        Vertices (u, v), pixels.
    shape : (int, int)
        (H, W) of the mask.

    Returns
    -------
    (H, W) bool array
    """
    pts = np.round(np.asarray(poly, dtype=np.float64)).astype(np.int32).reshape(-1, 1, 2)
    mask = np.zeros(shape, dtype=np.uint8)
    cv2.fillPoly(mask, [pts], 1, lineType=cv2.LINE_8)
    return mask.astype(bool)
