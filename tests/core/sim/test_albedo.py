"""The simulator's colour: a pixel seen directly has the albedo of its hit point (checked against
the analytic ray-face intersection), a pixel seen through mirrors has that albedo times the tint of
every mirror on its ray, a textured object shows its texture, `simulate` writes colour frames the
session reader accepts and truth.json the tints, and the depth does not depend on colour."""
import json
from dataclasses import replace

import cv2
import numpy as np
import pytest

from mirrorcore.base.errors import FileFormatError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.io.session import TRUTH_FILE
from mirrorcore.io.sessionfile import load_session
from mirrorcore.sim.albedo import (CHECKER_M, CHECKER_PHASE, FLOOR_COLOUR, OBJECT_COLOURS,
                                   WALL_COLOUR, object_albedo)
from mirrorcore.sim.export import write_session
from mirrorcore.sim.layouts import kaleidoscope_scene, paper_scene
from mirrorcore.sim.render import OBJECT, ROOM
from mirrorcore.sim.scene import DEFAULT_TINTS, Scene, SceneObject
from mirrorcore.sim.scenefile import scene_from_json
from mirrorcore.sim.sensor import SensorModel
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources.sim import SimulatedSource

CAMERA = Intrinsics.kinect_v1().scaled(0.5)
# the Kinect model without its colour noise: each level is the albedo times the tints, rounded
EXACT = replace(SensorModel.kinect_v1(), colour_sigma=0.0)
# distinct per-channel reflectances: a missing or swapped tint moves a level by 20 or more
TINTS = ((0.55, 0.9, 0.75), (0.85, 0.6, 0.95), (0.7, 0.8, 0.6))


def _tinted(scene: Scene) -> Scene:
    """The scene with TINTS on its mirrors."""
    return replace(scene, mirrors=tuple(replace(m, tint=TINTS[j])
                                        for j, m in enumerate(scene.mirrors)))


def _expected(scene, truth, sel, tints):
    """Albedo at the real hit points of `sel` times the product of `tints` (each (3,))."""
    pts = truth.points[sel]
    albedo = object_albedo(0, pts - np.asarray(scene.objects[0].centre, np.float32))
    return albedo * np.prod(np.asarray(tints, np.float64).reshape(-1, 3), axis=0)


def _edge_distance(local):
    """(..., 3) metres, object frame -> (..., 3) metres to the nearest checker edge per axis."""
    cells = (local + CHECKER_PHASE) / CHECKER_M
    return np.abs(cells - np.round(cells)) * CHECKER_M


def _off_edges(scene, truth, sel, margin=2e-3):
    """`sel` without the pixels whose hit point lies within `margin` metres of a checker edge."""
    cell = _edge_distance(truth.points - np.asarray(scene.objects[0].centre, np.float32))
    return sel & np.all(cell > margin, axis=-1)


def test_a_pixel_seen_directly_has_the_albedo_of_its_hit_point():
    # a box whose front face z = 1.9 m faces the camera; each ray meets it at z = 1.9
    box = SceneObject("box", (0.02, 0.01, 2.0), size=(0.6, 0.5, 0.2))
    scene = Scene(CAMERA, (), (box,), room=None)
    frame = Simulator(scene, EXACT).frame(0)
    x, y = CAMERA.rays
    z0 = 1.9
    local = np.stack([x * z0, y * z0, np.full_like(x, z0)], axis=-1) - np.asarray(box.centre)
    front = (np.abs(local[..., 0]) < 0.29) & (np.abs(local[..., 1]) < 0.24)
    cell = _edge_distance(local)
    sel = front & np.all(cell[..., :2] > 2e-3, axis=-1)
    assert sel.sum() > 2000 and np.all(frame.truth.surface[sel] == OBJECT)
    parity = np.floor((local[sel] + CHECKER_PHASE) / CHECKER_M).astype(int).sum(axis=1) % 2
    expected = np.asarray(OBJECT_COLOURS[0])[parity]
    assert np.array_equal(frame.colour[sel], expected.astype(np.uint8))
    # the texture shows: both checker colours, about half each, and a shifted image disagrees
    even, odd = (np.all(frame.colour[sel] == np.asarray(c), axis=1).mean()
                 for c in OBJECT_COLOURS[0])
    assert 0.35 < even < 0.65 and 0.35 < odd < 0.65 and even + odd == 1.0
    shifted = np.roll(frame.colour, 3, axis=1)[sel]
    assert np.any(shifted != expected, axis=1).mean() > 0.05
    assert np.all(frame.colour[frame.truth.depth == 0] == 0)


@pytest.fixture(scope="module")
def paper():
    scene = _tinted(paper_scene(camera=CAMERA))
    return scene, Simulator(scene, EXACT).frame(0)


def test_a_pixel_seen_through_a_mirror_has_albedo_times_its_tint(paper):
    scene, frame = paper
    truth, colour = frame.truth, frame.colour.astype(np.float64)
    for j in (1, 2):
        sel = _off_edges(scene, truth, truth.object_mask & (truth.source == j))
        assert sel.sum() > 100
        assert np.abs(colour[sel] - _expected(scene, truth, sel, TINTS[j - 1])).max() <= 1
        # the other mirror's tint, or none, is many levels off
        wrong = _expected(scene, truth, sel, TINTS[2 - j])
        assert np.abs(colour[sel] - wrong).max(axis=1).mean() > 15
        assert np.abs(colour[sel] - _expected(scene, truth, sel, ())).max(axis=1).mean() > 15
    direct = _off_edges(scene, truth, truth.object_mask & (truth.source == 0))
    assert np.abs(colour[direct] - _expected(scene, truth, direct, ())).max() <= 0.5


def test_the_room_has_its_own_colours_through_the_mirrors(paper):
    scene, frame = paper
    truth, colour = frame.truth, frame.colour.astype(np.float64)
    room = truth.surface == ROOM
    floor = room & (np.abs(truth.points[..., 1] - scene.room.floor_y) < 1e-3)
    wall = room & (np.abs(truth.points[..., 2] - scene.room.back_z) < 1e-3)
    checked = 0
    for j, tint in ((0, (1, 1, 1)), (1, TINTS[0]), (2, TINTS[1])):
        for part, albedo in ((floor, FLOOR_COLOUR), (wall, WALL_COLOUR)):
            sel = part & (truth.source == j)
            checked += sel.sum() > 100
            assert np.abs(colour[sel] - np.multiply(albedo, tint)).max(initial=0) <= 0.501
    assert checked >= 4


def test_through_two_mirrors_in_turn_the_product_of_both_tints():
    scene = _tinted(kaleidoscope_scene(camera=CAMERA))
    frame = Simulator(scene, EXACT).frame(0)
    truth, colour = frame.truth, frame.colour.astype(np.float64)
    seen = 0
    for first, second in ((1, 2), (2, 1)):
        sel = _off_edges(scene, truth, truth.object_mask & (truth.bounces == 2)
                         & (truth.mirrors[0] == first) & (truth.mirrors[1] == second))
        if not sel.any():
            continue
        seen += sel.sum()
        product = _expected(scene, truth, sel, (TINTS[first - 1], TINTS[second - 1]))
        assert np.abs(colour[sel] - product).max() <= 1
        one = _expected(scene, truth, sel, TINTS[first - 1])
        assert np.abs(colour[sel] - one).max(axis=1).mean() > 10
    assert seen > 50


def test_mirrors_without_a_tint_get_ordinary_ones_and_the_file_keeps_them():
    scene = paper_scene(n_mirrors=3)
    assert [m.tint for m in scene.mirrors] == list(DEFAULT_TINTS)
    back = scene_from_json(_tinted(scene).to_json())
    assert [m.tint for m in back.mirrors] == list(TINTS)
    data = scene.to_json()
    data["mirrors"][0]["tint"] = [1.2, 0.9, 0.9]
    with pytest.raises(FileFormatError, match=r"mirrors\[0\]\.tint"):
        scene_from_json(data)


def test_simulate_writes_colour_frames_and_truth_the_tints(tmp_path):
    scene = _tinted(paper_scene(camera=CAMERA, object="figure", distance=3.0))
    rig = Simulator(scene)
    folder = write_session(rig, tmp_path / "s", 2, progress=False)
    session = load_session(folder)
    assert len(session.colour_frames) == len(session.frames) == 2
    for i, name in enumerate(session.colour_frames):
        image = cv2.cvtColor(cv2.imread(str(folder / name)), cv2.COLOR_BGR2RGB)
        assert np.array_equal(image, rig.frame(i).colour)
    truth = json.loads((folder / TRUTH_FILE).read_text())
    assert [m["tint"] for m in truth["mirrors"]] == [list(t) for t in TINTS[:2]]
    assert [m["tint"] for m in truth["scene"]["mirrors"]] == [list(t) for t in TINTS[:2]]
    assert SimulatedSource(rig).has_colour
    live = SimulatedSource(rig).read(1)
    assert live.colour.dtype == np.uint8 and live.colour.shape == (*CAMERA.shape, 3)
    assert np.array_equal(live.colour, rig.frame(1).colour)
    assert (live.colour[rig.frame(1).truth.object_mask] > 0).any()


def test_the_depth_does_not_depend_on_the_colour():
    scene = paper_scene(camera=CAMERA)
    plain, tinted = Simulator(scene).frame(3), Simulator(_tinted(scene)).frame(3)
    tinted.colour
    assert np.array_equal(plain.depth, tinted.depth)
    assert np.array_equal(plain.truth.depth, tinted.truth.depth)
    assert not np.array_equal(plain.colour, tinted.colour)
    # nor on the colour's noise
    assert np.array_equal(Simulator(scene, EXACT).frame(3).depth, plain.depth)


def test_the_colour_camera_adds_its_noise_afresh_each_frame_and_reproducibly():
    scene = paper_scene(camera=CAMERA)
    noisy, exact = Simulator(scene, seed=4), Simulator(scene, EXACT, seed=4)
    seen = exact.frame(0).truth.surface != 0
    errors = [noisy.frame(i).colour[seen].astype(float) - exact.frame(i).colour[seen]
              for i in range(2)]
    # away from 0 and 255, where the levels clip
    inside = [(e, (exact.frame(i).colour[seen] > 10) & (exact.frame(i).colour[seen] < 245))
              for i, e in enumerate(errors)]
    for error, sel in inside:
        assert abs(error[sel].mean()) < 0.05
        assert abs(error[sel].std() - SensorModel().colour_sigma) < 0.1
    assert not np.array_equal(errors[0], errors[1])
    assert np.array_equal(Simulator(scene, seed=4).frame(1).colour, noisy.frame(1).colour)
    assert np.all(noisy.frame(0).colour[~seen] == 0)
