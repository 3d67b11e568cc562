"""The voxel grid of dense reconstruction: an axis-aligned volume in the camera frame, its bounding
box from a cloud, its blocks (cubes of b^3 voxels, the unit of sparse work; each method picks b),
and the runner that processes chunks of work in parallel with a progress callback and
cancellation."""
from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from mirrorcore.base.budget import check_memory
from mirrorcore.base.errors import Cancelled, MirrorscanError
from mirrorcore.base.progress import Progress, cancel_requested

# voxels along the edge of the smallest blocks a method uses (fusion)
SMALLEST_BLOCK = 4
# voxels per chunk of work: temporaries stay in the CPU caches, memory bounded
CHUNK_VOXELS = 1 << 16
QUEUED_PER_WORKER = 2             # chunks submitted at a time per worker thread
# bytes per smallest block of the whole grid a method may hold (coordinates, marks)
BLOCK_GRID_BYTES = 24

# a box this little (in voxels) over a whole number of voxels is that number of voxels
WHOLE_VOXELS = 1e-6
NO_SOURCE = 255   # the source grids' value for voxels that no view labels
Item = TypeVar("Item")


@dataclass(frozen=True)
class Volume:
    """A voxel grid in the camera frame.

    Voxel (i, j, k) has its centre at origin + voxel * (i, j, k): x along i, y along j, z along k
    (camera frame, metres). Grids of the volume are (nx, ny, nz) arrays indexed [i, j, k]. With
    blocks of b^3 voxels, block (p, q, r) holds the voxels [p b, (p + 1) b) x [q b, (q + 1) b) x
    [r b, (r + 1) b); the blocks on the far faces reach past the grid. Each method checks what it
    allocates besides (`check_grids`, the TSDF's blocks), before allocating it.

    Attributes
    ----------
    origin : (float, float, float)
        Metres, centre of voxel (0, 0, 0).
    voxel : float
        Edge, metres.
    shape : (int, int, int)
        (nx, ny, nz).

    Raises
    ------
    MirrorscanError
        A non-positive voxel size or an empty shape.
    MemoryBudgetError
        The grid's smallest blocks (BLOCK_GRID_BYTES a block) would not fit in the memory budget
        (mirrorcore.base.budget).
    """

    origin: tuple[float, float, float]
    voxel: float
    shape: tuple[int, int, int]

    def __post_init__(self) -> None:
        if not (np.isfinite(self.voxel) and self.voxel > 0):
            raise MirrorscanError(f"volume: the voxel size must be positive, got {self.voxel}")
        if len(self.shape) != 3 or min(self.shape) < 1:
            raise MirrorscanError(
                f"volume: the grid needs at least one voxel per axis, got {self.shape}")
        object.__setattr__(self, "origin", tuple(float(o) for o in self.origin))
        object.__setattr__(self, "shape", tuple(int(s) for s in self.shape))
        check_memory(float(np.prod(np.asarray(self.block_shape(SMALLEST_BLOCK),
                                              float))) * BLOCK_GRID_BYTES,
                     self._what())

    @classmethod
    def from_bounds(cls, lo, hi, voxel: float) -> "Volume":
        """Return the grid of `voxel`-sized cells covering a box.

        A box a whole number of voxels wide, up to rounding, keeps that number: the box of a grid
        gives the same grid back.

        Parameters
        ----------
        lo, hi : (3,) array
            The box's corners, metres, camera frame.
        voxel : float
            Metres.

        Returns
        -------
        Volume
        """
        lo, hi = np.asarray(lo, float).reshape(3), np.asarray(hi, float).reshape(3)
        if not np.all(hi > lo):
            raise MirrorscanError(
                f"volume: the box's upper corner {hi.tolist()} must exceed its lower {lo.tolist()}")
        shape = np.maximum(np.ceil((hi - lo) / voxel - WHOLE_VOXELS).astype(int), 1)
        return cls(tuple(lo + voxel / 2), voxel, tuple(shape))

    @classmethod
    def around(cls, points: np.ndarray, voxel: float, margin: float) -> "Volume":
        """Return the bounding box of points grown by `margin` on every side.

        Parameters
        ----------
        points : (n, 3) array
            Metres, camera frame.
        voxel : float
            Metres.
        margin : float
            Metres.

        Returns
        -------
        Volume

        Raises
        ------
        MirrorscanError
            There are no points.
        """
        points = np.asarray(points, float).reshape(-1, 3)
        if not len(points):
            raise MirrorscanError(
                "volume: no points to take a bounding box of (is the object in view?)")
        return cls.from_bounds(points.min(0) - margin, points.max(0) + margin, voxel)

    @property
    def size(self) -> int:
        """Number of voxels."""
        return int(np.prod(self.shape, dtype=np.int64))

    def block_shape(self, block: int) -> tuple[int, int, int]:
        """Return the number of blocks of block^3 voxels along x, y, z: ceil(shape / block).

        Parameters
        ----------
        block : int

        Returns
        -------
        (int, int, int)
        """
        return tuple(-(-int(s) // block) for s in self.shape)

    def padded_shape(self, block: int) -> tuple[int, int, int]:
        """Return the grid's shape grown to whole blocks of block^3 voxels.

        Parameters
        ----------
        block : int

        Returns
        -------
        (int, int, int)
        """
        return tuple(block * b for b in self.block_shape(block))

    def check_grids(self, voxel_bytes: float, what: str, block: int) -> None:
        """Refuse grids that would not fit in the memory budget.

        Parameters
        ----------
        voxel_bytes : float
            Bytes a voxel of the grid padded to whole blocks.
        what : str
            The grids, for the message.
        block : int
            Voxels along a block's edge.

        Raises
        ------
        MemoryBudgetError
            Naming the volume and `what`.
        """
        check_memory(float(np.prod(np.asarray(self.padded_shape(block), float))) * voxel_bytes,
                     f"{self._what()}: {what}")

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The voxel centres along x, y, z: three 1-D float64 arrays (nx,), (ny,), (nz,), metres."""
        return tuple(o + self.voxel * np.arange(n) for o, n in zip(self.origin, self.shape))

    def padded_axes(self, block: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return the voxel centres along x, y, z of the grid padded to whole blocks.

        Parameters
        ----------
        block : int

        Returns
        -------
        x, y, z : float32 array
            Metres, NaN past the volume.
        """
        return tuple(np.concatenate([a.astype(np.float32), np.full(p - len(a), np.nan, np.float32)])
                     for a, p in zip(self.axes(), self.padded_shape(block)))

    def corners(self) -> np.ndarray:
        """(8, 3) float64 metres: the corners of the box of the voxel centres."""
        lo = np.asarray(self.origin)
        hi = lo + self.voxel * (np.asarray(self.shape) - 1)
        return np.stack(np.meshgrid(*np.stack([lo, hi]).T, indexing="ij"), axis=-1).reshape(-1, 3)

    def centres(self, flat_index: np.ndarray) -> np.ndarray:
        """Return the centres of voxels.

        Parameters
        ----------
        flat_index : (n,) integer array
            C-order indices into the (nx, ny, nz) grid.

        Returns
        -------
        (n, 3) float32 array
            Metres.
        """
        ijk = np.stack(np.unravel_index(flat_index, self.shape), axis=-1)
        return (np.asarray(self.origin) + self.voxel * ijk).astype(np.float32)

    def nearest_index(self, points: np.ndarray) -> np.ndarray:
        """Return the C-order index of the nearest voxel of points (clipped to the grid).

        Parameters
        ----------
        points : (n, 3) array
            Metres, camera frame.

        Returns
        -------
        (n,) int64 array
        """
        ijk = np.rint((np.asarray(points, float).reshape(-1, 3) - self.origin) / self.voxel).astype(
            np.int64)
        return np.ravel_multi_index(tuple(np.clip(ijk, 0, np.array(self.shape) - 1).T), self.shape)

    def _what(self) -> str:
        """The volume in words, for a memory budget message."""
        return (f"volume: {'x'.join(str(int(s)) for s in self.shape)} voxels of "
                f"{self.voxel * 1e3:g} mm "
                "(use larger voxels or a smaller box)")


def run_chunks(items: Sequence[Item], work: Callable[[Item], None],
               progress: Progress | None = None,
               cancel=None, workers: int | None = None) -> None:
    """Call work(item) for every item, in this thread for one worker, else on `workers` threads.

    On threads, at most QUEUED_PER_WORKER items per thread are submitted at a time, so that memory
    stays bounded and no thread waits for the next item (numpy releases the GIL in its array
    operations).

    Parameters
    ----------
    items : sequence
    work : callable
        Called with each item. Its exceptions propagate.
    progress : Progress, optional
        progress(fraction) is called in this thread after each item (0 < fraction <= 1).
    cancel : threading.Event or callable, optional
        Asks to stop when set or when it returns True.
        Polled before each item starts (is submitted): the running items finish, then Cancelled is
        raised.
    workers : int, optional
        Default: the CPU count.

    Raises
    ------
    Cancelled
    """
    workers = max(1, workers or os.cpu_count() or 1)
    done = 0

    def finished_one() -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done / len(items))

    if workers == 1:
        for item in items:
            if cancel_requested(cancel):
                break
            work(item)
            finished_one()
    else:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            pending: set[Future] = set()
            todo = iter(items)
            try:
                while True:
                    while len(pending) < QUEUED_PER_WORKER * workers and not cancel_requested(
                        cancel):
                        item = next(todo, None)
                        if item is None:
                            break
                        pending.add(pool.submit(work, item))
                    if not pending:
                        break
                    finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                    for future in finished:
                        future.result()
                        finished_one()
            finally:
                for future in pending:
                    future.cancel()
                wait(pending)
    if done < len(items):
        raise Cancelled(f"stopped after {done} of {len(items)} chunks")
