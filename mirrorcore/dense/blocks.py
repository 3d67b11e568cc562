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
    """Some blocks of a volume, of size^3 voxels each.

    Attributes
    ----------
    volume : Volume
    ijk : (m, 3) int64 array
        Block coordinates, unique (in C order of the block grid unless said otherwise).
    size : int
        Voxels along a block's edge.
    """

    volume: Volume
    ijk: np.ndarray
    size: int

    @classmethod
    def all(cls, volume: Volume, size: int) -> "Blocks":
        """Return every block of the volume.

        Parameters
        ----------
        volume : Volume
        size : int
            Voxels along a block's edge.

        Returns
        -------
        Blocks
        """
        return cls.marked(volume, np.ones(volume.block_shape(size), bool), size)

    @classmethod
    def marked(cls, volume: Volume, marks: np.ndarray, size: int) -> "Blocks":
        """Return the blocks where `marks` holds.

        Parameters
        ----------
        volume : Volume
        marks : bool array of volume.block_shape(size)
        size : int
            Voxels along a block's edge.

        Returns
        -------
        Blocks
        """
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
        """Return the blocks at `rows`.

        Parameters
        ----------
        rows : slice, (k,) integer array or (m,) bool array

        Returns
        -------
        Blocks
        """
        return Blocks(self.volume, self.ijk[rows], self.size)

    def chunks(self, max_voxels: int = CHUNK_VOXELS) -> list[slice]:
        """Split the blocks into consecutive row ranges.

        Parameters
        ----------
        max_voxels : int
            The most voxels a range holds (at least one block).

        Returns
        -------
        list of slice
            Covering the blocks.
        """
        step = max(1, max_voxels // self.size ** 3)
        return [slice(i, min(i + step, len(self))) for i in range(0, len(self), step)]

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return the voxel centres, float32 metres (camera frame), NaN past the volume.

        The same values as Volume.axes() cast to float32.

        Returns
        -------
        x : (B, 1, 1, m) float32 array
        y : (1, B, 1, m) float32 array
        z : (1, 1, B, m) float32 array
        """
        b, m = self.size, len(self)
        local = np.arange(b)[:, None]
        x, y, z = (a[local + self.ijk[None, :, r] * b] for r,
                   a in enumerate(self.volume.padded_axes(b)))
        return x.reshape(b, 1, 1, m), y.reshape(1, b, 1, m), z.reshape(1, 1, b, m)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Return the box of each block's voxel centres inside the volume.

        Returns
        -------
        centre : (3, m) float64 array
            Metres, rows x, y, z.
        half : (3, m) float64 array
            Half size, metres.
        """
        volume = self.volume
        first = self.ijk * self.size
        last = np.minimum(first + self.size - 1, np.asarray(volume.shape) - 1)
        centre = np.asarray(volume.origin)[:, None] + volume.voxel * (first + last).T / 2
        return centre, volume.voxel * (last - first).T / 2

    def write(self, grid: np.ndarray, values) -> None:
        """Set these blocks' voxels of a grid.

        Parameters
        ----------
        grid : array of volume.padded_shape(size)
            C-contiguous.
        values : (B, B, B, m) array or scalar
            In the block layout.
        """
        a, b, c = self.ijk.T
        s = self.size
        grid.reshape(grid.shape[0] // s, s, grid.shape[1] // s, s, grid.shape[2] // s, s)[
            a, :, b, :, c, :] = \
            np.moveaxis(values, -1, 0) if np.ndim(values) else values


def padded_grid(volume: Volume, fill, dtype, block: int) -> np.ndarray:
    """Return a C-contiguous grid of volume.padded_shape(block) filled with `fill`.

    Parameters
    ----------
    volume : Volume
    fill : scalar
    dtype : numpy dtype
    block : int
        Voxels along a block's edge.

    Returns
    -------
    array
    """
    return np.full(volume.padded_shape(block), fill, dtype)


def cropped(volume: Volume, grid: np.ndarray) -> np.ndarray:
    """Return the (nx, ny, nz) part of a padded grid (a view).

    Parameters
    ----------
    volume : Volume
    grid : array
        Padded to whole blocks.

    Returns
    -------
    (nx, ny, nz) array
    """
    nx, ny, nz = volume.shape
    return grid[:nx, :ny, :nz]
