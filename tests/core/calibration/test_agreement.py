"""The readings of a view and their comparison with another view's surface (readings.py,
agreement.py): exact on analytic surfaces, edges and rims left out, the heat map's local
means."""
from dataclasses import replace

import cv2
import numpy as np
import pytest
from tests.helpers import plane_depth, sphere_depth

from mirrorcore.calibration.agreement import TargetView, local_means
from mirrorcore.calibration.readings import NEIGHBOURS_RADIUS, ViewPoints, view_points
from mirrorcore.geometry.camera import Intrinsics, project_points
from mirrorcore.geometry.plane import Plane

CAMERA = Intrinsics.kinect_v1()


def test_neighbour_surface_is_exact_on_a_plane_and_leaves_the_reading_out():
    wall = Plane.from_point_normal([0.0, 0.0, 2.5], [0.3, -0.2, -1.0])
    depth = plane_depth(CAMERA, wall).astype(np.float64)
    square = np.zeros(CAMERA.shape, bool)
    square[200:260, 300:360] = True
    rim = np.zeros(CAMERA.shape, bool)
    view = view_points(CAMERA, depth, np.flatnonzero(square), rim)
    assert 40 * 40 < len(view) <= 60 * 60
    np.testing.assert_allclose(wall.signed_distance(view.anchors), 0, atol=1e-6)
    # towards the camera
    np.testing.assert_allclose(view.normals, np.tile(wall.n, (len(view), 1)), atol=1e-4)
    np.testing.assert_allclose(view.points, view.anchors, atol=1e-6)
    # a reading 4 cm off: its own anchor stays on the plane (its neighbours give it), its
    # neighbours' move
    depth[230, 330] += 0.04
    moved = view_points(CAMERA, depth, np.flatnonzero(square), rim)
    where = np.searchsorted(moved.pixels, [230 * CAMERA.width + 330, 230 * CAMERA.width + 331])
    assert wall.signed_distance(moved.anchors[where[0]]) == pytest.approx(0, abs=1e-6)
    assert abs(wall.signed_distance(moved.points[where[0]])) > 0.01
    assert abs(wall.signed_distance(moved.anchors[where[1]])) > 1e-4


def test_readings_beside_a_depth_edge_are_left_out():
    depth = np.full(CAMERA.shape, 2.0)
    depth[:, 320:] = 2.3                                  # a step of 30 cm within one view
    square = np.zeros(CAMERA.shape, bool)
    square[200:260, 290:350] = True
    view = view_points(CAMERA, depth, np.flatnonzero(square), np.zeros(CAMERA.shape, bool))
    columns = view.pixels % CAMERA.width
    assert len(view) and not np.any((columns >= 320 - NEIGHBOURS_RADIUS) & (
        columns < 320 + NEIGHBOURS_RADIUS))
    assert columns.min() < 300 and columns.max() > 340


def test_an_anchors_variance_is_that_of_its_error():
    """On a tilted wall with Kinect v1 disparity noise (1.425e-3 / m), the anchors' variance along
    their rays (from their neighbours' scatter) matches their actual error over the readings, to 10
    %."""
    wall = Plane.from_point_normal([0.0, 0.0, 2.5], [0.3, -0.2, -1.0])
    truth = plane_depth(CAMERA, wall).astype(np.float64)
    noisy = 1.0 / (1.0 / truth + 1.425e-3 * np.random.default_rng(4).standard_normal(truth.shape))
    square = np.zeros(CAMERA.shape, bool)
    square[150:330, 220:420] = True
    view = view_points(CAMERA, noisy, np.flatnonzero(square), np.zeros(CAMERA.shape, bool))
    rays = view.anchors / view.anchors[:, 2:]
    error = (view.anchors[:, 2] - truth.reshape(-1)[view.pixels]) * np.linalg.norm(rays, axis=1)
    assert np.mean(error ** 2) == pytest.approx(np.mean(view.anchor_var), rel=0.1)
    # a 48-reading fit of readings 9 mm apart in depth
    assert 2e-3 < np.sqrt(np.mean(view.anchor_var)) < 5e-3


def test_the_anchors_error_does_not_bias_the_residual_on_a_curved_surface():
    """A ball 5 cm across (a limb's curvature) seen by the camera, and exact points of it seen
    obliquely from the side whose anchors are 8 mm off along their rays: the tangent where an anchor
    falls passes beside its point, inside the ball by 1.1 mm on average here; the comparison removes
    all but a tenth of that, knowing only the anchors' variance."""
    centre, radius, spread = np.array([0.0, 0.0, 2.0]), 0.05, 0.008
    depth = sphere_depth(CAMERA, centre, radius).astype(np.float64)
    target = TargetView(CAMERA, view_points(CAMERA, depth, np.flatnonzero(depth > 0), depth == 0))
    rng = np.random.default_rng(5)
    normals = rng.standard_normal((20000, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    points = centre + radius * normals
    # the other view, 1.5 m to the camera's right
    side = np.array([1.5, 0.0, 2.0])
    rays = (points - side) / np.linalg.norm(points - side, axis=1)[:, None]
    to_camera = -points / np.linalg.norm(points, axis=1)[:, None]
    seen = (-np.einsum("ij,ij->i", normals, rays) > np.cos(np.radians(80)))
    # away from the camera's rim
    seen &= np.einsum("ij,ij->i", normals, to_camera) > np.cos(np.radians(55))
    n = int(seen.sum())
    points, normals, rays = points[seen], normals[seen], rays[seen]
    anchors = points + spread * rng.standard_normal(n)[:, None] * rays
    mapped = ViewPoints(points, anchors, normals, rays, np.full(n, 0.05), np.full(n, spread ** 2),
                        np.zeros(n),
                        np.zeros(n, bool), np.zeros(n, np.int64), np.zeros((n, 6)))
    blind = replace(mapped, anchor_var=np.zeros(n))
    found, uncorrected = target.compare(mapped), target.compare(blind)
    assert len(found) > 1000 and np.array_equal(found.index, uncorrected.index)
    assert np.mean(uncorrected.residual) < -8e-4                 # -1.07 mm
    # +0.07 mm (+-0.03)
    assert abs(np.mean(found.residual)) < 0.1 * abs(np.mean(uncorrected.residual))


def test_a_point_is_compared_with_the_other_views_rim_only_when_it_surely_falls_there():
    """Exact points of the ball seen from the side that fall on the rim of the camera's view:
    compared when their anchors are known to 1 mm (0.3 pixel there), not when known to 8 mm (2.4
    pixels: the anchor's error could be all that puts them on the object); comparisons inside the
    rim are the same either way."""
    centre, radius = np.array([0.0, 0.0, 2.0]), 0.05
    depth = sphere_depth(CAMERA, centre, radius).astype(np.float64)
    rim = cv2.dilate((depth == 0).view(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    target = TargetView(CAMERA, view_points(CAMERA, depth, np.flatnonzero(depth > 0), rim))
    angle = np.radians(np.linspace(20, 88, 4000))
    # the ball's right side
    normals = np.column_stack([np.sin(angle), np.zeros_like(angle), -np.cos(angle)])
    points = centre + radius * normals
    side = np.array([1.5, 0.0, 2.0])
    rays = (points - side) / np.linalg.norm(points - side, axis=1)[:, None]
    n = len(points)
    exact = ViewPoints(points, points, normals, rays, np.full(n, 0.01), np.zeros(n), np.zeros(n),
                       np.zeros(n, bool),
                       np.zeros(n, np.int64), np.zeros((n, 6)))
    sure, unsure = (target.compare(replace(exact, anchor_var=np.full(n, s ** 2)))
                    for s in (1e-3, 8e-3))
    uv, _ = project_points(CAMERA, points)
    falls = target.index[np.round(uv[:, 1]).astype(int) * CAMERA.width + np.round(uv[:, 0]).astype(
        int)]
    on_rim = target.view.rim[falls[sure.index]]
    assert on_rim.sum() > 20 and not target.view.rim[falls[unsure.index]].any()
    np.testing.assert_array_equal(sure.index[~on_rim], unsure.index)


def test_the_heat_map_colours_a_point_by_its_views_local_mean():
    """One point's distance scatters by the depth noise, so a point is coloured by the mean of the
    finite distances of its own view within the window about it; other views and NaN (not
    compared) stay out."""
    shape = (5, 6)
    pixels = np.ravel_multi_index(([0, 0, 0, 0, 1, 4], [0, 1, 2, 3, 3, 5]), shape)
    values = np.array([1.0, 2.0, np.nan, 10.0, 4.0, 7.0])
    sources = np.array([1, 1, 1, 2, 1, 1])
    means = local_means(values, pixels, sources, shape, size=3)
    # (0, 3) is mirror 2's alone
    np.testing.assert_allclose(means, [1.5, 1.5, np.nan, 10.0, 4.0, 7.0])
