"""Property-based tests of the geometry (hypothesis): reflection is an involution and an isometry,
projection inverts reprojection, planes fitted under noise stay close to the truth, and any numbers
given as a plane or a polygon end in a plane, a polygon or our own one-line error."""
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics, project_points, reproject_pixels
from mirrorcore.geometry.plane import Plane, fit_plane_ransac, fit_plane_svd
from mirrorcore.geometry.polygon import validate_polygon

EXAMPLES = settings(max_examples=150, deadline=None)
unit = st.floats(-1, 1, allow_nan=False)
normals = st.tuples(unit, unit, unit).filter(lambda n: np.linalg.norm(n) > 0.1)
distances = st.floats(0.05, 10.0)
points = arrays(np.float64, st.tuples(st.integers(1, 50), st.just(3)), elements=st.floats(-20, 20))
any_float = st.floats(allow_nan=True, allow_infinity=True, width=64)


@EXAMPLES
@given(normals, distances, points)
def test_reflection_is_an_involution_and_an_isometry(normal, d, p):
    plane = Plane.from_abcd([*normal, d])
    once = plane.reflect(p)
    np.testing.assert_allclose(plane.reflect(once), p, atol=1e-9 * (1 + np.abs(p).max()))
    np.testing.assert_allclose(plane.signed_distance(once), -plane.signed_distance(p),
                               atol=1e-9 * (1 + d + np.abs(p).max()))
    pairwise = np.linalg.norm(p[:, None] - p[None], axis=-1)
    np.testing.assert_allclose(np.linalg.norm(once[:, None] - once[None], axis=-1), pairwise,
                               atol=1e-8 * (1 + pairwise.max()))
    M = plane.reflection_matrix()
    np.testing.assert_allclose((M[:3, :3] @ p.T).T + M[:3, 3], once,
                               atol=1e-9 * (1 + np.abs(p).max()))
    assert np.linalg.det(M[:3, :3]) == np.float64(-1.0) or abs(np.linalg.det(M[:3, :3]) + 1) < 1e-12


@st.composite
def cameras(draw) -> Intrinsics:
    w, h = draw(st.integers(8, 2000)), draw(st.integers(8, 2000))
    return Intrinsics(w, h, draw(st.floats(50, 3000)), draw(st.floats(50, 3000)),
                      draw(st.floats(0, w - 1)),
                      draw(st.floats(0, h - 1)))


@EXAMPLES
@given(cameras(), st.data())
def test_projection_inverts_reprojection(camera, data):
    n = data.draw(st.integers(1, 30))
    u = data.draw(arrays(np.float64, n, elements=st.floats(-0.5, camera.width - 0.5)))
    v = data.draw(arrays(np.float64, n, elements=st.floats(-0.5, camera.height - 0.5)))
    z = data.draw(arrays(np.float64, n, elements=st.floats(0.1, 10.0)))
    uv, depth = project_points(camera, reproject_pixels(camera, u, v, z))
    np.testing.assert_allclose(depth, z, rtol=1e-6)
    np.testing.assert_allclose(uv, np.stack([u, v], -1),
                               atol=2e-3 * (1 + max(camera.width, camera.height) / 500))


@EXAMPLES
@given(cameras(), arrays(np.float64, (5, 3), elements=st.floats(-5, 5)))
def test_points_behind_the_camera_never_project(camera, p):
    p[:, 2] = -np.abs(p[:, 2])
    uv, _ = project_points(camera, p)
    assert np.isnan(uv).all()


@EXAMPLES
@given(normals, distances, st.integers(0, 2**32 - 1), st.floats(0, 0.002))
def test_plane_fits_under_noise_stay_close(normal, d, seed, sigma):
    """A 1 m x 1 m patch of 200 points with Gaussian noise sigma along the normal (and 10 % outliers
    for RANSAC)."""
    rng = np.random.default_rng(seed)
    plane = Plane.from_abcd([*normal, d])
    e1 = np.cross(plane.n, [1.0, 0, 0] if abs(plane.n[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(plane.n, e1)
    st_ = rng.uniform(-0.5, 0.5, (200, 2))
    p = -plane.d * plane.n + st_ @ np.stack([e1, e2]) + rng.normal(0, sigma, (200, 1)) * plane.n
    fitted = fit_plane_svd(p)
    bound_deg = np.degrees(20 * sigma) + 1e-6       # ~ sigma / (patch size / 2) with a wide margin
    assert fitted.angle_to(plane) < bound_deg and abs(fitted.d - plane.d) < 10 * sigma + 1e-9 * d
    p[:20] += rng.uniform(-0.3, 0.3, (20, 3))
    robust = fit_plane_ransac(p, 3 * sigma + 1e-4, rng)
    assert robust.plane.angle_to(plane) < bound_deg + 0.5


@EXAMPLES
@given(st.lists(any_float, min_size=0, max_size=6))
def test_any_numbers_as_a_plane_are_a_plane_or_our_error(values):
    try:
        plane = Plane.from_abcd(values)
    except MirrorscanError as exc:
        assert "plane" in str(exc) and "\n" not in str(exc)
        return
    assert abs(np.linalg.norm(plane.n) - 1) < 1e-9 and plane.d > 0


@EXAMPLES
@given(st.lists(st.tuples(any_float, any_float), max_size=8),
       st.tuples(st.integers(1, 600), st.integers(1, 600)))
def test_any_points_as_a_polygon_are_a_polygon_or_our_error(vertices, shape):
    try:
        poly = validate_polygon(vertices, shape)
    except MirrorscanError as exc:
        assert "\n" not in str(exc)
        return
    assert poly.shape == (len(vertices), 2) and len(vertices) >= 3 and np.isfinite(poly).all()
