"""Space carving of a voxel volume with the camera and its mirrors (the paper's Algorithm 2, and a
consistent carving).

How we read Algorithm 2 (method "paper", followed line by line): a voxel v of the volume in front of
the mirrors is projected to its nearest pixel p. If p is not an object pixel, v is removed.
Otherwise v is kept when its distance to the camera |v| is within th of |P|, P the reprojection of p
at its measured depth (the camera sees v's surface). Otherwise v is reflected through every mirror j
in turn; it is removed as soon as one reflection v_j projects off the object pixels, outside mirror
j's boundary, or with | |v_j| - |P_j| | >= th (the `break`). So a voxel that the camera does not see
on the surface survives only if EVERY mirror sees it on the surface; the loop's order and its
`break` change nothing but the work done. The prose ("removed if the deviation condition is not
satisfied with at least one mirror") says the same. Voxels behind a mirror plane are outside the
volume "in front of the mirrors" and removed. Note what follows: a surface seen by one mirror only
is lost wherever the camera does not see it, and the kept set is a shell 2 th thick around the
measured surfaces (the paper's "thicker surface"). *Extension*: the views through several mirrors in
turn (mirrorcore.dense.views) are virtual cameras like the mirrors' and join the loop, with their
outline (the pixels whose ray meets their mirrors in turn) as the mirror's boundary: read as
written, a voxel the camera does not see must then be seen by every one of them too, so "paper"
keeps little beyond the camera's view in a kaleidoscope.

Method "carve" (consistent carving): a voxel is removed (FREE) when any view, the camera or a
virtual camera (a mirror, or a sequence of mirrors), sees through it: its depth in that view is less
than the measured depth minus th. It is kept (SURFACE) when no view sees through it and at least one
view shows the object's surface within th of it. A voxel that no view sees through and none sees on
the surface (inside the object, or behind it from every view) is HIDDEN: neither carved nor kept as
surface (SURFACE | HIDDEN is the carved solid). Depth is sampled bilinearly (sub-pixel, as the paper
suggests for the sparse mirror regions) where the four pixels around a point show the surface with
no depth edge.

Both methods work on chunks of blocks of BLOCK^3 voxels (mirrorcore.dense.blocks). Method "carve"
first decides whole blocks (mirrorcore.dense.windows): a block that some view sees through, or that
lies behind a mirror, is FREE; a block in front of every mirror that every view sees behind its
surface by more than th (or not at all) is HIDDEN; only the other blocks, those near a measured
surface or a silhouette, are carved voxel by voxel, with the same result.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from mirrorcore.base.budget import check_memory
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.rig.model import Rig
from mirrorcore.dense.blocks import Blocks, cropped, padded_grid
from mirrorcore.dense.colour import CARVE_COLOUR_BYTES, colour_frames, voxel_colours
from mirrorcore.dense.sampling import (QuadTable, in_front_of_mirrors, nearest_pixels, pixel_index,
                                       project, project_blocks, transform)
from mirrorcore.dense.views import View, padded_flat, rig_views
from mirrorcore.dense.volume import NO_SOURCE, Progress, Volume, run_chunks
from mirrorcore.dense.windows import Window, mirror_sides, window_half

FREE, SURFACE, HIDDEN = 0, 1, 2          # voxel states
METHODS = ("paper", "carve")
# voxels along a block's edge (larger blocks decide more of the volume at once)
BLOCK = 8
CARVE_VOXEL_BYTES = 2                    # the state and source grids
DECIDE_BLOCKS = 1 << 16                  # blocks decided whole in one go


@dataclass(frozen=True, eq=False)
class CarveResult:
    """A carved volume.

    The grids are views of grids over the volume padded to whole blocks.

    Attributes
    ----------
    volume : Volume
    state : (nx, ny, nz) uint8 array
        FREE / SURFACE / HIDDEN.
    source : (nx, ny, nz) uint8 array
        The view (0 camera, j mirror j, from 33 a sequence of mirrors) that sees a SURFACE voxel
        nearest to its centre, NO_SOURCE elsewhere.
    method : str
    threshold : float
        th, metres.
    colours : (n, 3) uint8 array or None
        Carved with a colour image: the SURFACE voxels' colours (in the order of
        `surface_points`) from the views that see them (mirrorcore.dense.colour.voxel_colours);
        None without.
    """

    volume: Volume
    state: np.ndarray
    source: np.ndarray
    method: str
    threshold: float
    colours: np.ndarray | None = None

    def surface_points(self) -> tuple[np.ndarray, np.ndarray]:
        """Return the SURFACE voxels' centres and their sources.

        Returns
        -------
        points : (n, 3) float32 array
            Metres, camera frame.
        sources : (n,) uint8 array
        """
        index = np.flatnonzero(self.state.reshape(-1) == SURFACE)
        return self.volume.centres(index), self.source.reshape(-1)[index]


def carve(rig: Rig, depth: np.ndarray, mask: np.ndarray, volume: Volume, method: str = "carve",
          threshold: float | None = None, progress: Progress | None = None, cancel=None,
          workers: int | None = None, colour: np.ndarray | None = None) -> CarveResult:
    """Carve a volume with one depth frame (see the module docstring for the methods).

    Parameters
    ----------
    rig : Rig
    depth : (H, W) float array
        Metres, 0 = no reading.
    mask : (H, W) bool array
        The object's pixels (direct and in mirrors).
    volume : Volume
    method : str
    threshold : float, optional
        th, metres (default: the voxel size).
    progress : Progress, optional
        progress(fraction) after each chunk of blocks.
    cancel : threading.Event or callable, optional
        Asks to stop when set or when it returns True.
    workers : int, optional
        Threads (default the CPU count).
    colour : (H, W, 3) uint8 array, optional
        The frame's colour registered to its depth: the kept voxels are coloured from it.

    Returns
    -------
    CarveResult

    Raises
    ------
    Cancelled
        When stopped (nothing is returned).
    MirrorscanError
        An unknown method or a non-positive threshold.
    MemoryBudgetError
        The grids would not fit in the memory budget.
    """
    if method not in METHODS:
        raise MirrorscanError(
            f"carve: unknown method {method!r} (expected one of {', '.join(METHODS)})")
    th = volume.voxel if threshold is None else float(threshold)
    if not th > 0:
        raise MirrorscanError(f"carve: the threshold must be positive, got {threshold}")
    volume.check_grids(CARVE_VOXEL_BYTES, "the carving's state and source grids", BLOCK)
    image = None if colour is None else colour_frames(rig.intrinsics, colour, 1)[0]
    views = rig_views(rig, depth, mask)
    state = padded_grid(volume, FREE, np.uint8, BLOCK)
    source = padded_grid(volume, NO_SOURCE, np.uint8, BLOCK)
    blocks = Blocks.all(volume, BLOCK)
    if method == "paper":
        images = _PaperImages.of(rig, depth, mask)

        def voxels(chunk: Blocks) -> tuple[np.ndarray, np.ndarray]:
            return _paper_voxels(rig, views, images, th, chunk)
    else:
        blocks = _undecided_blocks(rig, views, th, blocks, state)
        tables = [QuadTable.of([view.quads]) for view in views]
        # made here once, not by each worker thread
        lows = [view.quads.low for view in views]

        def voxels(chunk: Blocks) -> tuple[np.ndarray, np.ndarray]:
            return _carve_voxels(rig, views, tables, lows, th, chunk)

    def work(rows: slice) -> None:
        chunk = blocks.take(rows)
        states, sources = voxels(chunk)
        chunk.write(state, states)
        chunk.write(source, sources)

    run_chunks(blocks.chunks(), work, progress, cancel, workers)
    result = CarveResult(volume, cropped(volume, state), cropped(volume, source), method, th)
    if image is None:
        return result
    points, sources = result.surface_points()
    check_memory(len(points) * CARVE_COLOUR_BYTES,
                 f"carve: the colours of {len(points):,} surface voxels")
    return replace(result, colours=voxel_colours(rig, views, image, points, sources, th))


@dataclass(frozen=True, eq=False)
class _PaperImages:
    """Flat (H*W + 1,) per-pixel inputs of Algorithm 2 (pad cell last): `object` the object pixels
    {p}_n, `distance` |P| = Z |ray| the measured distance to the camera (each view's outline is
    View.outline)."""

    object: np.ndarray
    distance: np.ndarray

    @classmethod
    def of(cls, rig: Rig, depth: np.ndarray, mask: np.ndarray) -> "_PaperImages":
        rays = rig.intrinsics.rays
        z = np.asarray(depth, np.float32)
        return cls(padded_flat(np.asarray(mask, bool) & (z > 0), False),
                   padded_flat(z * np.sqrt(rays[0] ** 2 + rays[1] ** 2 + 1), np.nan))


def _undecided_blocks(rig: Rig, views: tuple[View, ...], th: float, blocks: Blocks,
                      state: np.ndarray) -> Blocks:
    """Method 'carve' on whole blocks (mirrorcore.dense.windows), in batches of DECIDE_BLOCKS: FREE
    where some view sees through the block or it lies behind a mirror (as the grid starts), HIDDEN
    (written into `state`) where it lies in front of every mirror and every view sees it behind its
    surface by more than th -> the other blocks."""
    intr, volume = rig.intrinsics, blocks.volume
    extent = (BLOCK - 1) * volume.voxel
    windows = [Window.for_carving(v, window_half(intr, v.to_view, volume.corners(), extent))
               for v in views]
    undecided = []
    for start in range(0, len(blocks), DECIDE_BLOCKS):
        batch = blocks.take(slice(start, start + DECIDE_BLOCKS))
        box = batch.bounds()
        free, behind = np.zeros(len(batch), bool), np.ones(len(batch), bool)
        for window in windows:
            sees_through, sees_behind = window.test(intr, box, th)
            free |= sees_through
            behind &= sees_behind
        behind_a_mirror, in_front = mirror_sides(rig, box)
        free |= behind_a_mirror
        behind &= in_front
        batch.take(~free & behind).write(state, HIDDEN)
        undecided.append(batch.ijk[~free & ~behind])
    return Blocks(volume, np.concatenate(undecided), BLOCK)


def _carve_voxels(rig: Rig, views: tuple[View, ...], tables: list[QuadTable],
                  lows: list[np.ndarray], th: float,
                  blocks: Blocks) -> tuple[np.ndarray, np.ndarray]:
    """Method 'carve' voxel by voxel on blocks -> their state, source (B, B, B, m) uint8 (the block
    layout); tables
    and lows : each view's QuadTable and Quads.low. The camera's 3x3-minimum depth at each voxel's
    nearest pixel carves what it sees through even with sub-pixel lookup, and voxels behind a mirror
    are FREE; then every view's test, on its depth d: bilinear where the voxel's quad shows the
    surface (NaN elsewhere), else the quad's least depth, which is never more than the bilinear one
    (so testing both against the voxel carves the same)."""
    intr = rig.intrinsics
    x, y, z = blocks.axes()
    free = ~(z >= views[0].cull_depth[nearest_pixels(intr, x, y, z)] - np.float32(th))
    free = (free | ~in_front_of_mirrors(rig, x, y, z)).reshape(-1)
    best = np.full(free.size, np.inf, np.float32)
    best_source = np.full(free.size, NO_SOURCE, np.uint8)
    for view, table, low in zip(views, tables, lows):
        projection = project_blocks(intr, view.to_view, x, y, z)
        with np.errstate(invalid="ignore"):
            bilinear = table.surface_depth(0, table.slots(projection), projection)
            free |= projection.z < np.take(low, projection.index) - th
            free |= projection.z < bilinear - th
            gap = np.abs(projection.z - bilinear)               # NaN off the surface: never closer
        closer = gap < np.minimum(best, th + np.float32(1e-9))
        # only compared through min(best, th): the same
        np.fmin(best, gap, out=best)
        # uint8: the view's label where closer
        best_source += closer * (np.uint8(view.source) - best_source)
    seen = best_source != NO_SOURCE
    # FREE 0, SURFACE 1, HIDDEN 2
    state = ~free * (np.uint8(HIDDEN) - seen)
    best_source += free * (np.uint8(NO_SOURCE) - best_source)
    shape = (BLOCK, BLOCK, BLOCK, len(blocks))
    return state.astype(np.uint8).reshape(shape), best_source.reshape(shape)


def _paper_voxels(rig: Rig, views: tuple[View, ...], images: _PaperImages, th: float,
                  blocks: Blocks) -> tuple[np.ndarray, np.ndarray]:
    """Algorithm 2 as written on a chunk of blocks (see the module docstring); voxels start removed
    (FREE) -> their state, source (B, B, B, m) uint8 (the block layout)."""
    intr = rig.intrinsics
    x, y, z = blocks.axes()
    shape = (BLOCK, BLOCK, BLOCK, len(blocks))
    pixel = nearest_pixels(intr, x, y, z).reshape(-1)
    local = np.flatnonzero(images.object[pixel])          # Project(v) in {p}_n, else removed
    points = np.stack([np.broadcast_to(a, shape).reshape(-1)[local] for a in (x, y, z)])
    front = in_front_of_mirrors(rig, *points)
    with np.errstate(invalid="ignore"):
        direct = np.abs(np.linalg.norm(points, axis=0) - images.distance[pixel[local]]) < th
    every_mirror = np.ones(points.shape[1], bool)
    best = np.full(points.shape[1], np.inf, np.float32)
    best_source = np.zeros(points.shape[1], np.uint8)
    for view in views[1:]:
        p = transform(view.to_view, points)
        at = pixel_index(intr, *project(intr, p))
        with np.errstate(invalid="ignore"):
            gap = np.abs(np.linalg.norm(p, axis=0) - images.distance[at])
            every_mirror &= images.object[at] & view.outline[at] & (gap < th)
        closer = gap < best
        best = np.where(closer, gap, best)
        best_source[closer] = view.source
    kept = front & (direct | every_mirror)
    state = np.full(pixel.size, FREE, np.uint8)
    source = np.full(pixel.size, NO_SOURCE, np.uint8)
    state[local] = np.where(kept, SURFACE, FREE)
    source[local] = np.where(kept, np.where(direct, 0, best_source), NO_SOURCE)
    return state.reshape(shape), source.reshape(shape)
