"""The 3D view (mirrorscan.view) and the depth screen: pixels and rays, the depth frame filling the
free area, the names of mirrors and virtual cameras placed clear of each other."""
import itertools
from types import SimpleNamespace

import numpy as np
import pytest
from mirrorscan.view import home_pose, label_anchor, same_place, scene_points

from tests.app.support import simulated_app


def test_depth_screen_maps_rays_to_pixels_and_back(demo):
    screen = demo[1].tab.screen
    eye = screen.centre - [0.3, -0.2, 2.0]  # somewhere behind the screen
    for uv in [(0.0, 0.0), (319.5, 239.5), (639.0, 479.0), (100.25, 400.75)]:
        target = screen.world_of_pixel(*uv)
        got = screen.pixel_of_ray(eye, target - eye)
        np.testing.assert_allclose(got, uv, atol=1e-9)
    # u grows with x: not mirrored
    assert screen.world_of_pixel(0, 0)[0] < screen.world_of_pixel(639, 0)[0]
    # v grows with y (down)
    assert screen.world_of_pixel(0, 0)[1] < screen.world_of_pixel(0, 479)[1]
    assert screen.pixel_of_ray(eye, [0.0, 0.0, -1.0]) is None  # pointing away
    # beside it
    assert screen.pixel_of_ray(eye, screen.world_of_pixel(0, 0) - [0.5, 0, 0] - eye) is None


@pytest.mark.parametrize("aspect", [0.8, 1.04, 16 / 9])
def test_the_depth_frame_fills_the_free_area(demo, aspect):
    """From the view pose, every corner of the frame is inside the tab's view of 50 deg, and one
    side fits."""
    screen = demo[1].tab.screen
    position, target = screen.view_pose(aspect)
    distance = target[2] - position[2]
    half_h = np.tan(np.radians(25)) * distance
    half_w = half_h * aspect
    assert screen.height / 2 <= half_h and screen.width / 2 <= half_w
    # not lost in the middle
    assert max(screen.height / 2 / half_h, screen.width / 2 / half_w) > 0.95


def test_a_mirrors_name_is_at_the_middle_of_its_top_edge():
    """The middle of a pane's top edge; two mirrors hinged at 90 degrees, their hinge's top corner
    listed first (as the simulator's are), get their names apart (both were on that corner)."""
    # up is -y
    pane = np.array([[-0.5, 0.4, 2.0], [0.5, 0.4, 2.0], [0.5, -0.6, 2.2], [-0.5, -0.6, 2.2]])
    np.testing.assert_allclose(label_anchor(pane), [0.0, -0.6, 2.2])
    left = np.array([[0.0, -0.5, 2.35], [-0.7, -0.5, 1.65], [-0.7, 0.5, 1.65], [0.0, 0.5, 2.35]])
    right = left * [-1, 1, 1]
    np.testing.assert_allclose(label_anchor(left), [-0.35, -0.5, 2.0])
    np.testing.assert_allclose(label_anchor(right), [0.35, -0.5, 2.0])


def _home_pixels(points: np.ndarray, canvas: tuple[int, int], scene: np.ndarray) -> np.ndarray:
    """(k, 2) pixels of `points` (k, 3) metres in the first view (home_pose of `scene`, as
    Tab.look_home frames it) of a canvas (width, height) with the tab's 50 degrees of vertical field
    of view; y grows downwards."""
    fov = np.radians(50.0)
    position, target = home_pose(scene, fov, canvas[0] / canvas[1])
    forward = (target - position) / np.linalg.norm(target - position)
    right = np.cross(forward, [0.0, -1.0, 0.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    rays = points - position
    focal = canvas[1] / 2 / np.tan(fov / 2)
    depth = rays @ forward
    return np.stack(
        [
            canvas[0] / 2 + focal * (rays @ right) / depth,
            canvas[1] / 2 + focal * (rays @ down) / depth,
        ],
        1,
    )


def _name_boxes(
    labels, canvas: tuple[int, int], home: np.ndarray
) -> list[tuple[np.ndarray, np.ndarray]]:
    """(low, high) pixels of each label's name in the first view framing `home` (k, 3) metres: a box
    7 px a character wide and 18 px high, times its font scale, at its anchor's corner, as drawn."""
    anchors = _home_pixels(np.array([label.position for label in labels]), canvas, home)
    found = []
    for anchor, label in zip(anchors, labels):
        vertical, horizontal = label.anchor.split("-")
        size = np.array([7.0 * len(label.text), 18.0]) * label.font_screen_scale
        corner = np.array(
            [
                {"left": 0.0, "center": 0.5, "right": 1.0}[horizontal],
                {"top": 0.0, "center": 0.5, "bottom": 1.0}[vertical],
            ]
        )
        found.append((anchor - corner * size, anchor - corner * size + size))
    return found


CANVASES = [(976, 900), (620, 600)]  # the 3D view at 1400x900 and at 1024x600


@pytest.mark.parametrize("canvas", CANVASES)
def test_seen_from_home_every_virtual_camera_is_named_in_view_clear_of_the_object_and_names(
    demo, canvas
):
    """The walking figure's first view: the name of each camera seen in a mirror lies inside the 3D
    view (and the depth camera's), neither on the figure's points nor on a mirror's name, nor on
    the figure's head (2.5 frustum sizes under the frustum, seen from 24 degrees above), and seen
    from the right the right mirror's camera was out of view."""
    app, headless = demo
    frame = app.loop.run_once()
    scene = headless.tab.scene
    points = frame.cloud.points[:: max(1, len(frame.cloud) // 500)]
    home = np.concatenate([scene_points(app.snapshot.rig), points])
    figure = _home_pixels(points, canvas, home)
    mirrors = _name_boxes(
        [label for label in scene._labels if label.text.startswith("mirror")], canvas, home
    )
    cameras = _name_boxes(scene._virtual_labels, canvas, home)
    assert len(mirrors) == 2 and len(cameras) == 2
    for low, high in cameras + _name_boxes(
        [label for label in scene._labels if label.text == "depth camera"], canvas, home
    ):
        assert np.all(low >= 0) and np.all(high <= canvas), (low, high)
        assert not np.any(np.all((figure >= low) & (figure <= high), axis=1)), (low, high)
        assert not any(
            np.all(low <= other_high) and np.all(other_low <= high)
            for other_low, other_high in mirrors
        )


@pytest.mark.parametrize("scene", ["arc", "hinged", "four"])
def test_seen_from_home_the_names_of_cameras_through_several_mirrors_stand_apart(scene):
    """An arc of three mirrors around the figure, two hinged at 72 degrees, four mirrors: every name
    (the depth camera's, the mirrors', the cameras' through one mirror and through two) inside the
    3D view and none on another by more than 2 px, at both window sizes. Run inwards from every
    camera beyond the mirrors, names through two mirrors are not written over each other, nor on
    four mirrors over those through one."""
    from mirrorscan.bench.tabs import HeadlessTab

    from mirrorcore.sim.layouts import arc_scene, kaleidoscope_scene

    made = {
        "arc": lambda: arc_scene(3, object="figure", distance=3.0),
        "hinged": lambda: kaleidoscope_scene(72.0),
        "four": lambda: arc_scene(4),
    }[scene]()
    app = simulated_app(made)
    try:
        with HeadlessTab(app) as headless:
            tab = headless.tab
            frame = app.loop.run_once()
            labels = tab.scene._labels + tab.scene._virtual_labels
            assert any(label.text.count("then") for label in tab.scene._virtual_labels)
            points = frame.cloud.points[:: max(1, len(frame.cloud) // 500)]
            home = np.concatenate([scene_points(app.snapshot.rig), points])
            for canvas in CANVASES:
                boxes = _name_boxes(labels, canvas, home)
                for (low, high), label in zip(boxes, labels):
                    assert np.all(low >= 0) and np.all(high <= canvas), (label.text, canvas)
                for (a, (low, high)), (b, (other_low, other_high)) in itertools.combinations(
                    enumerate(boxes), 2
                ):
                    assert not (np.all(low < other_high - 2) and np.all(other_low < high - 2)), (
                        labels[a].text,
                        labels[b].text,
                        canvas,
                    )
    finally:
        app.stop()


def test_virtual_cameras_in_one_place_share_one_label():
    """Between mirrors hinged at 72 degrees, calibrated from their markers, the camera seen through
    two mirrors and through three stand 1.3 to 5.4 cm apart:
    one label names both, where their two labels were written over each other; cameras 12 cm apart
    keep their own."""

    def camera(sequence, x, z):
        pose = np.eye(4)
        pose[:3, 3] = (x, 0.0, z)
        return SimpleNamespace(sequence=sequence, pose=pose)

    cameras = [
        camera((1,), -2.307, 1.677),
        camera((2,), 2.305, 1.669),
        camera((1, 2), 1.432, 4.384),
        camera((2, 1), -1.430, 4.385),
        camera((1, 2, 1), 1.422, 4.391),
        camera((2, 1, 2), -1.376, 4.385),
        camera((1, 2, 1, 2), 1.552, 4.384),
    ]
    groups = same_place(cameras)
    assert [[c.sequence for c in g] for g in groups] == [
        [(1,)],
        [(2,)],
        [(1, 2), (1, 2, 1)],
        [(2, 1), (2, 1, 2)],
        [(1, 2, 1, 2)],
    ]
