"""Algorithm 1 through several mirrors in turn (mirrorcore.rig.raypaths): a corner of two mirrors
checked by hand, the simulated kaleidoscope against its ground truth (no ghost, every label right),
the bounce budget, the virtual cameras."""
import dataclasses

import numpy as np
import pytest

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.rig.model import Mirror, Rig
from mirrorcore.sim.export import true_rig
from mirrorcore.sim.layouts import kaleidoscope_scene
from mirrorcore.sim.render import Renderer

CAMERA = Intrinsics(8, 6, fx=4.0, fy=4.0, cx=3.5, cy=2.5)
GLASS = Plane.from_abcd([0, 0, -1, 2.0])     # mirror 1: z = 2, facing the camera
SIDE = Plane.from_abcd([-1, 0, 0, 1.0])      # mirror 2: x = 1, facing the camera (-x)
COLUMNS_4_5 = np.array([[4, 0], [5, 0], [5, 5], [4, 5]], float)
COLUMNS_6_7 = np.array([[6, 0], [7, 0], [7, 5], [6, 5]], float)


def corner(bounces: int = 3) -> Rig:
    """Column u = 5 (x/z = 0.375) meets the glass at z = 2, comes back towards the camera and meets
    the side mirror at x = 1 (at z = 4/3, which the camera sees in column 6.5), 2/3 further along:
    at unfolded depth 8/3. Columns 6 and 7 (x/z = 0.625, 0.875) meet the side mirror first (z = 1.6,
    8/7), then the glass at z = 2 (seen in columns 5 and 4), both at unfolded depth 2. In column 5
    the side mirror is met at height y = 8/3 y' (y' = y/z of the row), which the camera sees in row
    2 (v - 2.5) + 2.5: inside the image, so on its outline, for rows 1 to 3 only. Column 4 (x/z =
    0.125) would meet the side mirror's plane behind the camera: it never does."""
    return Rig(CAMERA, (Mirror("glass", GLASS, COLUMNS_4_5), Mirror("side", SIDE, COLUMNS_6_7)),
               bounces)


def test_the_corner_by_hand():
    chains = corner().reflection_table.chains
    column = chains.pixel % CAMERA.width
    row = chains.pixel // CAMERA.width
    assert sorted(set(column)) == [5, 6, 7] and sorted(row[column == 5]) == [1, 2, 3]
    assert len(chains) == 3 + 2 * CAMERA.height
    np.testing.assert_allclose(chains.threshold[0], np.where(column == 5, 8 / 3, 2.0), rtol=1e-6)
    # 1 then 2; 2 then 1
    np.testing.assert_array_equal(chains.label[0], np.where(column == 5, 33, 34))
    # no third mirror
    assert np.all(np.isinf(chains.threshold[1])) and np.all(np.isinf(chains.cutoff))
    np.testing.assert_allclose(chains.normal[0], [SIDE.n if c == 5 else GLASS.n for c in column])
    np.testing.assert_allclose(chains.offset[0], np.where(column == 5, 1.0, 2.0))


@pytest.mark.parametrize("z, source, point", [
    (1.5, 0, (0.5625, 1.5)),            # in front of the glass: direct
    (2.5, 1, (0.9375, 1.5)),            # behind the glass only: reflected through it, z -> 4 - z
    (3.0, 33, (0.875, 1.0)),            # beyond the side mirror too: x -> 2 - x after z -> 4 - z
])
def test_a_pixel_comes_back_through_each_mirror_it_is_beyond(z, source, point):
    depth = np.zeros(CAMERA.shape, np.float32)
    depth[2, 5] = z
    cloud = reconstruct_raw(corner(), depth)
    assert cloud.sources.tolist() == [source]
    np.testing.assert_allclose(cloud.points[0, [0, 2]], point, atol=1e-6)
    # y keeps the ray's value
    np.testing.assert_allclose(cloud.points[0, 1], (2 - 2.5) / 4 * z, atol=1e-6)


def test_one_bounce_leaves_out_what_came_through_a_second_mirror():
    depth = np.zeros(CAMERA.shape, np.float32)
    # rows 1-3: the side mirror begins at 8/3 = 2.67
    depth[:, 5] = [3.0, 2.5, 2.6, 2.7, 2.9, 1.9]
    cloud = reconstruct_raw(corner(bounces=1), depth)
    assert cloud.pixels[:, 1].tolist() == [0, 1, 2, 4, 5] and cloud.sources.tolist() == [
        1, 1, 1, 1, 0]
    assert reconstruct_raw(corner(bounces=2), depth).sources.tolist() == [1, 1, 1, 33, 1, 0]


def test_bounces_out_of_range_are_refused():
    for bounces in (0, 4, 2.5, True):
        with pytest.raises(MirrorscanError,
                           match="--bounces: the reflections followed must be 1 to 3"):
            corner(bounces)


@pytest.fixture(scope="module", params=[60.0, 72.0, 90.0])
def kaleidoscope(request):
    """(scene, ideal truth, rig with the true planes and outlines) of two hinged mirrors, at half
    resolution."""
    scene = kaleidoscope_scene(request.param, camera=Intrinsics.kinect_v1().scaled(0.5))
    return scene, Renderer(scene).render(), true_rig(scene)


def test_every_object_pixel_comes_back_to_its_true_place_with_its_label(kaleidoscope):
    """On the ideal frame, each pixel's point lands on the real surface it shows (not a ghost) and
    its label is the simulator's full sequence, for direct, one, two and three mirrors."""
    _, truth, rig = kaleidoscope
    cloud = reconstruct_raw(rig, truth.depth, truth.object_mask)
    assert len(cloud) == truth.object_mask.sum()
    real = truth.points.reshape(-1, 3)[cloud.pixel_index]
    assert np.linalg.norm(cloud.points - real, axis=1).max() < 1e-4
    np.testing.assert_array_equal(cloud.sources, truth.source.reshape(-1)[cloud.pixel_index])
    assert (cloud.sources >= 33).sum() > 0.15 * len(cloud)


def test_source_counts_list_the_views_through_several_mirrors(kaleidoscope):
    _, truth, rig = kaleidoscope
    cloud = reconstruct_raw(rig, truth.depth, truth.object_mask)
    counts = cloud.source_counts(2)
    assert list(counts)[:3] == [0, 1, 2] and sum(counts.values()) == len(cloud)
    assert set(counts) == {0, 1, 2} | set(cloud.sources.tolist()) and min(list(counts)[3:]) >= 33
    assert cloud.counts(2) == {"direct": counts[0], "mirror 1": counts[1], "mirror 2": counts[2]}


def test_fewer_bounces_drop_the_longer_paths_and_never_misplace_them(kaleidoscope):
    _, truth, rig = kaleidoscope
    full = reconstruct_raw(rig, truth.depth, truth.object_mask)
    one = reconstruct_raw(dataclasses.replace(rig, bounces=1), truth.depth, truth.object_mask)
    assert set(one.sources.tolist()) <= {0, 1, 2}
    assert len(full) > 1.2 * len(one)
    kept = np.isin(full.pixel_index, one.pixel_index)
    np.testing.assert_array_equal(full.points[kept], one.points)
    np.testing.assert_array_equal(full.pixel_index[full.sources <= 2], one.pixel_index)


def test_virtual_cameras_map_real_points_to_what_the_camera_measures(kaleidoscope):
    """Each virtual camera's to_view takes the real point of one of its pixels to that pixel's
    measured (virtual) point; poses are proper rigid transforms whose origin is the camera seen
    through the mirrors."""
    _, truth, rig = kaleidoscope
    cameras = rig.virtual_cameras()
    assert [c.name for c in cameras[:3]] == ["direct", "mirror 1", "mirror 2"]
    assert [c.source for c in cameras] == sorted({c.source for c in cameras})
    assert {c.source for c in cameras} >= set(np.unique(truth.source[truth.object_mask]).tolist())
    rays = truth.camera.rays
    virtual = np.stack([rays[0] * truth.depth, rays[1] * truth.depth, truth.depth], axis=-1)
    for cam in cameras:
        # what it sees: object, room, markers
        sel = (truth.surface > 0) & (truth.source == cam.source)
        real = np.c_[truth.points[sel], np.ones(sel.sum())]
        np.testing.assert_allclose((real @ cam.to_view.T)[:, :3], virtual[sel], atol=1e-4)
        assert np.linalg.det(cam.pose[:3, :3]) == pytest.approx(1.0)
        assert np.linalg.det(cam.to_view[:3, :3]) == pytest.approx((-1.0) ** len(cam.sequence))
        origin = np.linalg.inv(cam.to_view)[:3, 3]
        np.testing.assert_allclose(cam.pose[:3, 3], origin)
        assert cam.pixels > 0
