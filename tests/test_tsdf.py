"""Volumetric fusion (mirrorcore.tsdf) of the camera's and the mirrors' views: on the simulated sphere with Kinect
noise the mesh is at least as accurate as the raw cloud of Algorithm 1; the mesh PLY file; progress and cancel."""
import threading

import numpy as np
import open3d as o3d
import pytest

from mirrorcore.dense import DenseOptions, dense_volume
from mirrorcore.dense.tsdf import fuse
from mirrorcore.dense.volume import Volume
from mirrorcore.errors import Cancelled, MirrorscanError
from mirrorcore.pipeline import prepare_frame
from mirrorcore.ply import read_ply, write_ply
from mirrorcore.reconstruct import reconstruct_raw
from mirrorcore.sim.sensor import SensorModel
from tests.dense_scene import sphere_scene


def rmse_to_sphere(points, scene) -> float:
    return float(np.sqrt(np.mean((np.linalg.norm(points - scene.centre, axis=1) - scene.radius) ** 2)))


@pytest.fixture(scope="module", params=[0, 1])
def noisy(request):
    """(scene, prepared depth, mask, raw cloud, fused result) of one Kinect frame at full resolution."""
    scene = sphere_scene(1.0, SensorModel.kinect_v1(), seed=request.param)
    depth, mask = prepare_frame(scene.rig, scene.depth, scene.background)
    volume = dense_volume(scene.rig, depth, mask, DenseOptions())
    return scene, depth, mask, reconstruct_raw(scene.rig, depth, mask), fuse(scene.rig, depth, mask, volume)


def test_mesh_is_no_less_accurate_than_the_raw_cloud(noisy):
    scene, _, _, raw, fused = noisy
    mesh = fused.mesh()
    assert rmse_to_sphere(mesh.vertices, scene) <= rmse_to_sphere(raw.points, scene)
    assert len(mesh.faces) > 50_000                 # a closed-ish surface of 2 mm cells, not a few patches
    counts = np.bincount(mesh.sources, minlength=3)
    assert len(counts) == 3 and (counts > 10_000).all(), counts   # every view contributes (reflections work)


def test_mesh_ply_is_readable(noisy, tmp_path):
    mesh = noisy[4].mesh()
    write_ply(tmp_path / "mesh.ply", mesh.vertices, mesh.sources, mesh.faces)
    header = (tmp_path / "mesh.ply").read_bytes()[:400]
    assert b"binary_little_endian" in header and b"property list uchar int vertex_indices" in header
    points, sources = read_ply(tmp_path / "mesh.ply")
    assert np.array_equal(points, mesh.vertices) and np.array_equal(sources, mesh.sources)
    o3d_mesh = o3d.io.read_triangle_mesh(str(tmp_path / "mesh.ply"))
    assert np.array_equal(np.asarray(o3d_mesh.triangles), mesh.faces)


def test_several_frames_fuse(noisy):
    scene, depth, mask, _, fused = noisy
    twice = fuse(scene.rig, np.stack([depth, depth]), np.stack([mask, mask]), fused.volume)
    seen = fused.weight > 0
    assert np.allclose(twice.weight[seen], 2 * fused.weight[seen]) and np.allclose(twice.tsdf, fused.tsdf, atol=1e-6)


def test_progress_and_cancel(noisy):
    scene, depth, mask, _, fused = noisy
    fractions, stop = [], threading.Event()
    fuse(scene.rig, depth, mask, fused.volume, progress=fractions.append)
    assert fractions[-1] == 1.0 and np.all(np.diff(fractions) > 0)
    with pytest.raises(Cancelled):
        fuse(scene.rig, depth, mask, fused.volume, progress=lambda f: stop.set(), cancel=stop)


def test_bad_requests(noisy):
    scene, depth, mask, _, fused = noisy
    with pytest.raises(MirrorscanError, match="truncation"):
        fuse(scene.rig, depth, mask, fused.volume, truncation=-1)
    with pytest.raises(MirrorscanError, match="masks"):
        fuse(scene.rig, depth, mask[:10], fused.volume)
    far = Volume.from_bounds([5, 5, 5], [5.1, 5.1, 5.1], 0.01)
    with pytest.raises(MirrorscanError, match="no surface"):
        fuse(scene.rig, depth, mask, far).mesh()


def test_mesh_vertices_take_the_nearest_labelled_corner():
    """A vertex whose nearest voxel has no label takes the label of the nearest corner of its cube that has one."""
    from mirrorcore.dense.mesh import _corner_labels
    from mirrorcore.dense.volume import NO_SOURCE
    source = np.full((3, 3, 3), NO_SOURCE, np.uint8)
    source[1, 1, 1], source[2, 1, 1] = 2, 1
    verts = np.array([[1.2, 1.0, 1.0], [1.6, 1.0, 1.0], [0.4, 1.0, 1.0]])
    np.testing.assert_array_equal(_corner_labels(verts, source), [2, 1, 2])
