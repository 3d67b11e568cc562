"""The voxel grid (mirrorcore.dense.volume) and its blocks (mirrorcore.dense.blocks): box to shape,
centres, blocks and their layout, bounds, writing, refusals, the chunk runner."""
import threading

import numpy as np
import pytest

from mirrorcore.dense.blocks import Blocks, cropped, padded_grid
from mirrorcore.dense.volume import Volume, run_chunks
from mirrorcore.base.errors import Cancelled, MirrorscanError


def test_box_to_grid_and_back():
    v = Volume.from_bounds([0, 0, 1], [0.1, 0.05, 1.2], 0.01)
    assert v.shape == (10, 5, 20) and v.size == 1000
    assert np.allclose(v.origin, [0.005, 0.005, 1.005])
    corners = v.centres(np.array([0, v.size - 1]))
    assert np.allclose(corners, [[0.005, 0.005, 1.005], [0.095, 0.045, 1.195]])
    assert v.nearest_index(corners).tolist() == [0, v.size - 1]
    assert np.allclose(v.corners()[[0, -1]], corners)


def test_the_box_of_a_grid_gives_the_grid_back():
    """The box a grid covers, made into a grid again (the browser's Dense fields after a run), keeps
    its shape: a box a whole number of voxels wide, up to rounding, does not gain a voxel (it did,
    by rounding up 26.000000000004)."""
    for lo, voxel in (([1.9179862439359936, 1.1744999658616915, 2.740289695151073], 0.004),
                      ([0, 0, 1], 0.01)):
        grid = Volume.from_bounds(lo, np.add(lo, [0.836, 0.104, 0.872]), voxel)
        for _ in range(3):
            low = np.asarray(grid.origin) - voxel / 2
            again = Volume.from_bounds(low, low + voxel * np.asarray(grid.shape), voxel)
            assert again.shape == grid.shape and np.allclose(again.origin, grid.origin)
            grid = again
    # over by 0.025 voxel
    assert Volume.from_bounds([0, 0, 0], [0.0401, 0.04, 0.04], 0.004).shape == (11, 10, 10)


def test_around_a_cloud_with_margin():
    v = Volume.around(np.array([[0, 0, 2], [0.2, 0.1, 2.3]]), 0.002, 0.02)
    assert v.shape == (120, 70, 170)
    with pytest.raises(MirrorscanError, match="no points"):
        Volume.around(np.empty((0, 3)), 0.002, 0.02)


@pytest.mark.parametrize("args, match", [(((0, 0, 0), 0.0, (1, 1, 1)), "voxel size"),
                                         (((0, 0, 0), 0.01, (0, 1, 1)), "at least one voxel"),
                                         (((0, 0, 0), 0.01, (100_000, 100_000, 10_000)),
                                          "more than")])
def test_a_bad_volume_is_refused_by_name(args, match):
    with pytest.raises(MirrorscanError, match=match):
        Volume(*args)


@pytest.fixture
def volume():
    """10 x 6 x 9 voxels: blocks of 4 reach past the grid on every axis."""
    return Volume((0.0, 0.0, 1.0), 0.01, (10, 6, 9))


def test_blocks_cover_the_grid_and_lay_out_their_voxels(volume):
    blocks = Blocks.all(volume, 4)
    assert volume.block_shape(4) == (3, 2, 3) and volume.padded_shape(4) == (12, 8, 12) and len(
        blocks) == 18
    assert blocks.voxels == 18 * 64 and blocks.keys.tolist() == list(range(18))
    x, y, z = blocks.axes()
    assert x.shape == (4, 1, 1, 18) and y.shape == (1, 4, 1, 18) and z.shape == (1, 1, 4, 18)
    # block (2, 1, 2): voxels 8..11, 4..7, 8..11
    r = 17
    assert blocks.ijk[r].tolist() == [2, 1, 2]
    xs, ys, zs = (np.asarray(volume.axes()[a], np.float32) for a in range(3))
    np.testing.assert_array_equal(x[:2, 0, 0, r], xs[8:10])
    np.testing.assert_array_equal(y[0, :2, 0, r], ys[4:6])
    np.testing.assert_array_equal(z[0, 0, :1, r], zs[8:9])
    assert np.isnan(x[2:, 0, 0, r]).all() and np.isnan(y[0, 2:, 0, r]).all() and np.isnan(z[
        0, 0, 1:, r]).all()
    # the box of its voxel centres inside the grid
    centre, half = blocks.bounds()
    np.testing.assert_allclose(centre[:, r] - half[:, r], [0.08, 0.04, 1.08])
    np.testing.assert_allclose(centre[:, r] + half[:, r], [0.09, 0.05, 1.08])
    chunks = blocks.chunks(max_voxels=64 * 5)
    assert [len(range(18)[c]) for c in chunks] == [5, 5, 5, 3]


def test_block_values_land_on_their_voxels(volume):
    blocks = Blocks.all(volume, 4).take(np.array([0, 17]))
    values = np.arange(2 * 64, dtype=np.int32).reshape(2, 4, 4, 4)            # block-major
    grid = padded_grid(volume, -1, np.int32, 4)
    # the block layout (B, B, B, m)
    blocks.write(grid, np.moveaxis(values, 0, -1))
    assert grid[1, 2, 3] == values[0, 1, 2, 3] and grid[9, 5, 8] == values[1, 1, 1, 0]
    assert (grid == -1).sum() == grid.size - 128
    assert cropped(volume, grid).shape == (10, 6, 9)


@pytest.mark.parametrize("workers", [1, 2])
def test_runner_calls_every_chunk_once_then_cancels(workers):
    seen, lock, fractions = [], threading.Lock(), []

    def work(item):
        with lock:
            seen.append(item)
    run_chunks(list(range(7)), work, fractions.append, workers=workers)
    assert sorted(seen) == list(range(7))
    assert fractions == [k / 7 for k in range(1, 8)]
    stop = threading.Event()
    with pytest.raises(Cancelled, match="stopped after"):
        run_chunks(list(range(50)), lambda item: stop.set(), cancel=stop, workers=workers)


def test_runner_passes_errors_on():
    def work(item):
        raise ValueError(f"bad {item}")
    with pytest.raises(ValueError, match="bad"):
        run_chunks([1, 2, 3], work, workers=2)
