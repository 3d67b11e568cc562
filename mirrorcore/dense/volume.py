"""The voxel grid of dense reconstruction: an axis-aligned volume in the camera frame, its bounding box from a cloud,
its slabs (chunks) processed in parallel with a progress callback and cancellation."""
from __future__ import annotations

import os
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..budget import check_memory
from ..errors import Cancelled, MirrorscanError
from ..progress import Progress, cancel_requested

VOXEL_BYTES = 20                  # peak bytes per voxel of the costliest method: TSDF with its mesh measured 16.3
CHUNK_VOXELS = 1 << 18            # voxels per slab: temporaries stay in the CPU caches and memory stays bounded

NO_SOURCE = 255   # the source grids' value for voxels that no view labels


@dataclass(frozen=True)
class Volume:
    """Voxel (i, j, k) has its centre at origin + voxel * (i, j, k): x along i, y along j, z along k (camera frame,
    metres). Grids of the volume are (nx, ny, nz) arrays indexed [i, j, k].

    origin : (3,) metres, centre of voxel (0, 0, 0); voxel : edge in metres; shape : (nx, ny, nz).
    Raises MirrorscanError for a non-positive voxel size or an empty shape, MemoryBudgetError when the grids of a
    reconstruction (VOXEL_BYTES a voxel) would not fit in the memory budget (mirrorcore.budget).
    """

    origin: tuple[float, float, float]
    voxel: float
    shape: tuple[int, int, int]

    def __post_init__(self) -> None:
        if not (np.isfinite(self.voxel) and self.voxel > 0):
            raise MirrorscanError(f"volume: the voxel size must be positive, got {self.voxel}")
        if len(self.shape) != 3 or min(self.shape) < 1:
            raise MirrorscanError(f"volume: the grid needs at least one voxel per axis, got {self.shape}")
        check_memory(float(np.prod(np.asarray(self.shape, float))) * VOXEL_BYTES,
                     f"volume: {'x'.join(str(int(s)) for s in self.shape)} voxels of {self.voxel * 1e3:g} mm "
                     "(use larger voxels or a smaller box)")
        object.__setattr__(self, "origin", tuple(float(o) for o in self.origin))
        object.__setattr__(self, "shape", tuple(int(s) for s in self.shape))

    @classmethod
    def from_bounds(cls, lo, hi, voxel: float) -> "Volume":
        """The grid of `voxel`-sized cells covering the box lo..hi ((3,) metres, camera frame)."""
        lo, hi = np.asarray(lo, float).reshape(3), np.asarray(hi, float).reshape(3)
        if not np.all(hi > lo):
            raise MirrorscanError(f"volume: the box's upper corner {hi.tolist()} must exceed its lower {lo.tolist()}")
        shape = np.maximum(np.ceil((hi - lo) / voxel).astype(int), 1)
        return cls(tuple(lo + voxel / 2), voxel, tuple(shape))

    @classmethod
    def around(cls, points: np.ndarray, voxel: float, margin: float) -> "Volume":
        """The bounding box of points (n, 3) metres, camera frame, grown by `margin` metres on every side.
        Raises MirrorscanError when there are no points."""
        points = np.asarray(points, float).reshape(-1, 3)
        if not len(points):
            raise MirrorscanError("volume: no points to take a bounding box of (is the object in view?)")
        return cls.from_bounds(points.min(0) - margin, points.max(0) + margin, voxel)

    @property
    def size(self) -> int:
        """Number of voxels."""
        return int(np.prod(self.shape, dtype=np.int64))

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The voxel centres along x, y, z: three 1-D float64 arrays (nx,), (ny,), (nz,), metres."""
        return tuple(o + self.voxel * np.arange(n) for o, n in zip(self.origin, self.shape))

    def centres(self, flat_index: np.ndarray) -> np.ndarray:
        """flat_index : (n,) int, C-order indices into the (nx, ny, nz) grid -> (n, 3) float32 centres, metres."""
        ijk = np.stack(np.unravel_index(flat_index, self.shape), axis=-1)
        return (np.asarray(self.origin) + self.voxel * ijk).astype(np.float32)

    def nearest_index(self, points: np.ndarray) -> np.ndarray:
        """points (n, 3) metres -> (n,) int64 C-order index of the nearest voxel (clipped to the grid)."""
        ijk = np.rint((np.asarray(points, float).reshape(-1, 3) - self.origin) / self.voxel).astype(np.int64)
        return np.ravel_multi_index(tuple(np.clip(ijk, 0, np.array(self.shape) - 1).T), self.shape)

    def slab_points(self, slab: slice, local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """C-order indices (n,) int64 into the grid and centres (3, n) float32 (rows x, y, z, metres) of the voxels of
        slab `slab` (see `slabs`) at flat indices `local` (n,) within the slab."""
        index = local + slab.start * self.shape[1] * self.shape[2]
        ijk = np.unravel_index(index, self.shape)
        return index, np.stack([(o + self.voxel * i).astype(np.float32) for o, i in zip(self.origin, ijk)])

    def slabs(self, max_voxels: int = CHUNK_VOXELS) -> list[slice]:
        """Slices along x (axis 0) of at most max(max_voxels, one x-plane) voxels each, covering the grid."""
        step = max(1, max_voxels // (self.shape[1] * self.shape[2]))
        return [slice(i, min(i + step, self.shape[0])) for i in range(0, self.shape[0], step)]


def run_slabs(volume: Volume, work: Callable[[slice], None], progress: Progress | None = None,
              cancel=None, workers: int | None = None) -> None:
    """Call work(slab) for every slab of the volume on `workers` threads (default: the CPU count; numpy releases the
    GIL in its array operations), at most `workers` slabs at a time so that memory stays bounded.

    progress(fraction) is called in this thread after each slab (0 < fraction <= 1). cancel is polled before each
    slab starts: the running slabs finish, then Cancelled is raised. Exceptions of `work` propagate.
    """
    slabs = volume.slabs()
    workers = max(1, workers or os.cpu_count() or 1)
    done = 0
    with ThreadPoolExecutor(max_workers=workers) as pool:
        pending: set[Future] = set()
        todo = iter(slabs)
        try:
            while True:
                while len(pending) < workers and not cancel_requested(cancel):
                    slab = next(todo, None)
                    if slab is None:
                        break
                    pending.add(pool.submit(work, slab))
                if not pending:
                    break
                finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in finished:
                    future.result()
                    done += 1
                    if progress is not None:
                        progress(done / len(slabs))
        finally:
            wait(pending)
    if done < len(slabs):
        raise Cancelled(f"stopped after {done} of {len(slabs)} slabs")
