"""Sphere and cylinder fitting (mirrorcore.geometry.fitting) and the paper's error measures
(mirrorcore.fit_errors)."""
from __future__ import annotations

import numpy as np
import pytest

from mirrorcore.base.errors import Cancelled, MirrorscanError
from mirrorcore.geometry.fitting import estimate_normals, fit_cylinder, fit_sphere
from mirrorcore.geometry.shapes import Cylinder, FitErrors, ShapeFit, Sphere, per_source_errors


# --------------------------------------------------------------------------------- synthetic scans
def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _viewpoints(center: np.ndarray, mirrors: int) -> np.ndarray:
    """The camera (origin) and `mirrors` virtual cameras, as the paper's rig: the camera's position
    turned about the vertical (y) line through the object by +-120 degrees (mirror j's view is the
    object seen from viewpoint j)."""
    angles = np.radians([0.0, 120.0, -120.0][: 1 + mirrors])
    c, s = np.cos(angles), np.sin(angles)
    rot = np.zeros((len(angles), 3, 3))
    rot[:, 0, 0], rot[:, 0, 2], rot[:, 1, 1], rot[:, 2, 0], rot[:, 2, 2] = c, s, 1.0, -s, c
    return center + rot @ (-center)


def _visible(surface: np.ndarray, normals: np.ndarray, viewpoints: np.ndarray,
             min_cos: float = 0.2) -> tuple[np.ndarray, np.ndarray]:
    """Points facing a viewpoint (cosine of the view angle > min_cos, as a depth camera returns),
    labelled by the first viewpoint that sees them (0 = camera, j = mirror j) -> points (m, 3),
    sources (m,) uint8."""
    rays = _unit(viewpoints[None] - surface[:, None])                 # (n, v, 3)
    facing = np.einsum("nvk,nk->nv", rays, normals) > min_cos
    seen = facing.any(axis=1)
    return surface[seen], np.argmax(facing[seen], axis=1).astype(np.uint8)


def _sphere_scan(rng: np.random.Generator, mirrors: int, n: int = 6000):
    """A sphere at ~1.5-2.5 m of radius 5-30 cm, seen by the camera and `mirrors` mirrors ->
    (Sphere, points, sources)."""
    center = np.array([rng.uniform(-0.4, 0.4), rng.uniform(-0.3, 0.3), rng.uniform(1.5, 2.5)])
    radius = rng.uniform(0.05, 0.3)
    directions = _unit(rng.normal(size=(n, 3)))
    points, sources = _visible(center + radius * directions, directions,
                               _viewpoints(center, mirrors))
    return Sphere(tuple(center), radius), points, sources


def _cylinder_scan(rng: np.random.Generator, mirrors: int, n: int = 6000):
    """A cylinder of radius 5-30 cm and length 6 radii, seen like _sphere_scan, its axis in any
    orientation more than 34 degrees away from the line of sight (closer to it, the camera would see
    the end rather than the side)."""
    axis_point = np.array([rng.uniform(-0.4, 0.4), rng.uniform(-0.3, 0.3), rng.uniform(1.5, 2.5)])
    sight = _unit(axis_point)
    across = _unit(np.cross(sight, rng.normal(size=3)))
    direction = _unit(across + rng.uniform(-1.5, 1.5) * sight)
    radius = rng.uniform(0.05, 0.3)
    u = _unit(np.cross(direction, rng.normal(size=3)))
    v = np.cross(direction, u)
    theta, height = rng.uniform(0, 2 * np.pi, n), rng.uniform(-3 * radius, 3 * radius, n)
    radial = np.cos(theta)[:, None] * u + np.sin(theta)[:, None] * v
    surface = axis_point + height[:, None] * direction + radius * radial
    points, sources = _visible(surface, radial, _viewpoints(axis_point, mirrors))
    return Cylinder(tuple(axis_point), tuple(direction), radius), points, sources


def _corrupt(rng: np.random.Generator, points: np.ndarray, sources: np.ndarray, sigma: float,
             outlier_ratio: float):
    """Gaussian noise (sigma metres, every axis) and uniform outliers in the cloud's box grown by 50
    % (outlier_ratio of the returned points, labelled direct)."""
    noisy = points + rng.normal(scale=sigma, size=points.shape)
    lo, hi = points.min(axis=0), points.max(axis=0)
    margin = 0.25 * (hi - lo)
    count = int(round(outlier_ratio / (1 - outlier_ratio) * len(points)))
    outliers = rng.uniform(lo - margin, hi + margin, size=(count, 3))
    return np.vstack([noisy, outliers]), np.concatenate([sources, np.zeros(count, np.uint8)])


def _assert_cylinder_close(got: Cylinder, want: Cylinder, tol: float) -> None:
    """Same axis line (direction up to sign, axis point on the true axis) and radius, all within tol
    metres (direction within tol / radius radians)."""
    d_got, d_want = np.array(got.axis_direction), np.array(want.axis_direction)
    assert np.linalg.norm(np.cross(d_got, d_want)) < tol / want.radius
    assert np.linalg.norm(d_got) == pytest.approx(1.0, abs=1e-12)
    assert abs(Cylinder(want.axis_point, want.axis_direction,
                        0.0).deviations(np.array(got.axis_point))[0]) < tol
    assert got.radius == pytest.approx(want.radius, abs=tol)


# ---------------------------------------------------------------------------------- error measures
def test_sphere_deviations_by_hand():
    sphere = Sphere((1.0, 2.0, 3.0), 0.5)
    points = np.array([[1.0, 2.0, 3.6], [1.0, 2.3, 3.0], [1.5, 2.0, 3.0], [1.0, 2.0, 3.0]])
    # distances 0.6 (outside), 0.3 (inside), 0.5 (on), 0 (the centre)
    np.testing.assert_allclose(sphere.deviations(points), [0.1, -0.2, 0.0, -0.5], atol=1e-12)


def test_cylinder_deviations_by_hand():
    # axis: the line through (1, 0, 0) along z; a shift along the axis changes nothing
    cylinder = Cylinder((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), 1.0)
    points = np.array([[3.0, 0.0, 5.0], [1.0, 0.5, -7.0], [1.6, 0.8, 0.0], [1.0, 0.0, 2.0]])
    np.testing.assert_allclose(cylinder.deviations(points), [1.0, -0.5, 0.0, -1.0], atol=1e-12)


def test_error_figures_by_hand():
    # deviations 0.1, -0.2, 0, 0.3: mean 0.05, RMSE sqrt(0.14 / 4), mean |dev| 0.15
    errors = FitErrors.from_deviations(np.array([0.1, -0.2, 0.0, 0.3]))
    assert errors.points == 4
    assert errors.rmse == pytest.approx(np.sqrt(0.035))
    assert errors.mean_error == pytest.approx(0.05)
    assert errors.mean_abs_error == pytest.approx(0.15)
    assert errors.to_json() == pytest.approx({"points": 4, "rmse_mm": 1e3 * np.sqrt(0.035),
                                              "mean_error_mm": 50.0,
                                              "mean_abs_error_mm": 150.0})


def test_error_figures_of_no_points_are_null():
    assert FitErrors.from_deviations(np.array([])).to_json() == {
        "points": 0, "rmse_mm": None, "mean_error_mm": None, "mean_abs_error_mm": None}


def test_per_source_errors_by_hand():
    per_source = per_source_errors(np.array([0.1, -0.2, 0.0, 0.3, -0.1]), np.array([0, 1, 1, 3, 0]))
    # no mirror 2 points: no entry
    assert list(per_source) == [0, 1, 3]
    assert per_source[0] == FitErrors(2, pytest.approx(0.1), pytest.approx(0.0), pytest.approx(0.1))
    assert per_source[1] == FitErrors(2, pytest.approx(np.sqrt(0.02)), pytest.approx(-0.1),
                                      pytest.approx(0.1))
    assert per_source[3] == FitErrors(1, pytest.approx(0.3), pytest.approx(0.3), pytest.approx(0.3))
    with pytest.raises(ValueError, match="5 deviations but 4 source labels"):
        per_source_errors(np.zeros(5), np.zeros(4))


def test_shape_fit_json_over_all_points_inliers_and_sources():
    sphere = Sphere((0.0, 0.0, 2.0), 0.1)
    deviations = np.array([0.001, -0.003, 0.05, 0.002])
    fit = ShapeFit(sphere, np.abs(deviations) < 0.01, deviations, np.array([0, 0, 1, 2], np.uint8),
                   0.01)
    out = fit.to_json()
    assert out["shape"] == "sphere" and out["center"] == [0.0, 0.0, 2.0]
    assert out["radius_mm"] == pytest.approx(100.0)
    assert out["points"] == 4 and out["inliers"] == 3 and out["threshold_mm"] == pytest.approx(10.0)
    # the outlier counts
    assert out["rmse_mm"] == pytest.approx(1e3 * np.sqrt(np.mean(deviations ** 2)))
    assert out["mean_error_mm"] == pytest.approx(12.5)
    assert out["mean_abs_error_mm"] == pytest.approx(14.0)
    assert out["inlier_errors"]["mean_error_mm"] == pytest.approx(0.0)
    assert list(out["per_source"]) == ["direct", "mirror 1", "mirror 2"]
    assert out["per_source"]["direct"]["rmse_mm"] == pytest.approx(np.sqrt(5.0))
    assert out["per_source"]["mirror 1"]["mean_error_mm"] == pytest.approx(50.0)


# ------------------------------------------------------------------------------------ exact shapes
@pytest.mark.parametrize("mirrors", [0, 2])
@pytest.mark.parametrize("seed", range(4))
def test_sphere_exact_partial_views_recovered(seed, mirrors):
    truth, points, sources = _sphere_scan(np.random.default_rng(seed), mirrors)
    fit = fit_sphere(points, np.random.default_rng(seed), sources=sources)
    tol = 1e-6 * truth.radius
    np.testing.assert_allclose(fit.shape.centre, truth.centre, rtol=0, atol=tol)
    assert fit.shape.radius == pytest.approx(truth.radius, rel=1e-6)
    assert fit.inliers.all() and fit.errors.rmse < tol
    assert sorted(fit.per_source) == list(range(1 + mirrors))


@pytest.mark.parametrize("mirrors", [0, 2])
@pytest.mark.parametrize("seed", range(4))
def test_cylinder_exact_partial_views_any_orientation_recovered(seed, mirrors):
    truth, points, sources = _cylinder_scan(np.random.default_rng(seed), mirrors)
    fit = fit_cylinder(points, np.random.default_rng(seed), sources=sources)
    _assert_cylinder_close(fit.shape, truth, 1e-6 * truth.radius)
    assert fit.inliers.all() and fit.errors.rmse < 1e-6 * truth.radius
    # the canonical axis point is the foot of the points' centroid on the axis
    offset = points.mean(axis=0) - np.array(fit.shape.axis_point)
    along = offset @ np.array(fit.shape.axis_direction)
    assert abs(along) < 1e-9
    assert max(fit.shape.axis_direction, key=abs) > 0


# ------------------------------------------------------------------------------ noise and outliers
# Gaussian noise sigma = 2 mm on every axis and 20 % uniform outliers, threshold 3 sigma = 6 mm.
# Measured over 30 other seeds: radius error std 0.15 mm (sphere, camera only), 0.27 mm (cylinder,
# camera only), 0.04 mm (three views); worst 0.9 mm; centre error < 0.5 mm, axis direction error <
# 1e-3 rad. TOL = 2 mm is 7 std of the worst case and still catches any bias as large as sigma.
# Inlier RMSE measured 1.93-2.10 mm (the 3-sigma truncation keeps ~ sigma); over all points the
# outliers dominate it. The inliers' mean error is 0 at a least-squares optimum (d cost / dR = 0),
# so it checks that the refinement converged.
SIGMA, OUTLIERS, THRESHOLD, TOL = 0.002, 0.2, 0.006, 0.002


@pytest.mark.parametrize("kind", ["sphere", "cylinder"])
@pytest.mark.parametrize("mirrors", [0, 2])
@pytest.mark.parametrize("seed", range(3))
def test_shapes_with_noise_and_outliers(kind, seed, mirrors):
    rng = np.random.default_rng((100 if kind == "sphere" else 200) + seed)
    scan, fitter = (_sphere_scan, fit_sphere) if kind == "sphere" else (_cylinder_scan,
                                                                        fit_cylinder)
    truth, points, sources = scan(rng, mirrors, n=4000)
    points, sources = _corrupt(rng, points, sources, SIGMA, OUTLIERS)
    fit = fitter(points, np.random.default_rng(seed), threshold=THRESHOLD, sources=sources)
    if kind == "sphere":
        assert np.linalg.norm(np.array(fit.shape.centre) - truth.centre) < 2 * TOL
        assert fit.shape.radius == pytest.approx(truth.radius, abs=TOL)
    else:
        _assert_cylinder_close(fit.shape, truth, TOL)
    assert 0.7 * SIGMA < fit.inlier_errors.rmse < 1.1 * SIGMA
    # all points: the outliers count
    assert fit.errors.rmse > 3 * fit.inlier_errors.rmse
    assert abs(fit.inlier_errors.mean_error) < 1e-9


# ------------------------------------------------------------------------------- signs and sources
@pytest.mark.parametrize("kind", ["sphere", "cylinder"])
def test_per_source_errors_and_their_sign(kind):
    """Mirror 1's points pushed 3 mm outwards, mirror 2's 3 mm inwards (mis-calibrated mirrors),
    each mirror with a third of the direct view's points: with a 0.5 mm threshold the shape is the
    direct view's, and the per-source mean errors say which way each mirror is off. (The cylinder
    gets its exact normals: normals estimated across the 3 mm steps between views give 2-point
    samples too rough for a 0.5 mm threshold.)"""
    scan = _sphere_scan if kind == "sphere" else _cylinder_scan
    truth, points, sources = scan(np.random.default_rng(7), mirrors=2, n=12000)
    keep = (sources == 0) | (np.arange(len(sources)) % 3 == 0)
    points, sources = points[keep], sources[keep]
    shift = np.where(sources == 1, 0.003, np.where(sources == 2, -0.003, 0.0))
    normals = _outward_normals(truth, points)
    points = points + shift[:, None] * normals
    rng = np.random.default_rng(0)
    fit = (fit_sphere(points, rng, threshold=0.0005, sources=sources) if kind == "sphere" else
           fit_cylinder(points, rng, threshold=0.0005, sources=sources, normals=normals))
    assert fit.shape.radius == pytest.approx(truth.radius, rel=1e-6)
    assert np.array_equal(fit.inliers, sources == 0)
    direct, mirror1, mirror2 = (fit.per_source[s] for s in (0, 1, 2))
    assert direct.rmse < 1e-9 and direct.points == np.count_nonzero(sources == 0)
    assert mirror1.mean_error == pytest.approx(0.003) and mirror1.rmse == pytest.approx(0.003)
    assert mirror2.mean_error == pytest.approx(-0.003)
    assert mirror2.mean_abs_error == pytest.approx(0.003)
    n1, n2 = mirror1.points, mirror2.points
    assert fit.errors.mean_error == pytest.approx(0.003 * (n1 - n2) / len(points))
    assert fit.errors.rmse == pytest.approx(0.003 * np.sqrt((n1 + n2) / len(points)))
    assert fit.to_json()["per_source"]["mirror 2"]["mean_error_mm"] == pytest.approx(-3.0)


def _outward_normals(shape: Sphere | Cylinder, points: np.ndarray) -> np.ndarray:
    """(n, 3) unit outward surface normals of points on the shape."""
    if isinstance(shape, Sphere):
        return _unit(points - np.array(shape.centre))
    q = points - np.array(shape.axis_point)
    d = np.array(shape.axis_direction)
    return _unit(q - np.outer(q @ d, d))


def test_same_seed_same_fit_and_seeds_agree():
    rng = np.random.default_rng(3)
    _, points, sources = _cylinder_scan(rng, mirrors=1, n=3000)
    points, sources = _corrupt(rng, points, sources, SIGMA, OUTLIERS)
    fits = [fit_cylinder(points, np.random.default_rng(seed), threshold=THRESHOLD)
            for seed in (5, 5, 6)]
    assert fits[0].shape == fits[1].shape and np.array_equal(fits[0].deviations, fits[1].deviations)
    assert fits[2].shape.radius == pytest.approx(fits[0].shape.radius, abs=1e-4)


def test_given_normals_are_used():
    truth, points, sources = _cylinder_scan(np.random.default_rng(11), mirrors=0)
    good = _outward_normals(truth, points) * np.random.default_rng(0).choice([-1.0, 2.0],
                                                                             size=(len(points), 1))
    fit = fit_cylinder(points, np.random.default_rng(0), normals=good)
    _assert_cylinder_close(fit.shape, truth, 1e-6 * truth.radius)
    # all normals parallel: every sample degenerate
    with pytest.raises(MirrorscanError, match="no cylinder found"):
        fit_cylinder(points, np.random.default_rng(0),
                     normals=np.tile([0.0, 0.0, 1.0], (len(points), 1)))
    with pytest.raises(MirrorscanError, match=rf"{len(points)} points but normals of shape \(3,\)"):
        fit_cylinder(points, np.random.default_rng(0), normals=np.ones(3))


def test_estimate_normals_of_a_plane():
    xy = np.random.default_rng(0).uniform(-1, 1, size=(500, 2))
    normals = estimate_normals(np.column_stack([xy, np.full(500, 2.0)]))
    assert normals.shape == (500, 3)
    np.testing.assert_allclose(np.abs(normals[:, 2]), 1.0, atol=1e-9)


@pytest.mark.parametrize("fit_shape, scan",
                         [(fit_sphere, _sphere_scan), (fit_cylinder, _cylinder_scan)])
def test_progress_follows_the_samples_and_cancel_stops_the_fit(fit_shape, scan):
    """The fraction rises to 1 by the samples RANSAC will draw (batches of them, with 90 %
    outliers); the same fit is the one without progress; a cancel request stops it at the next
    batch, naming where."""
    rng = np.random.default_rng(4)
    _, points, sources = scan(rng, mirrors=1, n=1500)
    cloud = _corrupt(rng, points, sources, SIGMA, 0.9)[0]
    fractions: list[float] = []
    fit = fit_shape(cloud, np.random.default_rng(0), threshold=THRESHOLD, progress=fractions.append)
    assert len(fractions) > 5 and fractions[-1] == 1.0 and all(0 < f <= 1 for f in fractions)
    assert np.all(np.diff(fractions) > 0)
    assert fit.shape == fit_shape(cloud, np.random.default_rng(0), threshold=THRESHOLD).shape
    calls: list[float] = []

    def cancel_after_three() -> bool:
        calls.append(0.0)
        return len(calls) > 3
    with pytest.raises(Cancelled, match=r"^scan\.ply: the fit was cancelled$"):
        fit_shape(cloud, np.random.default_rng(0), threshold=THRESHOLD, where="scan.ply",
                  cancel=cancel_after_three)
    assert len(calls) == 4


# --------------------------------------------------------------------------------------- bad input
def test_too_few_points_are_refused_naming_the_file():
    with pytest.raises(MirrorscanError,
                       match=r"^scan\.ply: a sphere fit needs at least 4 points, got 3$"):
        fit_sphere(np.eye(3), np.random.default_rng(0), where="scan.ply")
    with pytest.raises(MirrorscanError,
                       match=r"^cloud: a cylinder fit needs at least 5 points, got 0$"):
        fit_cylinder(np.empty((0, 3)), np.random.default_rng(0))


def test_non_finite_points_threshold_and_labels():
    points = _sphere_scan(np.random.default_rng(0), 0)[1]
    bad = points.copy()
    bad[3, 1] = np.nan
    with pytest.raises(MirrorscanError, match="^x.ply: the cloud has non-finite coordinates$"):
        fit_sphere(bad, np.random.default_rng(0), where="x.ply")
    with pytest.raises(MirrorscanError, match="threshold must be positive"):
        fit_sphere(points, np.random.default_rng(0), threshold=0.0)
    with pytest.raises(MirrorscanError, match=f"{len(points)} points but 2 source labels"):
        fit_sphere(points, np.random.default_rng(0), sources=np.zeros(2))


def test_plane_is_no_sphere_or_cylinder():
    rng = np.random.default_rng(0)
    plane = np.column_stack([rng.uniform(-0.5, 0.5, size=(2000, 2)), np.full(2000, 2.0)])
    for fit_shape, kind in ((fit_sphere, "sphere"), (fit_cylinder, "cylinder")):
        with pytest.raises(MirrorscanError, match=f"^p.ply: no {kind} found"):
            fit_shape(plane, np.random.default_rng(0), where="p.ply")


def test_radius_range_rejects_models():
    truth, points, _ = _sphere_scan(np.random.default_rng(1), 0)
    with pytest.raises(MirrorscanError, match="no sphere found"):
        fit_sphere(points, np.random.default_rng(0),
                   radius_range=(2 * truth.radius, 3 * truth.radius))
    fit = fit_sphere(points, np.random.default_rng(0),
                     radius_range=(0.9 * truth.radius, 1.1 * truth.radius))
    assert fit.shape.radius == pytest.approx(truth.radius, rel=1e-6)
