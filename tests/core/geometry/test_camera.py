"""Intrinsics, reprojection (paper eq. 1) and projection, and the intrinsics file formats."""
import json

import numpy as np
import pytest

from mirrorcore.base.errors import FileFormatError
from mirrorcore.geometry.camera import Intrinsics, project_points, reproject_depth, reproject_pixels
from mirrorcore.geometry.camerafiles import (
    load_open3d_json,
    load_opencv_yaml,
    save_open3d_json,
    save_opencv_yaml,
)


def test_reprojection_by_hand():
    intr = Intrinsics(4, 3, fx=2.0, fy=4.0, cx=1.5, cy=1.0)
    depth = np.zeros((3, 4), np.float32)
    # u = 3, v = 2: x = (3 - 1.5) / 2 * 2 = 1.5, y = (2 - 1) / 4 * 2 = 0.5
    depth[2, 3] = 2.0
    depth[0, 0] = 1.0          # u = 0, v = 0: x = -0.75, y = -0.25
    points, pixels = reproject_depth(intr, depth)
    assert pixels.tolist() == [[0, 0], [3, 2]]      # (u, v), row-major order
    np.testing.assert_allclose(points, [[-0.75, -0.25, 1.0], [1.5, 0.5, 2.0]])


def test_principal_point_maps_to_the_optical_axis():
    intr = Intrinsics.kinect_v1()
    p = reproject_pixels(intr, [intr.cx], [intr.cy], [2.0])
    np.testing.assert_allclose(p, [[0, 0, 2.0]], atol=1e-6)


def test_ray_table_matches_pixel_formula():
    intr = Intrinsics.primesense()
    u, v = 600, 17                      # column 600, row 17: not swapped
    assert intr.rays.shape == (2, 480, 640)
    assert intr.rays[0, v, u] == pytest.approx((u - intr.cx) / intr.fx)
    assert intr.rays[1, v, u] == pytest.approx((v - intr.cy) / intr.fy)
    assert not intr.rays.flags.writeable


def test_project_inverts_reproject():
    intr = Intrinsics.kinect_v1()
    rng = np.random.default_rng(1)
    u, v, z = rng.uniform(0, 639, 500), rng.uniform(0, 479, 500), rng.uniform(0.5, 5, 500)
    uv, depth = project_points(intr, reproject_pixels(intr, u, v, z))
    np.testing.assert_allclose(uv, np.stack([u, v], 1), atol=1e-3)
    np.testing.assert_allclose(depth, z, rtol=1e-6)


def test_points_behind_the_camera_do_not_project():
    uv, _ = project_points(Intrinsics.kinect_v1(), [[0, 0, -1.0], [0, 0, 0]])
    assert np.isnan(uv).all()


def test_wrong_size_depth_is_refused():
    with pytest.raises(FileFormatError, match="320x240 does not match the camera's 640x480"):
        reproject_depth(Intrinsics.kinect_v1(), np.ones((240, 320)))


def test_scaled_keeps_pixel_centres():
    intr = Intrinsics.primesense().scaled(0.5)
    assert (intr.width, intr.height, intr.fx, intr.cx) == (320, 240, 262.5, 159.5)


def test_open3d_json_round_trip(tmp_path):
    intr = Intrinsics.kinect_v1()
    save_open3d_json(intr, tmp_path / "k.json")
    data = json.loads((tmp_path / "k.json").read_text())
    # column-major, as Open3D writes it
    assert data["intrinsic_matrix"][6] == pytest.approx(intr.cx)
    assert load_open3d_json(tmp_path / "k.json") == intr


def test_opencv_yaml_round_trip(tmp_path):
    intr = Intrinsics(320, 240, 290.0, 291.0, 160.2, 119.7, 0.0002)
    save_opencv_yaml(intr, tmp_path / "k.yaml")
    assert load_opencv_yaml(tmp_path / "k.yaml") == intr


def test_broken_intrinsics_files_are_refused_naming_the_file(tmp_path):
    (tmp_path / "bad.json").write_text("{\"width\": 640}")
    with pytest.raises(FileFormatError,
                       match="bad.json: not an Open3D PinholeCameraIntrinsic JSON"):
        load_open3d_json(tmp_path / "bad.json")
    with pytest.raises(FileFormatError, match="no such file"):
        load_opencv_yaml(tmp_path / "none.yaml")
    with pytest.raises(FileFormatError, match="fx, fy and depth_scale must be finite and positive"):
        Intrinsics(640, 480, -1, 500, 320, 240)
    with pytest.raises(FileFormatError, match="missing key"):
        Intrinsics.from_dict({"width": 640})
