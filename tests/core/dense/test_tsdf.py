"""Volumetric fusion (mirrorcore.tsdf) of the camera's and the mirrors' views: on the simulated
sphere with Kinect noise the mesh is at least as accurate as the raw cloud of Algorithm 1; the
sparse fusion computes every voxel of the truncation band as a fusion of the whole grid does, and
its mesh is the whole grid's; large boxes with little surface fit the memory budget; the mesh PLY
file; progress and cancel. The mesh is scikit-image's Lorensen marching cubes on the whole grids,
kept to observed edges, across block boundaries and with vertices exactly on grid points."""
import threading

import numpy as np
import open3d as o3d
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree
from skimage.measure import marching_cubes

from mirrorcore.base.budget import MemoryBudgetError, set_memory_budget
from mirrorcore.dense import DenseOptions, dense_volume, reconstruct_dense
from mirrorcore.dense.blocks import Blocks
from mirrorcore.dense.mesh import block_marching_cubes
from mirrorcore.dense.tsdf import BLOCK, fuse
from mirrorcore.dense.volume import NO_SOURCE, Volume
from mirrorcore.base.errors import Cancelled, MirrorscanError
from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.io.ply import read_ply, write_ply
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.sim.sensor import SensorModel
from tests.dense_scene import sphere_scene


def rmse_to_sphere(points, scene) -> float:
    return float(np.sqrt(np.mean((np.linalg.norm(points - scene.centre,
                                                 axis=1) - scene.radius) ** 2)))


@pytest.fixture(scope="module", params=[0, 1])
def noisy(request):
    """(scene, prepared depth, mask, raw cloud, fused result) of one Kinect frame at full
    resolution."""
    scene = sphere_scene(1.0, SensorModel.kinect_v1(), seed=request.param)
    depth, mask = prepare_frame(scene.rig, scene.depth, scene.background)
    volume = dense_volume(scene.rig, depth, mask, DenseOptions())
    return scene, depth, mask, reconstruct_raw(scene.rig, depth, mask), fuse(scene.rig, depth, mask,
                                                                             volume)


def test_mesh_is_no_less_accurate_than_the_raw_cloud(noisy):
    scene, _, _, raw, fused = noisy
    mesh = fused.mesh()
    assert rmse_to_sphere(mesh.vertices, scene) <= rmse_to_sphere(raw.points, scene)
    # a closed-ish surface of 2 mm cells, not a few patches
    assert len(mesh.faces) > 50_000
    counts = np.bincount(mesh.sources, minlength=3)
    # every view contributes (reflections work)
    assert len(counts) == 3 and (counts > 10_000).all(), counts


def test_mesh_ply_is_readable(noisy, tmp_path):
    mesh = noisy[4].mesh()
    write_ply(tmp_path / "mesh.ply", mesh.vertices, mesh.sources, mesh.faces)
    header = (tmp_path / "mesh.ply").read_bytes()[:400]
    assert b"binary_little_endian" in header and b"property list uchar int vertex_indices" in header
    points, sources = read_ply(tmp_path / "mesh.ply")
    assert np.array_equal(points, mesh.vertices) and np.array_equal(sources, mesh.sources)
    o3d_mesh = o3d.io.read_triangle_mesh(str(tmp_path / "mesh.ply"))
    assert np.array_equal(np.asarray(o3d_mesh.triangles), mesh.faces)


def test_a_frame_fused_twice_keeps_the_surface_and_doubles_the_weight(noisy):
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
    """Every voxel to which some view gives a value below 1 (within the truncation of its surface)
    is in the blocks and has the tsdf, weight and source of a fusion of every voxel, bit for bit;
    the voxels left out are those every view sees empty (tsdf 1) or not at all."""
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
    # 15 % of the grid's blocks
    assert len(sparse.blocks) < np.prod(volume.block_shape(BLOCK)) / 5


def lorensen_on_observed_edges(values, observed):
    """The reference: scikit-image's Lorensen marching cubes on whole grids (nx, ny, nz), kept to
    the faces whose 3 vertices lie on edges with both ends observed, the vertices at one grid point
    merged (scikit-image nudges each off it by 2e-16 along its own edge), the faces made degenerate
    by that and the vertices no face uses dropped -> vertices (n, 3) float64 voxel index
    coordinates, faces (f, 3), and the count of faces scikit-image made. A vertex exactly on a grid
    point tells no edge here: that point alone must be observed (the blocks' mesh checks the edge
    its corner was found on); the grids below have no such vertex beside an unobserved voxel."""
    verts, faces, _, _ = marching_cubes(values, 0.0, method="lorensen", allow_degenerate=True)
    made = len(faces)
    lower, upper = (tuple(np.minimum(r(verts), np.array(values.shape) - 1).astype(int).T)
                    for r in (np.floor, np.ceil))
    faces = faces[(observed[lower] & observed[upper])[faces].all(axis=1)]
    _, first, same = np.unique(np.round(verts.astype(np.float64), 6), axis=0, return_index=True,
                               return_inverse=True)
    faces = same.reshape(-1)[faces]
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2])
                  & (faces[:, 0] != faces[:, 2])]
    used = np.zeros(len(first), bool)
    used[faces.reshape(-1)] = True
    return verts[first[used]].astype(np.float64), np.cumsum(used)[faces] - 1, made


def oriented(faces):
    """(f, 3) vertex indices -> the faces without a repeated index, each rotated to start at its
    least index (the winding kept), in sorted order."""
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2])
                  & (faces[:, 0] != faces[:, 2])]
    start = np.argmin(faces, axis=1)[:, None]
    faces = np.take_along_axis(faces, (start + np.arange(3)) % 3, axis=1)
    return faces[np.lexsort(faces.T[::-1])]


def assert_same_mesh(mesh, volume, verts, faces):
    """The block mesh has the reference's vertices (metres, to 1e-6 m) and its faces with their
    winding. Vertices closer than that (a few, near grid points: float32 metres do not tell them
    apart) count as one place; the faces are compared as triples of places, and the places as counts
    of vertices."""
    expected = np.asarray(volume.origin) + volume.voxel * verts
    assert len(mesh.vertices) == len(expected)
    np.testing.assert_allclose(np.sort(mesh.vertices, axis=0), np.sort(expected, axis=0), atol=1e-6)
    pairs = cKDTree(expected).query_pairs(1e-6, output_type="ndarray")
    _, place = connected_components(coo_matrix((np.ones(len(pairs)), tuple(pairs.T)),
                                               (len(expected),) * 2))
    assert len(pairs) <= len(expected) // 1000
    distance, match = cKDTree(expected).query(mesh.vertices)
    assert distance.max() < 1e-6
    np.testing.assert_array_equal(np.bincount(place[match], minlength=len(expected)),
                                  np.bincount(place, minlength=len(expected)))
    assert len(oriented(place[faces])) >= len(faces) - len(faces) // 1000
    np.testing.assert_array_equal(oriented(place[match][mesh.faces]), oriented(place[faces]))


def in_blocks(volume, values, mask, source, keep=None):
    """Whole grids (padded to blocks of BLOCK^3 voxels) -> the Blocks where `keep` holds (default:
    those with a voxel in the mask) and their values, mask and source as (m, B, B, B)."""
    b = BLOCK
    shape = tuple(n // b for n in values.shape)
    cut = [g.reshape(shape[0], b, shape[1], b, shape[2], b).transpose(0, 2, 4, 1, 3, 5)
           for g in (values, mask, source)]
    blocks = Blocks.marked(volume, cut[1].any(axis=(3, 4, 5)) if keep is None else keep, b)
    return blocks, *(g[tuple(blocks.ijk.T)] for g in cut)


def test_the_mesh_of_the_blocks_is_scikit_images_lorensen_on_the_whole_grids(half):
    """Marching cubes over the blocks gives the vertices and the oriented faces that scikit-image's
    Lorensen marching cubes gives on the whole grids (the voxels outside the blocks unobserved: tsdf
    1, weight 0), kept to the faces on observed edges; every vertex has a label."""
    scene, depth, mask, volume = half
    fused = fuse(scene.rig, depth, mask, volume)
    mesh = fused.mesh()
    tsdf, weight, _ = fused.grids()
    verts, faces, made = lorensen_on_observed_edges(tsdf, weight > 0)
    # the observed-edge rule drops some
    assert len(faces) > 20_000 and made > len(faces) + 1000
    assert_same_mesh(mesh, volume, verts, faces)
    assert (mesh.sources != NO_SOURCE).all()


def test_a_surface_across_blocks_is_the_whole_grids():
    """A tilted plane crossing 27 blocks and a sphere, with the blocks far from both and one block
    the plane crosses left out (unobserved): the block mesh is the whole grid's across every block
    boundary and around the missing blocks, the faces of the cubes whose lowest corner is in a
    missing block included."""
    volume = Volume.from_bounds([0, 0, 0], [12, 12, 12], 1.0)
    x, y, z = np.meshgrid(*(np.arange(12.0),) * 3, indexing="ij")
    plane = (0.6 * x + 0.3 * y + 0.2 * z - 5.25) / 2                  # no value exactly 0
    sphere = (np.sqrt((x - 8.2) ** 2 + (y - 3.1) ** 2 + (z - 7.6) ** 2) - 2.7) / 2
    values = np.clip(np.minimum(np.abs(plane), np.abs(sphere)) * np.sign(plane * sphere), -1,
                     1).astype(np.float32)
    mask = np.ones(values.shape, bool)
    near = np.abs(values).reshape(3, 4, 3, 4, 3, 4).min(axis=(1, 3, 5)) < 0.7
    assert 3 <= np.count_nonzero(~near) <= 10 and near[1, 1, 1]
    near[1, 1, 1] = False
    blocks, v, m, s = in_blocks(volume, values, mask, np.zeros(values.shape, np.uint8), near)
    mesh = block_marching_cubes(blocks, v, m, s)
    whole = np.ones(values.shape, bool)
    for i, j, k in blocks.ijk * BLOCK:
        whole[i:i + BLOCK, j:j + BLOCK, k:k + BLOCK] = False
    values[whole], mask[whole] = 1.0, False
    verts, faces, _ = lorensen_on_observed_edges(values, mask)
    assert len(faces) > 300
    assert_same_mesh(mesh, volume, verts, faces)


def test_vertices_on_grid_points_are_one_vertex_and_their_degenerate_faces_go():
    """The plane x + y + z = 3 through grid points: every vertex is a grid point (a value exactly
    0), one vertex each (10 of them), and the faces of the cubes that it only touches at a corner,
    degenerate, are dropped; it is scikit-image's mesh with its copies at one point merged. A lone
    zero among positive voxels makes only degenerate faces: they go, and so does its vertex."""
    volume = Volume.from_bounds([0, 0, 0], [4, 4, 4], 1.0)
    values = np.sum(np.indices((4, 4, 4)), axis=0).astype(np.float32) - 3
    mask, source = np.ones(values.shape, bool), np.zeros(values.shape, np.uint8)
    mesh = block_marching_cubes(*in_blocks(volume, values, mask, source))
    grid = (mesh.vertices - np.asarray(volume.origin)) / volume.voxel
    assert len(grid) == 10 and np.array_equal(grid,
                                              np.round(grid)) and (grid.sum(axis=1) == 3).all()
    a, b, c = (grid[mesh.faces[:, k]] for k in range(3))
    assert len(mesh.faces) > 0 and (np.linalg.norm(np.cross(b - a, c - a), axis=1) > 0.5).all()
    assert_same_mesh(mesh, volume, *lorensen_on_observed_edges(values, mask)[:2])
    lone = np.ones((4, 4, 4), np.float32)
    lone[1, 1, 1], lone[3, 3, 3] = 0.0, -1.0
    mesh = block_marching_cubes(*in_blocks(volume, lone, mask, source))
    grid = (mesh.vertices - np.asarray(volume.origin)) / volume.voxel
    assert len(mesh.faces) == 1 and sorted(map(tuple, grid)) == [(2.5, 3, 3), (3, 2.5, 3),
                                                                 (3, 3, 2.5)]


def test_mesh_vertices_take_the_label_of_the_nearer_end_of_their_edge():
    """A plane between x = 1 and x = 2 crossing each edge at t = 0.75, 0.25, 0.5, 0.25 along y: the
    vertex takes the label of the nearer end (1 at x = 1, 2 at x = 2; the lower end at 0.5), the
    other end's when the nearer one has none (x = 1 unlabelled at y = 3), and none when neither has
    one (z = 3)."""
    volume = Volume.from_bounds([0, 0, 0], [4, 4, 4], 1.0)
    values = np.ones((4, 4, 4), np.float32)
    values[1], values[2:] = np.array([0.75, 0.25, 0.5, 0.25])[:, None], -1.0
    # x = 2: t - 1, so that the crossing is at t
    values[2] = values[1] - 1
    source = np.zeros((4, 4, 4), np.uint8)
    source[1], source[2] = 1, 2
    source[1, 3], source[1:3, :, 3] = NO_SOURCE, NO_SOURCE
    mesh = block_marching_cubes(*in_blocks(volume, values, np.ones(values.shape, bool), source))
    grid = (mesh.vertices - np.asarray(volume.origin)) / volume.voxel
    assert len(grid) == 16
    np.testing.assert_allclose(grid[:, 0],
                               1 + np.array([0.75, 0.25, 0.5, 0.25])[grid[:, 1].astype(int)],
                               atol=1e-6)
    expected = np.where(grid[:, 2] == 3, NO_SOURCE, np.array([2, 1, 1, 2])[grid[:, 1].astype(int)])
    np.testing.assert_array_equal(mesh.sources, expected)


def test_a_large_box_with_little_surface_fits_the_budget(half):
    """60 cm at 1 mm: 216 million voxels (4.3 GB at 20 bytes a voxel). Its blocks near the sphere
    fit in 256 MiB and its mesh is as accurate as the raw cloud; carving, which holds two bytes a
    voxel, is refused before any work, and so is a fusion whose blocks do not fit."""
    scene, depth, mask, _ = half
    raw = reconstruct_raw(scene.rig, depth, mask).points
    volume = Volume.from_bounds(scene.centre - 0.3, scene.centre + 0.3, 0.001)
    assert volume.size == 600 ** 3
    set_memory_budget(256 << 20)
    try:
        mesh = reconstruct_dense(scene.rig, depth[None], mask[None], volume, "tsdf").mesh()
        assert len(mesh.faces) > 200_000 and rmse_to_sphere(mesh.vertices,
                                                            scene) <= rmse_to_sphere(raw, scene)
        with pytest.raises(MemoryBudgetError, match="carving's state and source grids"):
            reconstruct_dense(scene.rig, depth[None], mask[None], volume, "carve")
        set_memory_budget(8 << 20)
        with pytest.raises(MemoryBudgetError, match=r"tsdf: [\d,]+ blocks of 4\^3 voxels of 1 mm"):
            fuse(scene.rig, depth, mask, volume)
    finally:
        set_memory_budget(None)


def test_fusion_reports_progress_and_stops_when_cancelled(noisy):
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
