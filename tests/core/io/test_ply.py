"""PLY files (io/ply.py): the layout, the scene's colours in red green blue with the labels in
source, readers of other tools' files, broken files refused."""

import numpy as np
import open3d as o3d
import pytest
import trimesh

from mirrorcore.base.errors import FileFormatError
from mirrorcore.base.palette import source_colours
from mirrorcore.io.ply import encode_ply, read_ply, write_ply


def test_ply_layout_and_readers(tmp_path):
    pts = np.random.default_rng(1).normal(size=(50, 3)).astype(np.float32)
    src = np.repeat([0, 1, 2, 1, 0], 10)
    write_ply(tmp_path / "c.ply", pts, src)
    raw = (tmp_path / "c.ply").read_bytes()
    header = raw[:raw.index(b"end_header")].decode()
    assert "format binary_little_endian 1.0" in header
    assert [line.split()[-1] for line in header.splitlines() if line.startswith("property")] == \
        ["x", "y", "z", "red", "green", "blue", "source"]
    assert "float x" in header and "uchar source" in header and "face" not in header
    p, s = read_ply(tmp_path / "c.ply")
    np.testing.assert_array_equal(p, pts)
    np.testing.assert_array_equal(s, src)
    o3d_cloud = o3d.io.read_point_cloud(str(tmp_path / "c.ply"))
    np.testing.assert_allclose(np.asarray(o3d_cloud.points), pts, atol=1e-7)
    colours = (np.asarray(o3d_cloud.colors) * 255).round()
    # colour by source
    assert (colours[:10] == colours[0]).all() and not (colours[10] == colours[0]).all()
    assert len(trimesh.load(tmp_path / "c.ply").vertices) == 50


def test_the_scenes_colours_go_in_red_green_blue_and_the_labels_stay_in_source(tmp_path):
    rng = np.random.default_rng(3)
    pts = rng.normal(size=(40, 3)).astype(np.float32)
    src = np.repeat([0, 1, 2, 33], 10).astype(np.uint8)
    rgb = rng.integers(0, 256, (40, 4), dtype=np.uint8)[:, :3]      # a strided view, as Cloud.rgb
    faces = np.array([[0, 1, 2], [3, 4, 39]])
    write_ply(tmp_path / "m.ply", pts, src, faces, rgb)
    mesh = trimesh.load(tmp_path / "m.ply", process=False)
    np.testing.assert_array_equal(mesh.visual.vertex_colors[:, :3], rgb)
    np.testing.assert_array_equal(mesh.faces, faces)
    np.testing.assert_array_equal(read_ply(tmp_path / "m.ply")[1], src)
    o3d_cloud = o3d.io.read_point_cloud(str(tmp_path / "m.ply"))
    np.testing.assert_array_equal((np.asarray(o3d_cloud.colors) * 255).round(), rgb)
    # without colours, the source colours; the same layout and size either way
    plain = encode_ply(pts, src, faces)
    assert len(plain) == len((tmp_path / "m.ply").read_bytes())
    assert plain == encode_ply(pts, src, faces, source_colours(src))
    with pytest.raises(ValueError, match="40 points but colours of shape"):
        encode_ply(pts, src, colours=rgb[:5])


def test_ascii_ply_from_another_tool(tmp_path):
    pts = np.random.default_rng(2).normal(size=(20, 3))
    o3d.io.write_point_cloud(str(tmp_path / "a.ply"),
                             o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts)),
                             write_ascii=True)
    p, s = read_ply(tmp_path / "a.ply")
    np.testing.assert_allclose(p, pts, atol=1e-5)
    assert s is None


def test_a_broken_ply_is_refused_naming_the_file(tmp_path):
    (tmp_path / "x.ply").write_bytes(b"not a ply")
    with pytest.raises(FileFormatError, match="x.ply: not a PLY file"):
        read_ply(tmp_path / "x.ply")
    write_ply(tmp_path / "t.ply", np.zeros((10, 3)), np.zeros(10, int))
    (tmp_path / "t.ply").write_bytes((tmp_path / "t.ply").read_bytes()[:-50])
    with pytest.raises(FileFormatError, match="t.ply: broken PLY"):
        read_ply(tmp_path / "t.ply")
