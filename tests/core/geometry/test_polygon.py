"""Polygons: validation (too few vertices, self-crossing, outside the image) and rasterisation at
the edges."""
from __future__ import annotations

import tracemalloc

import cv2
import numpy as np
import pytest

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.polygon import (
    MAX_VERTICES,
    edge_distance,
    first_crossing,
    polygon_mask,
    validate_polygon,
)


def test_square_mask_includes_its_edges_only():
    mask = polygon_mask(np.array([[2, 1], [5, 1], [5, 3], [2, 3]], float), (6, 8))
    expected = np.zeros((6, 8), bool)
    # rows (v) 1..3, columns (u) 2..5: u and v not swapped, edges included
    expected[1:4, 2:6] = True
    np.testing.assert_array_equal(mask, expected)


def test_mask_agrees_with_point_in_polygon():
    rng = np.random.default_rng(0)
    for _ in range(5):
        centre = rng.uniform(100, 200, 2)
        angles = np.sort(rng.uniform(0, 2 * np.pi, 7))
        poly = centre + np.stack([np.cos(angles), np.sin(angles)], 1) * rng.uniform(30, 90, (7, 1))
        mask = polygon_mask(poly, (300, 300))
        v, u = np.mgrid[0:300, 0:300]
        # vertices snap to pixel centres
        contour = np.round(poly).astype(np.float32).reshape(-1, 1, 2)
        dist = np.array([cv2.pointPolygonTest(contour, (float(x), float(y)), True)
                         for x, y in zip(u.ravel()[::7], v.ravel()[::7])])
        sampled = mask.ravel()[::7]
        assert sampled[dist >= 0].all()            # inside or on an edge: in the mask
        assert not sampled[dist < -0.5].any()      # more than half a pixel outside: not in it


def test_pixel_centres_on_an_edge_are_inside():
    tri = np.array([[10, 10], [30, 10], [10, 30]], float)
    mask = polygon_mask(tri, (40, 40))
    assert mask[10, 10:31].all() and mask[10:31, 10].all()     # the two axis-aligned edges
    assert mask[20, 20] and not mask[21, 21]                   # on the hypotenuse; one step past it


@pytest.mark.parametrize("poly, message", [
    ([[0, 0], [1, 1]], "at least 3 vertices"),
    ([[0, 0], [10, 10], [10, 0], [0, 10]], r"crosses itself \(edges 1 and 3\)"),
    ([[0, 0], [5, 5], [10, 10]], "no area"),
    ([[0, 0], [700, 0], [0, 10]], r"vertex 2 \(700, 0\) is outside the 640x480 image"),
    ([[0, 0], [np.nan, 0], [0, 10]], "finite"),
])
def test_bad_polygons_are_refused_naming_the_boundary(poly, message):
    with pytest.raises(MirrorscanError, match=message):
        validate_polygon(poly, (480, 640), "mirror 1: boundary")


def test_valid_concave_polygon_passes():
    poly = validate_polygon([[0, 0], [10, 0], [5, 3], [10, 10], [0, 10]], (480, 640))
    assert poly.shape == (5, 2)


def test_edge_distance_is_signed_and_nothing_is_inside_no_polygon():
    square = [(10, 10), (100, 10), (100, 100), (10, 100)]
    # inside: to the nearest edge
    assert edge_distance(square, (50, 30)) == pytest.approx(20.0)
    assert edge_distance(square, (103, 50)) == pytest.approx(-3.0)         # outside
    assert edge_distance(square, (100, 50)) == 0.0                         # on it
    assert edge_distance(square[:2], (50, 10)) == -np.inf


# --------------------------------------------------------------------- polygons
def test_the_crossing_test_of_a_large_polygon_stays_small_in_memory():
    angles = np.linspace(0, 2 * np.pi, 8000, endpoint=False)
    circle = np.c_[320 + 200 * np.cos(angles), 240 + 200 * np.sin(angles)]
    tracemalloc.start()
    assert first_crossing(circle) is None                           # 32 M edge pairs: 4.3 GB before
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 50 << 20
    bowtie = circle.copy()
    # two vertices swapped: it crosses itself
    bowtie[[10, 4000]] = bowtie[[4000, 10]]
    assert first_crossing(bowtie) is not None
    with pytest.raises(MirrorscanError,
                       match=f"boundary: 8,000 vertices, more than the {MAX_VERTICES:,}"):
        validate_polygon(circle, (480, 640), "boundary")


def test_the_first_crossing_is_the_same_pair_as_the_exhaustive_test():
    rng = np.random.default_rng(3)

    def exhaustive(poly):
        n = len(poly)
        for i in range(n):
            for j in range(i + 2, n):
                if i == 0 and j == n - 1:
                    continue
                if _meet(poly[i], poly[(i + 1) % n], poly[j], poly[(j + 1) % n]):
                    return i, j
        return None

    for _ in range(300):
        poly = rng.integers(0, 6, (int(rng.integers(4, 12)), 2)).astype(float)
        assert first_crossing(poly) == exhaustive(poly)


def _meet(p1, q1, p2, q2) -> bool:
    """Segment p1-q1 meets p2-q2, touching included (a plain scalar test to compare with)."""
    def orient(p, q, r):
        return np.sign((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]))

    def on(p, q, r):
        return min(p[0], q[0]) <= r[0] <= max(p[0], q[0]) and min(p[1], q[1]) <= r[1] <= max(p[
            1], q[1])

    o1, o2, o3, o4 = orient(p1, q1, p2), orient(p1, q1, q2), orient(p2, q2, p1), orient(p2, q2, q1)
    if o1 * o2 < 0 and o3 * o4 < 0:
        return True
    return any(o == 0 and on(a, b, c) for o, a, b, c in
               ((o1, p1, q1, p2), (o2, p1, q1, q2), (o3, p2, q2, p1), (o4, p2, q2, q1)))
