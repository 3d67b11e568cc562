"""TSDF fusion inside the allocated blocks: which views and tests each block needs, decided for
whole blocks first (BlockPlan), then the per-voxel sums of the views' truncated distances and
weights (fuse_blocks); mirrorcore.dense.tsdf describes the fusion."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirrorcore.dense.blocks import Blocks
from mirrorcore.dense.sampling import (Projection, QuadTable, in_front_of_mirrors, nearest_pixels,
                                       project_blocks)
from mirrorcore.dense.views import View
from mirrorcore.dense.volume import CHUNK_VOXELS, NO_SOURCE, SMALLEST_BLOCK
from mirrorcore.dense.windows import Window, mirror_sides, window_half
from mirrorcore.rig.model import Rig

# voxels along a block's edge: small blocks follow the surface's band closely
BLOCK = SMALLEST_BLOCK
# metres: the least depth a weight is computed at (the voxels that near are not seen)
Z_TINY = 1e-6


# BlockPlan codes: cull voxel by voxel; test the mirror planes; view k sees: SEEN << k
CUT, STRADDLE, SEEN = 1, 2, 4


@dataclass(frozen=True, eq=False)
class BlockPlan:
    """What fusion computes in some blocks, decided for whole blocks first
    (mirrorcore.dense.windows): rows (k,) int, the blocks that hold a voxel the camera does not see
    empty beyond the truncation and that are not behind a mirror, ordered by their code (k,) int:
    CUT when some voxel may be culled by the camera (tested voxel by voxel), STRADDLE when some
    voxel may be behind a mirror, and SEEN << v when view v may see some voxel within the truncation
    of its surface or in front of it. Blocks of one code are fused together, all alike."""

    rows: np.ndarray
    codes: np.ndarray

    @classmethod
    def of(cls, rig: Rig, frames: list[tuple[View, ...]], cull: np.ndarray, blocks: Blocks,
           trunc: float) -> "BlockPlan":
        """The plan for `blocks` of the views of `frames`; `cull`, the camera's cull depth."""
        intr, volume = rig.intrinsics, blocks.volume
        extent = (BLOCK - 1) * volume.voxel
        halves = [window_half(intr, view.to_view, volume.corners(), extent) for view in frames[0]]
        box = blocks.bounds()
        camera = Window.for_cull(cull, frames[0][0].shape, halves[0])
        culled, _ = camera.test(intr, box, trunc)
        # every voxel at or beyond the camera's depth - trunc
        _, uncut = camera.test(intr, box, -trunc)
        behind_a_mirror, front = mirror_sides(rig, box)
        culled |= behind_a_mirror
        rows = np.flatnonzero(~culled)
        box = (box[0][:, rows], box[1][:, rows])
        codes = np.where(uncut[rows], 0, CUT) + np.where(front[rows], 0, STRADDLE)
        for k, half in enumerate(halves):
            window = Window.for_fusion([views[k] for views in frames], half)
            codes += np.where(window.test(intr, box, trunc)[1], 0, SEEN << k)
        order = np.argsort(codes, kind="stable")
        return cls(rows[order], codes[order])

    def items(self, max_voxels: int = CHUNK_VOXELS) -> list[tuple[slice, int]]:
        """The work: (rows of self.rows, their code) for runs of one code, <= max_voxels each."""
        step = max(1, max_voxels // BLOCK ** 3)
        starts = np.flatnonzero(np.diff(self.codes, prepend=-1))
        ends = np.append(starts[1:], len(self.codes))
        return [(slice(i, min(i + step, end)), int(self.codes[start])) for start,
                end in zip(starts, ends)
                for i in range(start, end, step)]


def fuse_blocks(rig: Rig, tables: list[QuadTable], to_views: list[np.ndarray],
                 views: tuple[View, ...],
                 cull: np.ndarray, trunc: float, blocks: Blocks, code: int, tsdf: np.ndarray,
                 weight: np.ndarray,
                 source: np.ndarray) -> None:
    """Fuse the views that `code` (BlockPlan) names (their tables over the frames, extrinsics, and
    the views of one frame for their labels) into `blocks`, writing their tsdf, weight (m, B, B, B)
    float32 and source uint8 (as they start: 1, 0, NO_SOURCE). A view is projected once for every
    frame (they share the rig)."""
    intr = rig.intrinsics
    x, y, z = blocks.axes()
    keep = None
    if code & CUT:
        keep = z >= cull[nearest_pixels(intr, x, y, z)] - np.float32(trunc)
    if code & STRADDLE:
        front = in_front_of_mirrors(rig, x, y, z)
        keep = front if keep is None else keep & front
    size = BLOCK ** 3 * len(blocks)
    total, sum_w, best_w = (np.zeros(size, np.float32) for _ in range(3))
    best_source = np.full(size, NO_SOURCE, np.uint8)
    for k, view in enumerate(views):
        if not code & SEEN << k:
            continue
        projection = project_blocks(intr, to_views[k], x, y, z)
        clipped, count = _sampled_sdf(tables[k], projection, trunc)
        w = view_weight(projection, keep)
        clipped *= w
        total += clipped
        count *= w
        sum_w += count
        # the weight of a view counts where it is used
        w *= count > 0
        better = w > best_w
        # uint8: the view's label where better
        best_source += better * (np.uint8(view.source) - best_source)
        np.maximum(best_w, w, out=best_w)
    unseen = sum_w == 0
    values = (total + unseen) / (sum_w + unseen)                   # 1 where no view weighs in
    for out, a in ((tsdf, values), (weight, sum_w), (source, best_source)):
        out[:] = np.moveaxis(a.reshape(BLOCK, BLOCK, BLOCK, -1), -1, 0)


def view_weight(projection: Projection, keep: np.ndarray | None) -> np.ndarray:
    """Return a view's weight of voxels: (1 m / z)^4, z their depth in the view.

    Parameters
    ----------
    projection : Projection
        The voxels in the view.
    keep : bool array of n elements or None
        The voxels the camera does not cull and in front of every mirror (None: all).

    Returns
    -------
    (n,) float32 array
        0 where not kept.
    """
    # finite weights: voxels past the volume are NaN
    w = np.fmax(projection.z, np.float32(Z_TINY))
    np.square(w, out=w)
    np.square(w, out=w)
    np.divide(np.float32(1), w, out=w)
    if keep is not None:
        w *= keep.reshape(-1)
    return w


def _sampled_sdf(table: QuadTable, projection, trunc: float) -> tuple[np.ndarray, np.ndarray]:
    """One view of every frame (its QuadTable) sampled at the projected voxels -> (n,) float32 each:
    the sum over the frames of the sdf / truncation clipped to 1, where the voxel's quad shows the
    surface and sdf > -truncation, and how many frames that is."""
    slots = table.slots(projection)
    clipped = count = None
    with np.errstate(invalid="ignore"):
        for frame in range(len(table.rows)):
            sdf = table.surface_depth(frame, slots, projection)
            sdf -= projection.z
            used = sdf > -trunc
            sdf /= np.float32(trunc)
            np.fmin(sdf, 1, out=sdf)
            sdf *= used
            if clipped is None:
                clipped, count = sdf, used.astype(np.float32)
            else:
                clipped += sdf
                count += used
    return clipped, count

