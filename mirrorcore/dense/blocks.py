"""Sets of blocks of a volume (cubes of B^3 voxels, mirrorcore.dense.volume): the centres of their
voxels in the block layout (B, B, B, m), their bounds, chunks of them for the runner, and writing
their voxels in grids over the padded volume.

In the block layout the voxel [i, j, k] of block r (x along i, y along j, z along k, as in the grid)
is at [i, j, k, r], and the voxel centres come as three arrays that broadcast to (B, B, B, m): x (B,
1, 1, m), y (1, B, 1, m), z (1, 1, B, m). A computation that depends on x and z only (a pixel column
of the camera) is then done on (B, 1, B, m) values; the block index is the innermost axis so that
numpy's broadcast loops run along it, not along 8 voxels."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirrorcore.dense.volume import CHUNK_VOXELS, Volume


@dataclass(frozen=True, eq=False)
class Blocks:
    """Some blocks of `volume` of size^3 voxels each: ijk (m, 3) int64 block coordinates, unique (in
    C order of the block grid unless said otherwise)."""

    volume: Volume
    ijk: np.ndarray
    size: int

    @classmethod
    def all(cls, volume: Volume, size: int) -> "Blocks":
        """Every block of the volume."""
        return cls.marked(volume, np.ones(volume.block_shape(size), bool), size)

    @classmethod
    def marked(cls, volume: Volume, marks: np.ndarray, size: int) -> "Blocks":
        """The blocks where marks (volume.block_shape(size)) bool holds."""
        return cls(volume, np.argwhere(marks).astype(np.int64).reshape(-1, 3), size)

    def __len__(self) -> int:
        return len(self.ijk)

    @property
    def voxels(self) -> int:
        """Voxels in the block layout (padding past the volume included): len * size^3."""
        return len(self) * self.size ** 3

    @property
    def keys(self) -> np.ndarray:
        """(m,) int64 the blocks' C-order indices in the block grid."""
        return np.ravel_multi_index(tuple(self.ijk.T), self.volume.block_shape(self.size))

    def take(self, rows) -> "Blocks":
        """The blocks at `rows` (a slice, (k,) int indices or (m,) bool)."""
        return Blocks(self.volume, self.ijk[rows], self.size)

    def chunks(self, max_voxels: int = CHUNK_VOXELS) -> list[slice]:
        """Consecutive row ranges of at most max(max_voxels, one block) voxels each, covering the
        blocks."""
        step = max(1, max_voxels // self.size ** 3)
        return [slice(i, min(i + step, len(self))) for i in range(0, len(self), step)]

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The voxel centres, float32 metres (camera frame), NaN past the volume: x (B, 1, 1, m), y
        (1, B, 1, m), z (1, 1, B, m), the same values as Volume.axes() cast to float32."""
        b, m = self.size, len(self)
        local = np.arange(b)[:, None]
        x, y, z = (a[local + self.ijk[None, :, r] * b] for r,
                   a in enumerate(self.volume.padded_axes(b)))
        return x.reshape(b, 1, 1, m), y.reshape(1, b, 1, m), z.reshape(1, 1, b, m)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The box of each block's voxel centres inside the volume: centre (3, m) and half size (3,
        m), float64 metres (x, y, z rows)."""
        volume = self.volume
        first = self.ijk * self.size
        last = np.minimum(first + self.size - 1, np.asarray(volume.shape) - 1)
        centre = np.asarray(volume.origin)[:, None] + volume.voxel * (first + last).T / 2
        return centre, volume.voxel * (last - first).T / 2

    def write(self, grid: np.ndarray, values) -> None:
        """Set these blocks' voxels of `grid` (volume.padded_shape(size), C-contiguous) to values
        ((B, B, B, m), the block layout, or a scalar)."""
        a, b, c = self.ijk.T
        s = self.size
        grid.reshape(grid.shape[0] // s, s, grid.shape[1] // s, s, grid.shape[2] // s, s)[
            a, :, b, :, c, :] = \
            np.moveaxis(values, -1, 0) if np.ndim(values) else values


def padded_grid(volume: Volume, fill, dtype, block: int) -> np.ndarray:
    """A C-contiguous grid of volume.padded_shape(block) filled with `fill`."""
    return np.full(volume.padded_shape(block), fill, dtype)


def cropped(volume: Volume, grid: np.ndarray) -> np.ndarray:
    """The (nx, ny, nz) part of a padded grid (a view)."""
    nx, ny, nz = volume.shape
    return grid[:nx, :ny, :nz]
