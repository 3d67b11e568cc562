"""Outward normals of carved points (mirrorcore.dense.normals): on the simulated sphere with Kinect
noise, carved both ways, the normals point away from the centre; each normal's sign follows the
view that saw its point."""
import numpy as np
import pytest

from mirrorcore.dense import DenseOptions, dense_volume
from mirrorcore.dense.carve import carve
from mirrorcore.dense.normals import surface_normals, view_centres
from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.sim.sensor import SensorModel
from tests.dense_scene import sphere_scene

VOXEL = 0.004


@pytest.fixture(scope="module")
def scene():
    return sphere_scene(1.0, SensorModel.kinect_v1())


@pytest.mark.parametrize("method", ["carve", "paper"])
def test_carved_sphere_normals_point_outward(scene, method):
    depth, mask = prepare_frame(scene.rig, scene.depth, scene.background)
    volume = dense_volume(scene.rig, depth, mask, DenseOptions(voxel=VOXEL))
    points, sources = carve(scene.rig, depth, mask, volume, method, VOXEL).surface_points()
    normals = surface_normals(points, sources, scene.rig, VOXEL)
    assert normals.shape == points.shape and normals.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-5)
    radial = (points - scene.centre) / np.linalg.norm(points - scene.centre, axis=1)[:, None]
    cosine = np.einsum("ij,ij->i", normals, radial)
    # every view's part of the sphere
    for source in (0, 1, 2):
        seen = sources == source
        assert seen.sum() > 100 and np.mean(cosine[seen] > 0.7) > 0.9, (source, cosine[seen])


def test_a_normal_faces_the_view_that_saw_its_point(scene):
    """A flat patch between the camera and a mirror's virtual camera: labelled as the camera's,
    its normals face the camera; as the mirror's, the mirror's virtual camera."""
    grid = np.stack(np.meshgrid(np.arange(-5, 6), np.arange(-5, 6)), axis=-1).reshape(-1, 2)
    patch = np.column_stack([grid * VOXEL, np.full(len(grid), 0.0)]) + scene.centre
    centres = view_centres(scene.rig)
    for source in (0, 1):
        normals = surface_normals(patch, np.full(len(patch), source, np.uint8), scene.rig, VOXEL)
        towards = centres[source] - patch
        assert np.all(np.einsum("ij,ij->i", normals, towards) > 0), source
        assert np.allclose(np.abs(normals[:, 2]), 1.0, atol=1e-6)
