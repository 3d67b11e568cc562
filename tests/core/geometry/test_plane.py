"""Planes: the sign convention, reflection (paper eq. 3), the reflection matrix, and fitting by SVD
and RANSAC."""
import numpy as np
import pytest

from mirrorcore.base.errors import CalibrationError
from mirrorcore.geometry.plane import Plane, fit_plane_ransac, fit_plane_svd
from mirrorcore.geometry.ransac import ransac_iterations


def mirror_2m() -> Plane:
    """A mirror 2 m in front of the camera, tilted: its normal points back to the camera."""
    return Plane.from_point_normal([0.3, -0.1, 2.0], [0.4, 0.1, -1.0])


def test_convention_camera_side_is_positive():
    plane = mirror_2m()
    assert plane.d > 0 and np.linalg.norm(plane.n) == pytest.approx(1)
    # the camera is in front
    assert plane.signed_distance(np.zeros(3)) == pytest.approx(plane.d)
    # beyond the glass is behind
    assert plane.signed_distance([0.3, -0.1, 3.0]) < 0
    # any sign in, the same plane out
    flipped = Plane.from_abcd(-plane.abcd)
    np.testing.assert_allclose(flipped.abcd, plane.abcd)


def test_reflection_by_hand():
    plane = Plane.from_abcd([0, 0, -1, 2])           # z = 2, normal towards the camera (-z)
    np.testing.assert_allclose(plane.reflect(np.array([1.0, 2.0, 3.0])), [1, 2, 1])
    # the virtual camera
    np.testing.assert_allclose(plane.reflect(np.array([0.0, 0.0, 0.0])), [0, 0, 4])


def test_reflection_is_an_involution_and_an_isometry():
    rng = np.random.default_rng(0)
    plane, p = mirror_2m(), rng.normal(size=(200, 3))
    r = plane.reflect(p)
    np.testing.assert_allclose(plane.reflect(r), p, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(r[:100] - r[100:], axis=1),
                               np.linalg.norm(p[:100] - p[100:], axis=1))
    # swaps the sides
    np.testing.assert_allclose(plane.signed_distance(r), -plane.signed_distance(p))
    # midpoints on the glass
    np.testing.assert_allclose(plane.signed_distance((p + r) / 2), 0, atol=1e-12)


def test_reflection_matrix_agrees_with_eq3():
    plane = mirror_2m()
    M = plane.reflection_matrix()
    p = np.random.default_rng(1).normal(size=(20, 3))
    np.testing.assert_allclose((p @ M[:3, :3].T) + M[:3, 3], plane.reflect(p), atol=1e-12)
    np.testing.assert_allclose(M @ M, np.eye(4), atol=1e-12)
    assert np.linalg.det(M) == pytest.approx(-1)


def test_float32_stays_float32():
    assert mirror_2m().reflect(np.ones((3, 3), np.float32)).dtype == np.float32


def test_svd_fit_is_exact_on_exact_points():
    plane = mirror_2m()
    rng = np.random.default_rng(2)
    pts = plane.project(rng.uniform(-1, 1, (50, 3)) + [0, 0, 2])
    fitted = fit_plane_svd(pts)
    np.testing.assert_allclose(fitted.abcd, plane.abcd, atol=1e-12)


def test_ransac_ignores_outliers_and_is_reproducible():
    plane = mirror_2m()
    rng = np.random.default_rng(3)
    pts = plane.project(rng.uniform(-0.5, 0.5, (300, 3)) + [0, 0, 2]) + rng.normal(0, 0.001, (
        300, 3))
    pts[:90] += rng.uniform(0.05, 0.5, (90, 3))                    # 30 % gross outliers
    a = fit_plane_ransac(pts, 0.004, np.random.default_rng(7))
    b = fit_plane_ransac(pts, 0.004, np.random.default_rng(7))
    assert a.plane == b.plane
    assert a.plane.angle_to(plane) < 0.5
    assert abs(a.plane.d - plane.d) < 0.002
    assert not a.inliers[:90].any() or a.inliers[:90].mean() < 0.05
    assert a.inliers[90:].mean() > 0.95
    assert a.rms < 0.002


@pytest.mark.parametrize("pts, message", [
    ([[0, 0, 1], [1, 0, 1]], "at least 3 points"),
    ([[0, 0, 1], [1, 0, 1], [2, 0, 1], [3, 0, 1]], "collinear"),
])
def test_degenerate_points_are_refused_naming_the_mirror(pts, message):
    with pytest.raises(CalibrationError, match=message):
        fit_plane_svd(pts, "mirror 1")


def test_bad_planes_are_refused():
    with pytest.raises(CalibrationError, match="normal .* is zero"):
        Plane.from_abcd([0, 0, 0, 1])
    with pytest.raises(CalibrationError, match="passes through the camera"):
        Plane.from_abcd([0, 0, 1, 0])
    with pytest.raises(CalibrationError, match="camera behind the mirror"):
        Plane.from_abcd([0, 0, 1, -2], orient=False)


def test_ransac_iterations_rule():
    assert ransac_iterations(1.0, 3) == 1
    assert ransac_iterations(0.5, 3, 0.99) == 35          # log(0.01) / log(1 - 0.125) = 34.5
    assert ransac_iterations(0.0, 3) > 10**6
