"""The voxel grid (mirrorcore.volume): box to shape, centres, slabs, refusals, the slab runner."""
import numpy as np
import pytest

from mirrorcore.dense.volume import Volume, run_slabs
from mirrorcore.errors import Cancelled, MirrorscanError


def test_box_to_grid_and_back():
    v = Volume.from_bounds([0, 0, 1], [0.1, 0.05, 1.2], 0.01)
    assert v.shape == (10, 5, 20) and v.size == 1000
    assert np.allclose(v.origin, [0.005, 0.005, 1.005])
    corners = v.centres(np.array([0, v.size - 1]))
    assert np.allclose(corners, [[0.005, 0.005, 1.005], [0.095, 0.045, 1.195]])
    assert v.nearest_index(corners).tolist() == [0, v.size - 1]


def test_around_a_cloud_with_margin():
    v = Volume.around(np.array([[0, 0, 2], [0.2, 0.1, 2.3]]), 0.002, 0.02)
    assert v.shape == (120, 70, 170)
    with pytest.raises(MirrorscanError, match="no points"):
        Volume.around(np.empty((0, 3)), 0.002, 0.02)


def test_slabs_cover_the_grid_once():
    v = Volume((0, 0, 1), 0.01, (37, 20, 30))
    covered = np.concatenate([np.arange(37)[s] for s in v.slabs(max_voxels=1000)])
    assert covered.tolist() == list(range(37))


@pytest.mark.parametrize("args, match", [(((0, 0, 0), 0.0, (1, 1, 1)), "voxel size"),
                                         (((0, 0, 0), 0.01, (0, 1, 1)), "at least one voxel"),
                                         (((0, 0, 0), 0.01, (2000, 1000, 1000)), "more than")])
def test_refusals(args, match):
    with pytest.raises(MirrorscanError, match=match):
        Volume(*args)


def test_runner_calls_every_slab_then_cancels():
    v = Volume((0, 0, 1), 0.01, (300, 30, 30))
    seen = []
    run_slabs(v, seen.append, workers=2)
    assert sorted(s.start for s in seen) == [s.start for s in v.slabs()]
    with pytest.raises(Cancelled):
        run_slabs(v, lambda s: None, cancel=lambda: True)
