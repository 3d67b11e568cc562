"""Volumetric fusion (mirrorcore.tsdf) of the camera's and the mirrors' views: on the simulated sphere with Kinect
noise the mesh is at least as accurate as the raw cloud of Algorithm 1; the sparse fusion computes every voxel of
the truncation band as a fusion of the whole grid does, and its mesh is the whole grid's; large boxes with little
surface fit the memory budget; the mesh PLY file; progress and cancel."""
import threading

import numpy as np
import open3d as o3d
import pytest
from skimage.measure import marching_cubes

from mirrorcore.budget import MemoryBudgetError, set_memory_budget
from mirrorcore.dense import DenseOptions, dense_volume, reconstruct_dense
from mirrorcore.dense.blocks import Blocks
from mirrorcore.dense.mesh import _merge_copies, _observed_edges
from mirrorcore.dense.tsdf import BLOCK, fuse
from mirrorcore.dense.volume import NO_SOURCE, Volume
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
    (tsdf, weight, _), (tsdf2, weight2, _) = fused.grids(), twice.grids()
    seen = weight > 0
    assert np.array_equal(seen, weight2 > 0)
    assert np.allclose(weight2[seen], 2 * weight[seen]) and np.allclose(tsdf2, tsdf, atol=1e-6)


@pytest.fixture(scope="module")
def half():
    """(scene, prepared depth, mask, volume) of one Kinect frame at half resolution, 2 mm voxels."""
    scene = sphere_scene(0.5, SensorModel.kinect_v1(), seed=3)
    depth, mask = prepare_frame(scene.rig, scene.depth, scene.background)
    return scene, depth, mask, dense_volume(scene.rig, depth, mask, DenseOptions())


def test_the_sparse_fusion_computes_the_band_as_the_whole_grid_does(half):
    """Every voxel to which some view gives a value below 1 (within the truncation of its surface) is in the blocks
    and has the tsdf, weight and source of a fusion of every voxel, bit for bit; the voxels left out are those every
    view sees empty (tsdf 1) or not at all."""
    scene, depth, mask, volume = half
    sparse = fuse(scene.rig, depth, mask, volume)
    whole = fuse(scene.rig, depth, mask, volume, blocks=Blocks.all(volume, BLOCK))
    (t, w, s), (tw, ww, sw) = sparse.grids(), whole.grids()
    band = (ww > 0) & (tw < 1)
    assert band.sum() > 20_000 and (w[band] > 0).all()
    computed = w > 0
    for a, b in ((t, tw), (w, ww), (s, sw)):
        np.testing.assert_array_equal(a[computed], b[computed])
    left_out = (ww > 0) & ~computed
    assert left_out.sum() > 0 and (tw[left_out] == 1).all()
    assert (t[~computed] == 1).all() and (s[~computed] == NO_SOURCE).all()
    assert len(sparse.blocks) < np.prod(volume.block_shape(BLOCK)) / 5     # 15 % of the grid's blocks


def test_the_mesh_of_the_blocks_is_the_whole_grids(half):
    """Marching cubes over the blocks gives the vertices and faces that it gives on the whole grids (the voxels
    outside the blocks unobserved), with the same observed-edge rule."""
    scene, depth, mask, volume = half
    fused = fuse(scene.rig, depth, mask, volume)
    mesh = fused.mesh()
    tsdf, weight, _ = fused.grids()
    verts, faces, _, _ = marching_cubes(tsdf, 0.0, mask=weight > 0, allow_degenerate=False)
    verts, faces = _observed_edges(verts, faces, weight > 0)
    expected = (np.asarray(volume.origin) + volume.voxel * verts).astype(np.float32)
    assert len(mesh.vertices) == len(expected) and abs(len(mesh.faces) - len(faces)) <= len(faces) // 1000
    np.testing.assert_allclose(np.sort(mesh.vertices, axis=0), np.sort(expected, axis=0), atol=1e-6)
    assert (mesh.sources != NO_SOURCE).all()


def test_a_large_box_with_little_surface_fits_the_budget(half):
    """60 cm at 1 mm: 216 million voxels (4.3 GB at the 20 bytes a voxel fusion used to need). Its blocks near the
    sphere fit in 256 MiB and its mesh is as accurate as the raw cloud; carving, which holds two bytes a voxel, is
    refused before any work, and so is a fusion whose blocks do not fit."""
    scene, depth, mask, _ = half
    raw = reconstruct_raw(scene.rig, depth, mask).points
    volume = Volume.from_bounds(scene.centre - 0.3, scene.centre + 0.3, 0.001)
    assert volume.size == 600 ** 3
    set_memory_budget(256 << 20)
    try:
        mesh = reconstruct_dense(scene.rig, depth[None], mask[None], volume, "tsdf").mesh()
        assert len(mesh.faces) > 200_000 and rmse_to_sphere(mesh.vertices, scene) <= rmse_to_sphere(raw, scene)
        with pytest.raises(MemoryBudgetError, match="carving's state and source grids"):
            reconstruct_dense(scene.rig, depth[None], mask[None], volume, "carve")
        set_memory_budget(8 << 20)
        with pytest.raises(MemoryBudgetError, match=r"tsdf: [\d,]+ blocks of 4\^3 voxels of 1 mm"):
            fuse(scene.rig, depth, mask, volume)
    finally:
        set_memory_budget(None)


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


def test_merging_copies_drops_the_faces_it_makes_degenerate_and_the_vertices_only_they_used():
    """Vertices 0 and 1 share a key (one edge, two blocks); vertex 4 is used only by the face (0, 1, 4), which the
    merge makes degenerate: it goes, and the other faces are renumbered to the vertices kept (0, 2, 3, 5)."""
    edge = np.array([7, 7, 9, 11, 13, 15])
    faces = np.array([[0, 2, 3], [0, 1, 4], [1, 3, 5]])
    keep, merged = _merge_copies(edge, faces)
    assert keep.tolist() == [0, 2, 3, 5] and merged.tolist() == [[0, 1, 2], [0, 2, 3]]
