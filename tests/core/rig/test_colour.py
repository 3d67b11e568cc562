"""Algorithm 1's colours: every point takes its pixel's colour with its view's colour gain undone
(a view through several mirrors undoes the product of their gains), so that the points seen through
a tinted mirror carry the surface's own colour."""
from dataclasses import replace

import numpy as np
import pytest

from mirrorcore.base.errors import FileFormatError
from mirrorcore.base.palette import sequence_label
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.rig.colour import correction_table, point_colours, rgb_words, view_gain
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.sim.albedo import object_albedo
from mirrorcore.sim.export import true_rig
from mirrorcore.sim.layouts import kaleidoscope_scene, paper_scene
from mirrorcore.sim.render import OBJECT
from mirrorcore.sim.simulator import Simulator

CAMERA = Intrinsics.kinect_v1().scaled(0.5)
GAINS = ((0.8, 0.9, 0.7), (0.6, 0.85, 0.95), (0.9, 0.5, 0.8))


def test_a_view_through_several_mirrors_multiplies_their_gains():
    two_then_one = sequence_label((2, 1))
    np.testing.assert_allclose(view_gain(GAINS, 0), 1.0)
    np.testing.assert_allclose(view_gain(GAINS, 2), GAINS[1])
    np.testing.assert_allclose(view_gain(GAINS, two_then_one), np.multiply(GAINS[1], GAINS[0]))
    # a mirror not measured counts as 1
    np.testing.assert_allclose(view_gain((None, GAINS[1]), two_then_one), GAINS[1])
    table = correction_table(GAINS)
    np.testing.assert_allclose(table[two_then_one, :3] * np.multiply(GAINS[1], GAINS[0]), 1.0,
                               rtol=1e-6)


def test_point_colours_undo_the_gain_round_and_clip():
    image = np.array([[[100, 50, 250], [100, 50, 250], [100, 50, 250]]], np.uint8)
    table = correction_table(((0.5, 0.8, 0.9),))
    out = point_colours(image, np.array([0, 1, 2]), np.array([0, 1, 0], np.uint8), table)
    assert out.dtype == np.uint8
    assert out[0].tolist() == [100, 50, 250] and out[2].tolist() == [100, 50, 250]
    # 100 / 0.5, 50 / 0.8 = 62.5 rounds to even, 250 / 0.9 clips at 255
    assert out[1].tolist() == [200, 62, 255]


def test_a_colour_image_of_another_size_is_refused():
    rig = true_rig(paper_scene(object="sphere", camera=CAMERA))
    depth = np.full(CAMERA.shape, 2.0, np.float32)
    with pytest.raises(FileFormatError, match="colour image: uint8 10x10x3 is not 8-bit RGB"):
        reconstruct_raw(rig, depth, colour=np.zeros((10, 10, 3), np.uint8))


def _colour_errors(scene, gains) -> dict[int, np.ndarray]:
    """Per source label, the (k, 3) colour error (levels) of the object's points of the ideal
    depth, the rig's gains set to `gains`, against the albedo at each pixel's true hit point."""
    frame = Simulator(scene).frame(0)
    rig = replace(true_rig(scene), colour_gains=gains)
    mask = frame.truth.surface == OBJECT
    cloud = reconstruct_raw(rig, frame.truth.depth, mask, frame.colour)
    hits = frame.truth.points_at(cloud.pixel_index)
    truth = object_albedo(0, hits - np.asarray(scene.objects[0].centre, np.float32))
    error = cloud.rgb.astype(np.float64) - truth
    return {int(s): error[cloud.sources == s] for s in np.unique(cloud.sources)}


@pytest.mark.parametrize("name", ["paper", "kaleidoscope"])
def test_every_view_carries_the_surface_colour_once_the_true_gains_are_undone(name):
    scene = (paper_scene(object="sphere", camera=CAMERA) if name == "paper"
             else kaleidoscope_scene(object="sphere", camera=CAMERA))
    tints = tuple(m.tint for m in scene.mirrors)
    errors = _colour_errors(scene, tints)
    multi = [s for s in errors if s > len(scene.mirrors)]
    assert len(errors[0]) > 500 and all(len(errors[j]) > 200
                                        for j in range(1, len(scene.mirrors) + 1))
    assert name == "paper" or multi, "the kaleidoscope shows views through two mirrors"
    for label, error in errors.items():
        if len(error) >= 50:
            # within rounding: each level is the albedo times the tints, rounded, then divided
            assert np.all(np.abs(error.mean(axis=0)) < 1.5), (label, error.mean(axis=0))
    # without the gains, every mirror's view is more than 3 levels too dark in every channel
    dim = _colour_errors(scene, ())
    for j in range(1, len(scene.mirrors) + 1):
        assert np.all(dim[j].mean(axis=0) < -3), (j, dim[j].mean(axis=0))


def test_a_frame_without_colour_has_no_rgb_and_falls_back_to_the_source_colours():
    scene = paper_scene(object="sphere", camera=CAMERA)
    frame = Simulator(scene).frame(0)
    cloud = reconstruct_raw(true_rig(scene), frame.depth, frame.truth.surface == OBJECT)
    assert cloud.rgb is None
    assert np.array_equal(cloud.true_colours, cloud.colours)
    picked = cloud.select(cloud.sources == 1)
    assert picked.rgb is None and len(picked) > 0


def test_rgb_words_pack_red_green_blue_and_255_and_an_empty_cloud_has_none():
    rgb = np.array([[1, 2, 3], [250, 128, 0]], np.uint8)
    words = rgb_words(rgb)
    assert words.dtype == np.uint32
    np.testing.assert_array_equal(words.view(np.uint8).reshape(-1, 4),
                                  [[1, 2, 3, 255], [250, 128, 0, 255]])
    np.testing.assert_array_equal(rgb_words(np.zeros((4, 8, 3), np.uint8)[:, ::2]),
                                  np.full(16, 255 << 24 if np.little_endian else 255, np.uint32))
    assert rgb_words(np.zeros((0, 3), np.uint8)).shape == (0,)

