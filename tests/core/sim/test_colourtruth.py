"""The colour truth: the albedo at a point is the colour the simulator gives the surface there,
a cloud's colours are compared per source with signs that mean something (too bright reads > 0),
and a cloud in the source palette has no scene colour."""
from dataclasses import replace

import numpy as np
import pytest

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.base.palette import source_colours, source_sequence
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.sim.albedo import FLOOR_COLOUR, WALL_COLOUR
from mirrorcore.sim.colourtruth import (WITHIN_LEVELS, colour_errors, has_scene_colour,
                                        true_albedo, view_pixels)
from mirrorcore.sim.layouts import kaleidoscope_scene, paper_scene
from mirrorcore.sim.render import OBJECT, ROOM
from mirrorcore.sim.sensor import SensorModel
from mirrorcore.sim.simulator import Simulator

CAMERA = Intrinsics.kinect_v1().scaled(0.5)


@pytest.fixture(scope="module")
def rendered():
    """The paper's scene (two tinted mirrors), its ideal frame, and per pixel: seen (a surface of
    the room or the object, through at most one mirror), the label (0 or the mirror), the real
    points and the tints on each ray."""
    scene = paper_scene(camera=CAMERA)
    # without the colour camera's noise: each level is the albedo times the tints, rounded
    frame = Simulator(scene, replace(SensorModel.kinect_v1(), colour_sigma=0.0)).frame(0)
    truth = frame.truth
    mirrors = truth.mirrors.reshape(len(truth.mirrors), -1)
    seen = (np.isin(truth.surface.reshape(-1), (OBJECT, ROOM))
            & np.all(mirrors[1:] == 0, axis=0))
    index = np.flatnonzero(seen)
    labels = mirrors[0, index].astype(np.int64)
    tints = np.array([(1.0, 1.0, 1.0), *(m.tint for m in scene.mirrors)], np.float32)[labels]
    return (scene, frame.colour.reshape(-1, 3)[index], labels, truth.points_at(index), tints,
            truth.surface.reshape(-1)[index], truth)


def _errors(rendered, points, labels, colours):
    """colour_errors against the fixture's scene, its true planes and ideal render."""
    scene, *_, truth = rendered
    return colour_errors(points, labels, colours, scene, truth.planes, truth=truth)


def test_the_albedo_at_the_true_points_is_the_colour_the_simulator_gives_them(rendered):
    scene, colour, labels, points, tints, surface, _ = rendered
    albedo = true_albedo(points, scene)
    assert set(labels.tolist()) == {0, 1, 2} and (surface == ROOM).sum() > 1000
    # the render is the albedo times the tints, rounded
    assert np.all(np.abs(albedo * tints - colour) <= 0.5 + 1e-3)
    on_object = surface == OBJECT
    assert on_object.sum() > 1000 and len(np.unique(albedo[on_object], axis=0)) == 2
    room = albedo[~on_object]
    assert np.all(np.all(room == FLOOR_COLOUR, axis=1) | np.all(room == WALL_COLOUR, axis=1))


def test_colours_with_the_tint_undone_match_and_a_gain_left_out_does_not(rendered):
    scene, colour, labels, points, tints, *_ = rendered
    undone = np.clip(np.rint(colour / tints), 0, 255).astype(np.uint8)
    errors = _errors(rendered, points, labels, undone)
    assert [e.source for e in errors] == [0, 1, 2]
    assert sum(e.points for e in errors) == len(points) and not any(e.unseen for e in errors)
    for e in errors:
        # a tint's rounding, at most 0.5 / 0.82 levels
        assert np.all(np.abs(e.bias) < 0.7) and e.rmse < 0.7 and e.within == 1.0
        # the direct view's colours are exact: no ratio to them
        assert e.within_at_point == 1.0 and e.ratio is None and errors[0].rmse == 0
    left_out = _errors(rendered, points, labels, colour)
    assert np.all(np.abs(left_out[0].bias) < 0.5)
    for e, mirror in zip(left_out[1:], scene.mirrors):
        # the tints dim every channel: 11 to 18 % of levels of 60 to 235
        assert all(b < -5 for b in e.bias) and e.within < 0.5
        assert e.bias[0] < -(1 - mirror.tint[0]) * 60


def test_the_bias_is_signed_and_the_rmse_and_share_count_every_channel(rendered):
    scene, colour, labels, points, *_ = rendered
    albedo = np.rint(true_albedo(points, scene))
    brighter = np.clip(albedo + (12, 0, -3), 0, 255).astype(np.uint8)
    # without labels every point is taken as seen directly
    sel = np.all((albedo >= 3) & (albedo <= 243), axis=1) & (labels == 0)
    (error,) = _errors(rendered, points[sel], None, brighter[sel])
    assert error.source is None and error.points == sel.sum() and error.ratio == 1.0
    assert error.bias == pytest.approx((12.0, 0.0, -3.0), abs=1e-4)
    assert error.rmse == pytest.approx(np.sqrt((144 + 9) / 3), abs=1e-4)
    assert error.within == error.within_at_point == 0.0 and 12 > WITHIN_LEVELS


def test_a_cloud_in_the_source_palette_has_no_scene_colour(rendered):
    _, colour, labels, *_ = rendered
    assert has_scene_colour(colour, labels)
    assert not has_scene_colour(source_colours(labels), labels)
    # whatever the palette's colours: one per source
    assert not has_scene_colour(source_colours(labels, [5, 2]), labels)
    assert not has_scene_colour(None, labels)
    assert not has_scene_colour(np.zeros((0, 3), np.uint8), labels[:0])
    one = np.full((len(labels), 3), 90, np.uint8)
    assert not has_scene_colour(one, None)
    one[-1] = 91
    assert has_scene_colour(one, None) and has_scene_colour(one, labels)


def test_refusals_name_what_is_missing(rendered):
    scene, colour, labels, points, *_ = rendered
    with pytest.raises(MirrorscanError, match="the cloud has no points"):
        _errors(rendered, points[:0], labels[:0], colour[:0])
    with pytest.raises(MirrorscanError, match="source label 2 names a mirror the session does "
                       r"not have \(1 mirrors\)"):
        colour_errors(points, labels, colour, scene, rendered[-1].planes[:1],
                      truth=rendered[-1])
    with pytest.raises(MirrorscanError, match="the scene has no object to compare with"):
        true_albedo(points, replace(scene, objects=()))


def test_a_point_seen_through_two_mirrors_maps_back_to_its_own_pixel_last_mirror_first():
    scene = kaleidoscope_scene(camera=CAMERA)
    truth = Simulator(scene).frame(0).truth
    labels = truth.source.reshape(-1)
    pixels = np.flatnonzero((truth.surface.reshape(-1) == OBJECT) & (labels >= 0))
    labels = labels[pixels]
    multi = [label for label in np.unique(labels) if len(source_sequence(label)) == 2]
    assert {0, 1, 2} <= set(labels.tolist()) and len(multi) == 2
    points = truth.points_at(pixels)
    np.testing.assert_array_equal(view_pixels(points, labels, truth.planes, CAMERA), pixels)
    # the two sequences through both mirrors swapped: the first mirror first lands elsewhere
    a, b = multi
    swapped = np.where(labels == a, b, np.where(labels == b, a, labels))
    moved = view_pixels(points, swapped, truth.planes, CAMERA) != pixels
    assert np.all(moved[np.isin(labels, multi)]) and not moved[~np.isin(labels, multi)].any()
    # without labels every point is taken as seen directly
    assert np.array_equal(view_pixels(points, None, truth.planes, CAMERA) == pixels, labels == 0)
