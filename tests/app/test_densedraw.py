"""How a dense result is drawn (mirrorscan.densedraw): a sphere's points lit by their outward
normals are brighter where they face the key light and vary in shade; a colour per point, when the
result has one, is what is shaded; a mesh with colours per vertex is drawn in them."""
import time

import numpy as np
from mirrorscan.densedraw import (AMBIENT, DENSE_COLOUR, FILL_LIGHT, KEY, KEY_LIGHT, UNLIT,
                                  draw_dense, shade)
from mirrorscan.results import DenseResult


def fibonacci_sphere(n: int) -> np.ndarray:
    k = np.arange(n) + 0.5
    polar, turn = np.arccos(1 - 2 * k / n), np.pi * (1 + 5 ** 0.5) * k
    return np.column_stack([np.cos(turn) * np.sin(polar), np.sin(turn) * np.sin(polar),
                            np.cos(polar)])


def result(vertices, faces=None, normals=None, colours=None) -> DenseResult:
    return DenseResult(np.asarray(vertices, np.float32), np.zeros(len(vertices), np.uint8), faces,
                       "carve" if faces is None else "tsdf", np.full(3, -1.0), np.full(3, 1.0),
                       0.004, time.time(), "sim", (), normals, colours)


def test_a_sphere_s_points_are_brighter_facing_the_key_light():
    normals = fibonacci_sphere(2000)
    grey = shade(normals, None, len(normals)).astype(float).mean(axis=1)
    facing = normals @ KEY_LIGHT
    # varied, and ordered by how much each faces the light
    assert grey.std() > 20
    assert grey[facing > 0.8].min() > grey[facing < -0.2].max()
    # facing away from both lights: the ambient light only
    dark = (facing < 0) & (normals @ FILL_LIGHT < 0)
    assert dark.sum() > 100
    np.testing.assert_allclose(grey[dark], AMBIENT * np.mean(DENSE_COLOUR), atol=1.0)
    # inward normals would light the far side: the shading tells them apart
    assert not np.array_equal(shade(-normals, None, len(normals)), shade(normals, None,
                                                                         len(normals)))


def test_points_without_normals_and_own_colours():
    assert np.array_equal(shade(None, None, 3), np.tile(np.rint(np.multiply(DENSE_COLOUR, UNLIT)),
                                                        (3, 1)))
    normals = np.array([KEY_LIGHT, np.zeros(3)])
    colours = np.array([[200, 100, 50], [10, 20, 30]], np.uint8)
    shaded = shade(normals, colours, 2)
    # lit by the key and the ambient light, in its own colour
    assert shaded[0, 0] > shaded[0, 1] > shaded[0, 2] and shaded[0, 0] >= 180
    np.testing.assert_array_equal(shaded[1], np.rint(colours[1] * UNLIT))


class Scene:
    """What draw_dense calls of a viser scene, recorded."""

    def __getattr__(self, name):
        return lambda *args, **kwargs: (name, args, kwargs)


def test_a_carving_is_drawn_as_shaded_points_and_a_coloured_mesh_in_its_colours():
    normals = fibonacci_sphere(500).astype(np.float32)
    kind, args, kwargs = draw_dense(Scene(), "/dense/result", result(normals * 0.1,
                                                                     normals=normals))
    assert kind == "add_point_cloud" and kwargs["point_shading"] == "flat"
    np.testing.assert_array_equal(args[2], shade(normals, None, 500))
    # a carving in the scene's colour is shaded the same way, in its points' own colours
    colours = np.random.default_rng(0).integers(0, 256, (500, 3), dtype=np.uint8)
    _, args, _ = draw_dense(Scene(), "/dense/result", result(normals * 0.1, normals=normals,
                                                             colours=colours))
    np.testing.assert_array_equal(args[2], shade(normals, colours, 500))
    lit = normals @ KEY_LIGHT > 0.5
    assert (args[2][lit].astype(int) <= colours[lit]).all()
    assert (args[2][lit].astype(int) >= np.floor(colours[lit] * (AMBIENT + 0.5 * KEY))).all()
    faces = np.array([[0, 1, 2]], np.int32)
    colours = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255]], np.uint8)
    kind, args, _ = draw_dense(Scene(), "/dense/result", result(np.eye(3), faces,
                                                                colours=colours))
    assert kind == "add_mesh_trimesh"
    np.testing.assert_array_equal(args[1].visual.vertex_colors[:, :3], colours)
    kind, _, kwargs = draw_dense(Scene(), "/dense/result", result(np.eye(3), faces))
    assert kind == "add_mesh_simple" and kwargs["color"] == DENSE_COLOUR
