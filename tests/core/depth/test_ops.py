"""depthops: the curvature-following smoothing of the views through several mirrors
(local_quadratic_depth), and the robust mean of several frames."""
import cv2
import numpy as np
import pytest
from tests.helpers import plane_depth, sphere_depth

from mirrorcore.depth import ops as depthops
from mirrorcore.depth.ops import (local_quadratic_depth, robust_mean_depth, smooth_depth,
                                  without_occluders)
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.depth.noise import axial_sigma
from mirrorcore.sim.sensor import SensorModel

CAMERA = Intrinsics.primesense()


def fit_all(depth: np.ndarray, labels: np.ndarray | None = None) -> np.ndarray:
    """Every pixel with a reading fitted, its own reading as the reference; one label unless
    given."""
    labels = (depth > 0).astype(np.int32) if labels is None else labels
    return local_quadratic_depth(depth, depth, np.flatnonzero(depth > 0), labels)


def inner(mask: np.ndarray, pixels: float) -> np.ndarray:
    """The pixels of mask farther than `pixels` from its edge."""
    return cv2.distanceTransform(mask.astype(np.uint8), cv2.DIST_L2, 3) > pixels


def test_a_plane_is_fitted_exactly_up_to_the_image_border():
    """A plane's disparity is linear in the pixel coordinates: the fit reproduces it, also where the
    window is cut by the image's border, which a one-sided average would not."""
    depth = plane_depth(CAMERA, Plane.from_point_normal([0.2, -0.1, 2.5], [0.3, -0.2, -1.0]))
    assert (depth > 0).all()
    np.testing.assert_allclose(fit_all(depth), depth, atol=2e-5)


def test_a_sphere_is_fitted_where_an_average_sags():
    """The paper's sphere (r = 115 mm) at 2.75 m, as a view through two mirrors sees it: the fit is
    within 0.4 mm of it 3 pixels inside its silhouette (0.01 mm on average), where an average over
    the same 9 x 9 pixels lies 1.3 mm inside it."""
    depth = sphere_depth(CAMERA, [0.0, 0.0, 2.865], 0.115)
    interior = inner(depth > 0, 3)
    fitted, averaged = fit_all(depth), smooth_depth(depth, depth > 0, radius=4)
    assert np.abs(fitted - depth)[interior].max() < 4e-4
    assert abs(np.mean((fitted - depth)[interior])) < 1e-5
    assert np.mean((averaged - depth)[interior]) > 1e-3


def test_noise_is_reduced_more_than_by_the_average_without_bias():
    """Kinect v1 noise (uncorrelated here) on the sphere: the fit over 9 x 9 pixels, with the 5 x 5
    average as its reference, leaves less noise than that average does."""
    rng = np.random.default_rng(5)
    truth = sphere_depth(CAMERA, [0.1, 0.0, 2.865], 0.115)
    depth = np.where(truth > 0, truth + rng.normal(size=truth.shape) * axial_sigma(truth),
                     0).astype(np.float32)
    interior, mask = inner(truth > 0, 3), truth > 0
    reference = smooth_depth(depth, mask)            # as the pipeline gives it
    error = (local_quadratic_depth(depth, reference, np.flatnonzero(mask),
                                   mask.astype(np.int32)) - truth)[interior]
    rms = {name: np.sqrt(np.mean(e[interior] ** 2)) for name,
           e in (("raw", depth - truth), ("average", reference - truth))}
    # 0.24 and 0.74 times
    assert np.sqrt(np.mean(error ** 2)) < min(0.3 * rms["raw"], 0.8 * rms["average"])
    # 0.17 mm
    assert abs(np.mean(error)) < 5e-4


def test_other_labels_do_not_count_however_close_their_depth():
    """Two views side by side 5 mm apart in depth (well within the range kernel): each stays on its
    own plane."""
    depth = np.full(CAMERA.shape, 2.0, np.float32)
    depth[:, 320:] = 2.005
    labels = np.where(np.arange(CAMERA.width) < 320, 33, 34)[None, :].repeat(CAMERA.height, 0)
    np.testing.assert_allclose(fit_all(depth, labels), depth, atol=1e-6)
    mixed = fit_all(depth, np.ones(CAMERA.shape, np.int32))
    # one label: the two planes blur into each other
    assert np.abs(mixed - depth)[:, 316:324].max() > 1e-3


def test_only_the_chosen_pixels_change_and_a_lone_pixel_keeps_its_reference():
    depth = np.full(CAMERA.shape, 2.0, np.float32)
    # alone on its surface: beyond the range kernel of its neighbours
    depth[100, 100] = 2.5
    reference = depth + 0.001
    chosen = np.ravel_multi_index(([100, 200], [100, 200]), CAMERA.shape)
    out = local_quadratic_depth(depth, reference, chosen, np.zeros(CAMERA.shape, np.int32))
    assert out[100, 100] == reference[100, 100]
    assert out[200, 200] == pytest.approx(2.0, abs=1e-6)
    unchosen = np.ones(CAMERA.shape, bool)
    unchosen[200, 200] = False
    np.testing.assert_array_equal(out[unchosen], reference[unchosen])


def test_pixels_are_fitted_in_chunks_with_the_same_result(monkeypatch):
    rng = np.random.default_rng(2)
    truth = sphere_depth(CAMERA, [0.0, 0.0, 2.0], 0.3)
    depth = np.where(truth > 0, truth + rng.normal(size=truth.shape) * axial_sigma(truth),
                     0).astype(np.float32)
    whole = fit_all(depth)
    monkeypatch.setattr(depthops, "QUADRATIC_CHUNK", 1000)
    # the matrix products block differently
    np.testing.assert_allclose(fit_all(depth), whole, atol=1e-6)


def test_the_robust_mean_of_frames_averages_the_disparity_steps_and_leaves_out_what_passed():
    """A wall at 2 m (disparity steps of 11 mm there) read 30 times with the Kinect's noise: the
    per-pixel median snaps to a step, the robust mean does not; a person in front in 3 frames of 30
    counts for neither."""
    sensor, rng = SensorModel.kinect_v1(), np.random.default_rng(0)
    camera = Intrinsics.kinect_v1()
    truth = np.full(camera.shape, 2.004, np.float32)
    stack = np.stack([sensor.apply(camera, truth, rng) for _ in range(30)])
    stack[:3, :100, :100] = 1.2                                   # someone passed in front
    median = np.median(stack, axis=0)
    mean = robust_mean_depth(stack)
    assert abs(np.mean(mean[100:, 100:]) - 2.004) < 0.3e-3 < abs(np.mean(median[
        100:, 100:]) - 2.004)
    assert abs(np.mean(mean[:100, :100]) - 2.004) < 0.5e-3


def test_what_passes_in_front_of_the_background_in_most_frames_is_left_out():
    """A person in front of a wall in 8 frames of 10: the median reads the person; without the
    readings in front of the background (one noisy frame of the wall), the robust mean reads the
    wall. Readings behind the background (a mirror's glass beside a marker) and pixels the
    background has no reading of keep theirs."""
    sensor, rng = SensorModel.kinect_v1(), np.random.default_rng(1)
    camera = Intrinsics.kinect_v1()
    truth = np.full(camera.shape, 3.5, np.float32)
    stack = np.stack([sensor.apply(camera, truth, rng) for _ in range(10)])
    background = sensor.apply(camera, truth, rng)
    stack[:8, :100, :100] = 3.0                                   # the person, 0.5 m in front
    stack[:, 100:110, :10] = 4.5                                  # behind the background: kept
    background[200:210, :10] = 0                                  # no background reading: kept
    stack[:8, 200:210, :10] = 3.0
    kept = without_occluders(stack, background)
    # (the sensor drops a few readings)
    seen = background[:100, :100] > 0
    assert seen.mean() > 0.95 and np.all(kept[:8, :100, :100][:, seen] == 0)
    assert np.all(kept[:, 100:110, :10] == 4.5)
    assert np.all(kept[:8, 200:210, :10] == 3.0)
    # the wall's noise is hardly ever taken for
    dropped = np.mean(kept[:, 300:, 300:] != stack[:, 300:, 300:])
    # one (4 disparity steps apart: 5e-5)
    assert dropped < 1e-4
    # the median: the person
    assert abs(np.median(np.stack([*stack, background])[:, :100, :100]) - 3.0) < 0.02
    assert abs(np.mean(robust_mean_depth(np.stack([*kept, background])[
        :, :100, :100])) - 3.5) < 0.01
