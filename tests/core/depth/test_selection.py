"""Object selection: background subtraction with a depth-dependent tolerance, flying pixels, specks,
ROI, range."""
import numpy as np
from tests.helpers import sphere_depth

from mirrorcore.depth.ops import median_depth, smooth_depth
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.depth.noise import axial_sigma
from mirrorcore.depth.selection import Selection, flying_pixels, object_mask, remove_specks

CAMERA = Intrinsics.primesense()


def noisy(depth: np.ndarray, rng) -> np.ndarray:
    return np.where(depth > 0, depth + rng.normal(size=depth.shape) * axial_sigma(depth),
                    0).astype(np.float32)


def scene(rng, wall=4.0):
    sphere = sphere_depth(CAMERA, [0.0, 0.0, 2.0], 0.115)
    truth = sphere > 0
    background = np.full(CAMERA.shape, wall, np.float32)
    frame = np.where(truth, sphere, background)
    return noisy(background, rng), noisy(frame, rng), truth


def test_noisy_far_wall_does_not_leak():
    rng = np.random.default_rng(0)
    # sigma(4 m) = 23 mm: a fixed 5 cm tolerance leaks
    background, frame, truth = scene(rng, wall=4.0)
    mask = object_mask(CAMERA, frame, background, Selection(smooth=False))
    assert (mask & ~truth).sum() == 0
    assert (mask & truth).sum() > 0.97 * truth.sum()
    fixed = (frame > 0) & (frame < background - 0.05)          # what a fixed tolerance would do
    assert (fixed & ~truth).sum() > 100


def test_flying_pixels_and_specks_are_removed():
    rng = np.random.default_rng(1)
    background, frame, truth = scene(rng, wall=3.0)
    # left silhouette pixels of the sphere
    edge = truth & ~np.roll(truth, 1, axis=1)
    v, u = np.nonzero(edge)
    # mixed readings half-way to the wall
    frame[v, u - 1] = 2.5
    frame[10:12, 10:12] = 1.0                                   # a 4-pixel speck near the camera
    mask = object_mask(CAMERA, frame, background, Selection(min_blob=20))
    assert not mask[v, u - 1].any()
    assert not mask[10:12, 10:12].any()
    assert (mask & truth).sum() > 0.97 * truth.sum()


def test_specks_are_dropped_by_size_however_many_pieces():
    """Pieces of 1-4 pixels on a grid (few, then more than 255: the 8-bit lookup and the general
    path) and pieces of exactly min_blob - 1 and min_blob pixels: only the last and the large blob
    stay."""
    for step in (40, 12):                                       # 143 and 1,400 specks
        mask = np.zeros((480, 640), bool)
        mask[step // 2::step, step // 2::step] = True
        mask[1::step, 1::step] = mask[1::step, 2::step] = True
        mask[90:340, 90:270] = False                             # room for the pieces below
        mask[100:110, 200:260] = True                            # a blob
        mask[300, 100:119] = True                                # 19 pixels
        mask[320, 100:120] = True                                # 20 pixels
        kept = remove_specks(mask, 20)
        expected = np.zeros_like(mask)
        expected[100:110, 200:260] = expected[320, 100:120] = True
        assert remove_specks(mask, 1).sum() == mask.sum()
        assert np.array_equal(kept, expected), step


def test_flying_pixels_follow_their_definition():
    """A pixel is flying when it lies behind its nearest masked 8-neighbour by more than max(6
    sigma(z), 0.03 z)."""
    rng = np.random.default_rng(4)
    depth = rng.uniform(0.5, 5.0, (60, 80)).astype(np.float32)
    mask = rng.random((60, 80)) < 0.8
    sel = Selection()
    padded = np.pad(np.where(mask, depth, np.inf), 1, mode="edge")
    nearest = np.min([padded[1 + dv:61 + dv, 1 + du:81 + du] for dv in (-1, 0, 1)
                      for du in (-1, 0, 1)], axis=0)
    gap = np.maximum(sel.flying_sigmas * axial_sigma(depth), sel.flying_gap * depth)
    expected = mask & (depth - nearest > gap)
    assert 100 < expected.sum() < mask.sum()
    assert np.array_equal(flying_pixels(depth, mask, sel), expected)


def test_roi_and_depth_range():
    rng = np.random.default_rng(2)
    background, frame, truth = scene(rng)
    half = Selection(roi=((0, 0), (319, 0), (319, 479), (0, 479)))
    mask = object_mask(CAMERA, frame, background, half)
    assert mask[:, 320:].sum() == 0 and mask[:, :320].sum() > 0.45 * truth.sum()
    assert not object_mask(CAMERA, frame, None, Selection(depth_min=2.5, depth_max=3.0)).any()
    no_background = object_mask(CAMERA, frame, None, Selection(depth_max=2.5))
    assert (no_background & ~truth).sum() == 0 and (
        no_background & truth).sum() > 0.97 * truth.sum()


def test_a_selection_reads_its_json_and_refuses_bad_keys_by_name():
    import pytest

    from mirrorcore.base.errors import FileFormatError
    assert Selection.from_json({"depth_max": 5}).depth_max == 5
    assert Selection.from_json(Selection(roi=((0, 0), (5, 0), (0, 5))).to_json()).roi == ((0, 0), (
        5, 0), (0, 5))
    with pytest.raises(FileFormatError, match="unknown key\\(s\\) colour"):
        Selection.from_json({"colour": 1})
    with pytest.raises(FileFormatError, match="depth_min < depth_max"):
        Selection.from_json({"depth_min": 3, "depth_max": 2})
    with pytest.raises(FileFormatError, match="roi: the polygon crosses itself"):
        Selection.from_json({"roi": [[0, 0], [9, 9], [9, 0], [0, 9]]})


def test_median_ignores_missing_readings():
    frames = np.array([[[1.0, 0.0]], [[3.0, 0.0]], [[0.0, 2.0]]], np.float32)
    np.testing.assert_array_equal(median_depth(frames), [[2.0, 2.0]])


def test_smoothing_reduces_noise_and_keeps_edges():
    rng = np.random.default_rng(3)
    truth = np.full(CAMERA.shape, 2.0, np.float32)
    truth[:, 320:] = 3.0
    depth = noisy(truth, rng)
    mask = np.ones(CAMERA.shape, bool)
    smoothed = smooth_depth(depth, mask)
    left = np.s_[:, 10:300]
    assert np.std(smoothed[left] - 2.0) < 0.4 * np.std(depth[left] - 2.0)
    assert abs(np.mean(smoothed[left]) - 2.0) < 5e-4                     # no bias
    # no blur across the 1 m edge
    assert np.abs(smoothed[:, 318:322] - truth[:, 318:322]).max() < 0.05
    mask[:, :100] = False
    # unmasked pixels untouched
    assert (smooth_depth(depth, mask)[:, :100] == depth[:, :100]).all()
