"""GLB files of clouds and meshes: trimesh reads back the same vertices (metres, camera frame)
and colours, under the node that turns the camera frame into glTF's axes; the suffix chooses GLB
or PLY."""
import numpy as np
import pytest
import trimesh

from mirrorcore.base.palette import source_colours
from mirrorcore.io.glb import CAMERA_TO_GLTF, encode_glb, write_glb, write_result
from mirrorcore.io.ply import encode_ply

RNG = np.random.default_rng(7)
POINTS = RNG.uniform(-1, 3, (200, 3)).astype(np.float32)
COLOURS = RNG.integers(0, 256, (200, 3), dtype=np.uint8)
SOURCES = RNG.integers(0, 3, 200).astype(np.uint8)
FACES = RNG.integers(0, 200, (50, 3)).astype(np.int32)


def _read(path):
    """The one geometry of a GLB file and its node's transform."""
    scene = trimesh.load(path, file_type="glb", process=False)
    (name,) = scene.graph.nodes_geometry
    transform, geometry = scene.graph.get(name)
    return scene.geometry[geometry], transform


def test_a_cloud_reads_back_with_its_points_and_colours(tmp_path):
    path = tmp_path / "cloud.glb"
    write_glb(path, POINTS, COLOURS)
    cloud, transform = _read(path)
    assert isinstance(cloud, trimesh.PointCloud)
    np.testing.assert_array_equal(cloud.vertices, POINTS)
    np.testing.assert_array_equal(cloud.colors[:, :3], COLOURS)
    # y down, z forward (OpenCV) -> y up, looking along -z (glTF)
    np.testing.assert_array_equal(transform, CAMERA_TO_GLTF)
    assert np.linalg.det(transform[:3, :3]) == 1.0


def test_a_mesh_reads_back_with_its_vertices_faces_and_vertex_colours(tmp_path):
    path = tmp_path / "mesh.glb"
    write_glb(path, POINTS, COLOURS, FACES)
    mesh, _ = _read(path)
    assert isinstance(mesh, trimesh.Trimesh)
    np.testing.assert_array_equal(mesh.vertices, POINTS)
    np.testing.assert_array_equal(mesh.faces, FACES)
    np.testing.assert_array_equal(mesh.visual.vertex_colors[:, :3], COLOURS)


def test_the_suffix_chooses_glb_else_ply_and_a_glb_without_colours_has_the_source_colours(
        tmp_path):
    write_result(tmp_path / "a.GLB", POINTS, SOURCES)
    cloud, _ = _read(tmp_path / "a.GLB")
    np.testing.assert_array_equal(cloud.colors[:, :3], source_colours(SOURCES))
    write_result(tmp_path / "a.ply", POINTS, SOURCES, FACES, COLOURS)
    assert (tmp_path / "a.ply").read_bytes() == encode_ply(POINTS, SOURCES, FACES, COLOURS)


@pytest.mark.parametrize("colours, faces, match", [
    (COLOURS[:10], None, "200 points but colours of shape"),
    (COLOURS, np.array([[0, 1, 200]]), "face indices must be in 0..199"),
])
def test_mismatched_input_is_refused(colours, faces, match):
    with pytest.raises(ValueError, match=match):
        encode_glb(POINTS, colours, faces)


def test_mismatched_labels_are_refused(tmp_path):
    with pytest.raises(ValueError, match="200 points but 3 source labels"):
        write_result(tmp_path / "a.glb", POINTS, SOURCES[:3])
    assert not (tmp_path / "a.glb").exists()
