"""Temporal smoothing (mirrorcore.depth.temporal): static pixels are averaged over the neighbour
frames, moving ones keep the centre frame's reading (a limb crossing the pixel, a surface moving by
less than one reading's noise), holes are not filled, and the window is clipped at the ends of a
recording."""
import numpy as np
import pytest

from mirrorcore.depth.noise import KINECT_AXIAL_COEF
from mirrorcore.depth.temporal import frame_window, temporal_smooth

SHAPE = (60, 80)
# one reading's standard deviation in disparity (1/m), at every depth
SIGMA_W = KINECT_AXIAL_COEF


def noisy_frames(w_true: np.ndarray, k: int, seed: int = 0) -> np.ndarray:
    """k readings of the disparity images w_true (..., H, W) (1/m) with the camera's noise, as depth
    (metres): (k, ..., H, W) float32."""
    rng = np.random.default_rng(seed)
    return (1.0 / (w_true + rng.normal(0.0, SIGMA_W, (k, *w_true.shape)))).astype(np.float32)


def test_a_static_scene_is_averaged_over_the_window():
    w_true = np.full(SHAPE, 1 / 2.5)
    frames = noisy_frames(w_true, 5)
    out = temporal_smooth(frames, 2)
    before = np.std(1 / frames[2] - w_true)
    after = np.std(1 / out - w_true)
    assert after / before == pytest.approx(1 / np.sqrt(5), rel=0.1)    # the mean of 5 readings
    assert out.dtype == np.float32 and out.shape == SHAPE


def test_a_limb_crossing_the_pixels_is_not_smeared():
    """A bar 0.6 m in front of a wall moves 12 pixels a frame: where the centre frame sees the bar
    it keeps its reading (no wall mixed in), where it sees the wall it keeps the wall."""
    w_wall, w_bar = 1 / 3.0, 1 / 2.4
    truth = []
    for k in range(5):
        w = np.full(SHAPE, w_wall)
        w[:, 20 + 12 * k:30 + 12 * k] = w_bar
        truth.append(w)
    frames = noisy_frames(np.stack(truth), 1)[0]
    out = temporal_smooth(frames, 2)
    error = np.abs(1 / out - truth[2])
    # every pixel stays on its own surface: no more than a reading's noise (mixing in one other
    # frame: 2.3 sigma, averaging the 5: 11.7 sigma)
    assert error.max() < 5 * SIGMA_W
    # frames showing the centre frame's surface there
    same = np.sum(np.stack(truth) == truth[2], axis=0)
    alone = same == 1
    # the bar's pixels, wall in every other frame...
    assert alone.sum() == 10 * SHAPE[0]
    # ...keep the centre frame's reading
    np.testing.assert_array_equal(out[alone], frames[2][alone])
    far = same == 5
    # static wall away from the bar: averaged
    far[:, 12:] = False
    assert np.std(1 / out[far] - truth[2][far]) < 0.6 * SIGMA_W


def test_a_surface_moving_by_less_than_the_noise_is_seen_moving():
    """Each frame of a recording's end is 2 sigma nearer than the one before, everywhere: every
    single pixel difference is within the per-pixel tolerance, but the patch's mean is not, so the
    last frame stays as it is (averaging would pull it 4 sigma back)."""
    frames = np.stack([np.full(SHAPE, 1 / (0.4 + 2 * k * SIGMA_W))
                       for k in range(5)]).astype(np.float32)
    out = temporal_smooth(frames, 4)
    np.testing.assert_allclose(out, frames[4], rtol=1e-6)


def test_holes_stay_holes_and_missing_neighbours_are_ignored():
    frames = np.full((3, *SHAPE), 2.0, np.float32)
    frames[1, 5, 5] = 0                    # centre without a reading
    frames[0, 7, 7] = 0                    # a neighbour without one
    frames[2, 7, 7] = np.nan
    frames[1, 7, 7] = 2.001
    out = temporal_smooth(frames, 1)
    assert out[5, 5] == 0
    assert out[7, 7] == pytest.approx(2.001)


def test_the_window_is_clipped_at_the_ends():
    assert list(frame_window(0, 2, 10)) == [0, 1, 2]
    assert list(frame_window(5, 2, 10)) == [3, 4, 5, 6, 7]
    assert list(frame_window(9, 2, 10)) == [7, 8, 9]
    assert list(frame_window(0, 0, 1)) == [0]


@pytest.mark.parametrize("frames, centre", [(np.zeros((3, 4)), 0), (np.zeros((3, 4, 4)), 3)])
def test_bad_stacks_are_refused(frames, centre):
    with pytest.raises(ValueError, match="temporal_smooth"):
        temporal_smooth(frames, centre)
