"""Algorithm 1: which pixels are reflected, through which mirror, and where their points go."""
import hashlib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from tests.helpers import sphere_depth

from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.rig.pipeline import object_cloud
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.rig.model import Mirror, Rig
from mirrorcore.io.sessionfile import load_session

CAMERA = Intrinsics(8, 6, fx=4.0, fy=4.0, cx=3.5, cy=2.5)
PLANE = Plane.from_abcd([0, 0, -1, 2.0])               # glass at z = 2, facing the camera
LEFT = np.array([[0, 0], [3, 0], [3, 5], [0, 5]], float)  # columns 0..3 (edges included)


def rig(*mirrors) -> Rig:
    return Rig(CAMERA, tuple(mirrors))


def test_behind_the_glass_inside_the_boundary_is_reflected():
    depth = np.full(CAMERA.shape, 3.0, np.float32)       # everything reads 1 m behind the glass
    cloud = reconstruct_raw(rig(Mirror("m", PLANE, LEFT)), depth)
    u = cloud.pixels[:, 0]
    # boundary edge u = 3 inside
    assert (cloud.sources[u <= 3] == 1).all() and (cloud.sources[u >= 4] == 0).all()
    # z = 3 reflected through z = 2 gives z = 1
    np.testing.assert_allclose(cloud.points[u <= 3, 2], 1.0, atol=1e-6)
    np.testing.assert_allclose(cloud.points[u >= 4, 2], 3.0)
    # x and y are reflected too: through z = 2 they keep their value
    x_direct = (u[u <= 3] - CAMERA.cx) / CAMERA.fx * 3.0
    np.testing.assert_allclose(cloud.points[u <= 3, 0], x_direct, atol=1e-6)


def test_points_in_front_of_the_mirror_are_never_reflected():
    # in front of the glass (the real object, a marker)
    depth = np.full(CAMERA.shape, 1.5, np.float32)
    cloud = reconstruct_raw(rig(Mirror("m", PLANE, LEFT)), depth)
    assert (cloud.sources == 0).all()
    np.testing.assert_allclose(cloud.points[:, 2], 1.5)


def test_first_mirror_wins_where_boundaries_overlap():
    near = Plane.from_abcd([0, 0, -1, 2.0])
    far = Plane.from_abcd([0, 0, -1, 2.5])
    all_pixels = np.array([[0, 0], [7, 0], [7, 5], [0, 5]], float)
    depth = np.full(CAMERA.shape, 2.2, np.float32)       # behind `near` only
    cloud = reconstruct_raw(rig(Mirror("far", far, all_pixels), Mirror("near", near, LEFT)), depth)
    u = cloud.pixels[:, 0]
    # far does not apply (in front of it), near does
    assert (cloud.sources[u <= 3] == 2).all()
    assert (cloud.sources[u >= 4] == 0).all()
    # behind both: the first in session order wins
    depth[:] = 3.0
    cloud = reconstruct_raw(rig(Mirror("far", far, all_pixels), Mirror("near", near, LEFT)), depth)
    assert (cloud.sources == 1).all()
    np.testing.assert_allclose(cloud.points[:, 2], 2.0, atol=1e-6)


def test_mask_and_missing_readings():
    depth = np.full(CAMERA.shape, 3.0, np.float32)
    depth[0, 0] = 0
    mask = np.zeros(CAMERA.shape, bool)
    mask[0, :2] = True
    cloud = reconstruct_raw(rig(Mirror("m", PLANE, LEFT)), depth, mask)
    assert cloud.pixels.tolist() == [[1, 0]]             # (0, 0) has no reading; only masked pixels


def test_uncalibrated_mirror_pixels_are_left_out():
    depth = np.full(CAMERA.shape, 3.0, np.float32)
    cloud = reconstruct_raw(rig(Mirror("m", None, LEFT)), depth)
    assert (cloud.pixels[:, 0] >= 4).all() and (cloud.sources == 0).all()
    assert cloud.counts(1) == {"direct": 24, "mirror 1": 0}


def test_reflected_sphere_lands_on_the_real_sphere():
    """A virtual sphere behind a tilted mirror, rendered analytically, comes back onto the real
    one."""
    camera = Intrinsics.primesense()
    mirror = Plane.from_point_normal([0.0, 0.0, 2.5], [0.3, 0.1, -1.0])
    centre, radius = np.array([0.05, 0.0, 2.1]), 0.115
    virtual_centre = mirror.reflect(centre)
    depth = sphere_depth(camera, virtual_centre, radius)
    boundary = np.array([[0, 0], [639, 0], [639, 479], [0, 479]], float)
    cloud = reconstruct_raw(Rig(camera, (Mirror("m", mirror, boundary),)), depth)
    assert len(cloud) > 1000 and (cloud.sources == 1).all()
    dist = np.linalg.norm(cloud.points - centre, axis=1)
    assert np.abs(dist - radius).max() < 1e-4


def test_wrong_depth_size_is_refused():
    with pytest.raises(Exception, match="does not match the camera's 8x6"):
        reconstruct_raw(rig(), np.zeros((5, 5)))
    with pytest.raises(Exception, match="object mask: size 8x5 does not match the camera's 8x6"):
        reconstruct_raw(rig(), np.ones(CAMERA.shape), np.ones((5, 8), bool))


def test_empty_mask_gives_an_empty_cloud():
    cloud = reconstruct_raw(rig(Mirror("m", PLANE, LEFT)), np.full(CAMERA.shape, 3.0, np.float32),
                            np.zeros(CAMERA.shape, bool))
    assert len(cloud) == 0 and cloud.points.shape == (0, 3) and cloud.sources.dtype == np.uint8


def test_a_window_off_the_corner_keeps_pixel_indices():
    """Only the pixel (u=6, v=4) is masked: its point and its index come from that pixel, not the
    window's corner."""
    depth = np.full(CAMERA.shape, 3.0, np.float32)
    mask = np.zeros(CAMERA.shape, bool)
    mask[4, 6] = True
    cloud = reconstruct_raw(rig(Mirror("m", PLANE, LEFT)), depth, mask)
    assert cloud.pixels.tolist() == [[6, 4]]
    np.testing.assert_allclose(cloud.points[0], [(6 - 3.5) / 4 * 3, (4 - 2.5) / 4 * 3, 3.0],
                               atol=1e-6)


# sha256 (first 16 hex digits) of points, sources and pixel indices of the demo session's frames 0-4
# (the paper's rig, mirrors at 120 degrees): the whole frame, then the object's cloud, its depth not
# smoothed (OpenCV's bilateral filter changes its last bits between releases: 5.0 and 5.1 differ by
# up to 1.2 micrometres). Recorded with Algorithm 1 as it was before rays were followed through
# several mirrors (commit a4c18a3, the same object clouds on OpenCV 5.0 and 5.1).
DEMO_DIGESTS = [("6ab9d7e1fc0bd3dc", "b76beb237e6a3147"), ("ae8ac8717f864730", "f91b68d21f310c74"),
                ("e1e801ffe99a75ab", "fdf54b3c0b8bfc17"), ("e71109e6f2504321", "0fb8d401fed7c32f"),
                ("38c77736e9dc6e9f", "5220d552b95df3e1")]


def _digest(cloud) -> str:
    h = hashlib.sha256()
    for a in (cloud.points, cloud.sources, cloud.pixel_index):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


def test_where_no_ray_meets_two_mirrors_nothing_changes():
    """The paper's 120-degree rig: no pixel's ray meets a second mirror, and every cloud is the
    same, bit for bit."""
    session = load_session(Path(__file__).resolve().parents[3] / "sessions" / "demo")
    rig, background = Rig.from_session(session), session.read_background()
    selection = replace(session.selection, smooth=False)
    assert rig.bounces == 3 and len(rig.reflection_table.chains) == 0
    for i, expected in enumerate(DEMO_DIGESTS):
        depth = session.read_frame(i)
        cloud, _ = object_cloud(rig, depth, background, selection)
        assert (_digest(reconstruct_raw(rig, depth)), _digest(cloud)) == expected, f"frame {i}"
