"""The build measures in the level frame: sizes, heights, angles, lean, gaps and apex, on layouts
whose answers are known by hand."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from mirrorcore.plan.measures import Level, measure, mirror_measure, pair_measure
from mirrorcore.plan.planread import load_plan
from tests.core.plan.plans import THREE_PLAN, V_PLAN, tilted, write_plan

LEVEL = Level(np.array([1.0, 0, 0]), np.array([0, -1.0, 0]), np.array([0, 0, 1.0]), 1.0)


def test_a_mirror_leaning_back_gives_its_lean_and_heights():
    # 1.0 m high along its face, leaning 10 degrees back from upright, its bottom edge on the
    # floor (y = 1) at z = 2: its top 1.0 cos 10 above the floor, 1.0 sin 10 farther
    t = np.radians(10)
    top_y, top_z = 1 - np.cos(t), 2 + np.sin(t)
    corners = [[-0.3, 1, 2], [0.3, 1, 2], [0.3, top_y, top_z], [-0.3, top_y, top_z]]
    m = mirror_measure("m", np.array(corners), LEVEL)
    assert (m.width, m.height) == pytest.approx((0.6, 1.0))
    assert (m.bottom, m.top) == pytest.approx((0.0, np.cos(t)))
    assert m.lean == pytest.approx(10)
    # the same mirror turned over, its top towards the camera, leans forward
    forward = np.array(corners) * [1, 1, -1] + [0, 0, 4]
    assert mirror_measure("m", forward, LEVEL).lean == pytest.approx(-10)
    assert m.to_axis == pytest.approx(90)
    # its face turned to the camera: the normal points back (z < 0) and up
    assert m.normal[2] < 0 and m.normal[1] > 0


def test_two_mirrors_square_to_each_other_meet_at_90_degrees():
    # faces at 45 degrees to the axis, their near ends 0.1 m apart around x = 0, z = 2
    s = np.sqrt(0.5)
    left = np.array([[-0.05, 0, 2], [-0.05 - s, 0, 2 - s], [-0.05 - s, -1, 2 - s],
                     [-0.05, -1, 2]])
    right = left * [-1, 1, 1]
    a, b = (mirror_measure(n, c, LEVEL) for n, c in (("a", left), ("b", right)))
    pair = pair_measure(0, 1, a, b)
    assert (a.to_axis, b.to_axis) == pytest.approx((45, 45))
    assert pair.angle == pytest.approx(90) and pair.gap == pytest.approx(0.1)
    # their lines meet 0.05 m beyond the gap, on the axis
    np.testing.assert_allclose(pair.apex, [0, 2.05], atol=1e-9)


def test_parallel_mirrors_have_no_apex():
    a = mirror_measure("a", np.array([[-1, 0, 2], [-0.2, 0, 2], [-0.2, -1, 2], [-1, -1, 2.0]]),
                       LEVEL)
    b = mirror_measure("b", np.array([[0.2, 0, 2], [1, 0, 2], [1, -1, 2], [0.2, -1, 2.0]]),
                       LEVEL)
    pair = pair_measure(0, 1, a, b)
    assert pair.apex is None and pair.angle == pytest.approx(180)
    assert pair.gap == pytest.approx(0.4)


@pytest.mark.parametrize("down", [15, -10])
def test_a_tilted_camera_measures_the_same_layout(tmp_path, down):
    level = measure(load_plan(write_plan(tmp_path / "level", THREE_PLAN)))
    turned = measure(load_plan(write_plan(tmp_path / "turned", tilted(THREE_PLAN, down))))
    assert turned.level.tilt == pytest.approx(down) and turned.level.roll == pytest.approx(0)
    for a, b in zip(level.mirrors, turned.mirrors):
        np.testing.assert_allclose(a.corners, b.corners, atol=1e-9)
        assert (a.to_axis, a.lean, a.bottom, a.top) == pytest.approx(
            (b.to_axis, b.lean, b.bottom, b.top))
    np.testing.assert_allclose(np.sort(level.subject_points, axis=0),
                               np.sort(turned.subject_points, axis=0), atol=1e-9)


def test_neighbours_go_left_to_right_whatever_the_plan_order(tmp_path):
    data = copy.deepcopy(THREE_PLAN)
    data["mirrors"] = [data["mirrors"][k] for k in (2, 0, 1)]
    m = measure(load_plan(write_plan(tmp_path, data)))
    names = [(m.mirrors[p.first].name, m.mirrors[p.second].name) for p in m.pairs]
    assert names == [("left", "middle"), ("middle", "right")]


def test_the_v_subject_sphere_outline_is_its_size(tmp_path):
    points = measure(load_plan(write_plan(tmp_path, V_PLAN))).subject_points
    np.testing.assert_allclose(points.min(axis=0), [-0.15, 0.85, 1.65], atol=2e-3)
    np.testing.assert_allclose(points.max(axis=0), [0.15, 1.15, 1.95], atol=2e-3)
