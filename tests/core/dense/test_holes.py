"""Holes of a mesh and their closing (mirrorcore.dense.holes, TsdfResult.closed_mesh): a hole is
closed only when it is short enough and every new triangle lies where a view observed the voxels,
wound as the mesh, its new vertex in the mean colour of the hole's loop; on the simulated sphere
most holes close, the caps that no view saw stay open and the fused surface is as accurate as
before."""
import numpy as np
import pytest

from mirrorcore.dense import DenseOptions, dense_volume
from mirrorcore.dense.holes import close_holes, mesh_holes
from mirrorcore.dense.mesh import Mesh
from mirrorcore.dense.tsdf import HOLE_VOXELS, fuse
from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.sim.sensor import SensorModel
from tests.dense_scene import sphere_scene

VOXEL = 0.002


def plane_with_a_hole() -> Mesh:
    """A 6 x 6 grid of unit squares at z = 0, two triangles each, but the square at (2, 2)."""
    index = np.arange(49).reshape(7, 7)
    faces = []
    for i in range(6):
        for j in range(6):
            if (i, j) != (2, 2):
                a, b, c, d = index[i, j], index[i + 1, j], index[i + 1, j + 1], index[i, j + 1]
                faces += [(a, b, c), (a, c, d)]
    grid = np.stack(np.meshgrid(np.arange(7), np.arange(7), indexing="ij"), -1).reshape(-1, 2)
    vertices = np.column_stack([grid, np.zeros(49)]).astype(np.float32)
    return Mesh(vertices, np.array(faces, np.int32), np.arange(49, dtype=np.uint8))


def directed_edges(faces: np.ndarray) -> np.ndarray:
    return np.asarray(faces)[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)


def test_a_short_seen_hole_is_closed_wound_as_the_mesh():
    mesh = plane_with_a_hole()
    holes = mesh_holes(mesh)
    # the border (24) and the missing square (4)
    assert holes.count == 2 and holes.length == pytest.approx(28.0)
    closed = close_holes(mesh, lambda p: np.ones(len(p), bool), 4.0)
    assert mesh_holes(closed).count == 1 and mesh_holes(closed).length == pytest.approx(24.0)
    assert np.array_equal(closed.faces[:len(mesh.faces)], mesh.faces)
    np.testing.assert_allclose(closed.vertices[-1], [2.5, 2.5, 0.0])
    assert len(closed.vertices) == 50 and len(closed.faces) == len(mesh.faces) + 4
    # every edge is used once each way at most: one winding
    assert len(np.unique(directed_edges(closed.faces), axis=0)) == 3 * len(closed.faces)
    assert closed.sources[-1] in (16, 17, 23, 24)
    assert closed.colours is None
    # the new vertex takes the mean colour of the hole's loop (vertices 16, 17, 23, 24)
    colours = np.zeros((49, 3), np.uint8)
    colours[[16, 17, 23, 24], 0] = (10, 20, 30, 41)
    colours[:, 2] = 200
    painted = close_holes(Mesh(mesh.vertices, mesh.faces, mesh.sources, colours),
                          lambda p: np.ones(len(p), bool), 4.0)
    np.testing.assert_array_equal(painted.colours[:49], colours)
    np.testing.assert_array_equal(painted.colours[49], (25, 0, 200))


def test_a_hole_too_long_or_not_seen_stays_open():
    mesh = plane_with_a_hole()
    assert close_holes(mesh, lambda p: np.ones(len(p), bool), 3.99) is mesh
    assert close_holes(mesh, lambda p: np.zeros(len(p), bool), 100.0) is mesh
    # one new triangle's centroid unseen: the hole stays open
    corner = close_holes(mesh, lambda p: np.all(p[:, :2] > 2.3, axis=1) | (len(p) == 1), 4.0)
    assert corner is mesh


@pytest.fixture(scope="module", params=[0, 1])
def fused(request):
    scene = sphere_scene(1.0, SensorModel.kinect_v1(), seed=request.param)
    depth, mask = prepare_frame(scene.rig, scene.depth, scene.background)
    volume = dense_volume(scene.rig, depth, mask, DenseOptions(voxel=VOXEL))
    return scene, fuse(scene.rig, depth, mask, volume)


def rmse_to_sphere(points, scene) -> float:
    return float(np.sqrt(np.mean((np.linalg.norm(points - scene.centre, axis=1)
                                  - scene.radius) ** 2)))


def test_the_sphere_s_seen_holes_close_and_its_unseen_caps_stay_open(fused):
    scene, result = fused
    mesh, closed = result.mesh(), result.closed_mesh()
    before, after = mesh_holes(mesh), mesh_holes(closed)
    assert after.count <= before.count / 3 and after.length < before.length
    assert np.array_equal(closed.faces[:len(mesh.faces)], mesh.faces)
    long = [h for h in _loop_lengths(closed) if h > HOLE_VOXELS * VOXEL]
    # the top and bottom of the sphere, which no view sees, as long as before
    assert len(long) >= 2 and sum(long) == pytest.approx(
        sum(h for h in _loop_lengths(mesh) if h > HOLE_VOXELS * VOXEL))
    added = closed.vertices[len(mesh.vertices):]
    assert len(added) > 0 and result.observed(added).all()
    assert rmse_to_sphere(added, scene) < 3e-3
    assert rmse_to_sphere(closed.vertices, scene) <= rmse_to_sphere(mesh.vertices, scene) + 1e-5
    assert len(np.unique(directed_edges(closed.faces), axis=0)) == 3 * len(closed.faces)


def _loop_lengths(mesh: Mesh) -> list[float]:
    from mirrorcore.dense.holes import _loops
    return list(_loops(mesh.vertices, mesh.faces).lengths)
