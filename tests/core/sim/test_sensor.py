"""Kinect v1 sensor model: total axial std k Z^2 at 1, 2 and 3 m, the Gaussian table, exact
noiseless mode, visible quantisation steps, seeds, range, IR shadow (and its window against a
running minimum over whole rows)."""
import numpy as np
import pytest

from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.sim.sensor import SensorModel, ir_shadow, standard_normal

CAMERA = Intrinsics.kinect_v1()


def _wall(z: float) -> np.ndarray:
    return np.full(CAMERA.shape, z, dtype=np.float32)


@pytest.mark.parametrize("z", [1.0, 2.0, 3.0])
def test_axial_std_matches_khoshelham(z):
    # many depths around z so the quantisation offset is averaged as on a real wall
    depth = _wall(z) + np.linspace(-0.02, 0.02, CAMERA.width, dtype=np.float32)[None, :] * z
    out = SensorModel(lateral_sigma=0.0, shadow=False).apply(CAMERA, depth, np.random.default_rng(
        1))
    err = (out - depth)[out > 0] / depth[out > 0] ** 2          # normalised to Z^2
    assert np.std(err) == pytest.approx(1.425e-3, rel=0.10)
    assert abs(np.mean(err)) < 1e-4


@pytest.mark.parametrize("z", [1.0, 2.0, 3.0])
def test_axial_std_on_a_flat_wall_facing_the_camera(z):
    out = SensorModel(lateral_sigma=0.0, shadow=False).apply(CAMERA, _wall(
        z), np.random.default_rng(2))
    assert np.std(out[out > 0]) == pytest.approx(1.425e-3 * z * z, rel=0.10)


def test_standard_normal_table_has_gaussian_moments_and_tails():
    x = standard_normal(np.random.default_rng(3), (1000, 1000))
    assert x.dtype == np.float32 and x.shape == (1000, 1000)
    assert abs(x.mean()) < 0.005 and x.std() == pytest.approx(1.0, abs=0.005)
    # two-sided tail of N(0, 1)
    assert np.mean(np.abs(x) > 2) == pytest.approx(0.0455, abs=0.001)
    assert np.abs(x).max() < 4.4


def test_noiseless_mode_is_exact():
    depth = np.random.default_rng(0).uniform(0.3, 6.0, CAMERA.shape).astype(np.float32)
    out = SensorModel.ideal().apply(CAMERA, depth, np.random.default_rng(0))
    np.testing.assert_array_equal(out, depth)


def test_noiseless_kinect_shows_the_disparity_steps():
    depth = np.linspace(1.9, 2.1, CAMERA.width * CAMERA.height,
                        dtype=np.float32).reshape(CAMERA.shape)
    out = SensorModel.kinect_v1(noise=False).apply(CAMERA, depth, np.random.default_rng(0))
    fb = CAMERA.fx * 0.075
    steps = fb / np.unique(out[out > 0]) * 8                      # disparity in 1/8 pixels
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-3)
    assert 10 < len(steps) < 40                                   # about 12 mm apart at 2 m
    assert np.abs(out - depth)[out > 0].max() <= 0.5 * 2.1 ** 2 / (8 * fb) + 1e-4


def test_same_seed_same_frame_and_range():
    depth = _wall(2.0)
    depth[:, :10] = 0.3
    depth[:, -10:] = 6.0
    model = SensorModel.kinect_v1()
    a = model.apply(CAMERA, depth, np.random.default_rng(5))
    np.testing.assert_array_equal(a, model.apply(CAMERA, depth, np.random.default_rng(5)))
    assert not np.array_equal(a, model.apply(CAMERA, depth, np.random.default_rng(6)))
    assert np.all(a[:, :9] == 0) and np.all(a[:, -9:] == 0)


def test_ir_shadow_is_beside_the_near_edge_away_from_the_projector():
    """A near box (1 m) before a wall (3 m): with the projector at +x the shadow is a band left of
    the box, as wide as the disparity difference f b (1/1 - 1/3)."""
    depth = _wall(3.0)
    depth[200:280, 300:400] = 1.0
    fb = CAMERA.fx * 0.075
    shadow = ir_shadow(depth, fb)
    width = fb * (1 / 1.0 - 1 / 3.0)
    row = shadow[240]
    cols = np.flatnonzero(row)
    assert cols.max() == 299 and abs(len(cols) - width) <= 1.5
    assert not shadow[100].any() and not shadow[240, 300:].any()


def test_ir_shadow_equals_a_running_minimum_over_whole_rows():
    """The window of the largest disparity loses nothing: near objects at 0.5 m (90 px of
    disparity), gaps of no reading, random depths."""
    rng = np.random.default_rng(4)
    depth = rng.uniform(0.5, 5.0, CAMERA.shape).astype(np.float32)
    depth[rng.random(CAMERA.shape) < 0.2] = 0
    fb = CAMERA.fx * 0.075
    with np.errstate(divide="ignore"):
        xp = np.where(depth > 0, np.arange(CAMERA.width) - fb / depth, np.inf)
    right_min = np.minimum.accumulate(xp[:, ::-1], axis=1)[:, ::-1]
    beyond = np.concatenate([right_min[:, 1:], np.full((CAMERA.height, 1), np.inf)], axis=1)
    for tolerance in (0.0, 0.1, 3.0):
        np.testing.assert_array_equal(ir_shadow(depth, fb, tolerance),
                                      (depth > 0) & (beyond < xp - tolerance))
    assert not ir_shadow(np.zeros(CAMERA.shape, np.float32), fb).any()
