"""Volumetric fusion: a truncated signed distance (TSDF) volume fusing the camera's view and every
mirror's view of one or more depth frames of a static object, and its surface mesh.

Each mirror is a virtual camera whose extrinsic is the reflection through its plane (det -1): a
voxel v is seen by mirror j at the reflected point v_j, projected with the camera's intrinsics and
compared with the measured (virtual) depth there; a sequence of mirrors the camera sees through in
turn is one more, with the composition of their reflections as its extrinsic
(mirrorcore.dense.views). Open3D's TSDF integration takes a 4x4 extrinsic, but it is not used here:
fusing in numpy keeps the bilinear depth, the per-view weights and the per-voxel source of the best
view (`mirrorscan bench` times Open3D's VoxelBlockGrid on the same views beside it).

Per view, only the object's pixels of that view count (the camera's object pixels that no mirror
claims; a mirror's object pixels inside its boundary and behind its plane, see mirrorcore.views). A
voxel at depth z (in the view's frame) on a pixel with depth d gets sdf = d - z, used when sdf >
-truncation and clipped to truncation, with the weight (1 m / z)^4: the inverse variance of a
structured-light camera, whose noise grows with z^2 (mirror views are farther, hence noisier).
Voxels the camera sees empty by more than the truncation even in its 3x3 neighbourhood, and voxels
behind a mirror, are not computed (weight 0).

The fusion is sparse: only the blocks of BLOCK^3 voxels (mirrorcore.dense.blocks) that hold a voxel
within the truncation of some view's measurement are allocated and computed (`surface_blocks`): per
quad of pixels that shows the surface (mirrorcore.dense.sampling), the box around the part of its
frustum between its least depth minus the truncation and its greatest plus the truncation. Every
voxel whose value some view sets below 1 is in them, with the value a fusion of the whole grid gives
it; the voxels left out are those every view sees empty (or not at all).

With the frames' colour images, the voxels are coloured with the same weights, each view's pixels
divided by its mirrors' colour gains (mirrorcore.dense.colour); the mesh's vertices take the colour
interpolated along their edges. The colours are computed for the voxels the mesh reads (the ends
of its edges), from the tables the fusion read, so fusing them costs nothing until then.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirrorcore.base.budget import check_memory
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.rig.model import Rig
from mirrorcore.dense.blocks import Blocks, cropped, padded_grid
from mirrorcore.dense.holes import close_holes
from mirrorcore.dense.mesh import Mesh, block_marching_cubes
from mirrorcore.dense.blockfusion import BLOCK, fuse_blocks, BlockPlan
from mirrorcore.dense.colour import FusedColour, colour_frames, packed_padded
from mirrorcore.dense.sampling import BORDER, QuadTable
from mirrorcore.dense.views import cull_depth, rig_views
from mirrorcore.dense.volume import NO_SOURCE, Progress, Volume, run_chunks

# bytes per allocated voxel: tsdf, weight, source, and their copy when empty blocks go
TSDF_VOXEL_BYTES = 12
# pixels, and voxels: the float32 rounding of a voxel's projection and centre
PIXEL_MARGIN = 0.01
# the longest hole closed_mesh closes, in voxels of boundary: on the simulated sphere the holes the
# views saw around are 3-35 voxels long, the caps no view saw over 250 (docs/recording-and-dense.md)
HOLE_VOXELS = 40


@dataclass(frozen=True, eq=False)
class TsdfResult:
    """The fused blocks of a volume.

    Block r holds the voxels of blocks.ijk[r] in the block layout (mirrorcore.dense.blocks); every
    block has a voxel of weight > 0.

    Attributes
    ----------
    volume : Volume
    blocks : Blocks
    tsdf : (m, B, B, B) float32 array
        In [-1, 1]: signed distance / truncation, > 0 in front of the surface; 1 where weight is 0.
    weight : (m, B, B, B) float32 array
        Sum of the weights.
    source : (m, B, B, B) uint8 array
        The view (0 camera, j mirror j, from 33 a sequence of mirrors) of the largest single weight,
        NO_SOURCE where weight is 0.
    truncation : float
        Metres.
    paint : FusedColour or None
        Fused with colour images: what colours the voxels (`voxel_colours`); None without.
    """

    volume: Volume
    blocks: Blocks
    tsdf: np.ndarray
    weight: np.ndarray
    source: np.ndarray
    truncation: float
    paint: FusedColour | None = None

    def mesh(self) -> Mesh:
        """Extract the zero level set by marching cubes (mirrorcore.dense.mesh).

        On the edges between voxels with weight > 0; each vertex takes the source of the nearer end
        of its edge and, fused with colour, the colour interpolated along it.

        Returns
        -------
        Mesh

        Raises
        ------
        MirrorscanError
            There is no surface in the volume.
        """
        return block_marching_cubes(self.blocks, self.tsdf, self.weight > 0, self.source,
                                    None if self.paint is None else self.voxel_colours)

    def voxel_colours(self, ijk: np.ndarray) -> np.ndarray:
        """Return the fused colours of voxels (mirrorcore.dense.colour).

        Parameters
        ----------
        ijk : (k, 3) integer array
            The voxels' indices in the volume.

        Returns
        -------
        (k, 4) uint8 array
            Red, green, blue levels, and 1 where some view gave a colour (0 and black elsewhere).

        Raises
        ------
        MirrorscanError
            The fusion had no colour images.
        """
        if self.paint is None:
            raise MirrorscanError("tsdf: fused without colour images, so the voxels have no colour")
        return self.paint.colours(self.volume, ijk)

    def closed_mesh(self, max_length: float | None = None) -> Mesh:
        """The mesh with its short holes closed where a view observed the voxels.

        mirrorcore.dense.holes.close_holes with `observed`: a hole where no view saw stays open.

        Parameters
        ----------
        max_length : float, optional
            The longest hole closed, metres of boundary (default HOLE_VOXELS voxels).

        Returns
        -------
        Mesh

        Raises
        ------
        MirrorscanError
            There is no surface in the volume.
        """
        limit = HOLE_VOXELS * self.volume.voxel if max_length is None else max_length
        return close_holes(self.mesh(), self.observed, limit)

    def observed(self, points: np.ndarray) -> np.ndarray:
        """Whether a view observed the voxel nearest each point (its weight is above 0).

        Parameters
        ----------
        points : (k, 3) float array
            Metres, camera frame.

        Returns
        -------
        (k,) bool array
            False outside the volume and in the blocks not fused.
        """
        volume = self.volume
        if not len(self.blocks):
            return np.zeros(len(np.reshape(points, (-1, 3))), bool)
        ijk = np.rint((np.asarray(points, float).reshape(-1, 3) - volume.origin)
                      / volume.voxel).astype(np.int64)
        inside = np.all((ijk >= 0) & (ijk < np.asarray(volume.shape)), axis=1)
        ijk = np.where(inside[:, None], ijk, 0)
        keys = np.ravel_multi_index(tuple((ijk // BLOCK).T), volume.block_shape(BLOCK))
        # the blocks are in C order
        rows = np.minimum(np.searchsorted(self.blocks.keys, keys), len(self.blocks) - 1)
        found = inside & (self.blocks.keys[rows] == keys)
        local = ijk % BLOCK
        weight = self.weight[rows, local[:, 0], local[:, 1], local[:, 2]]
        return found & (weight > 0)

    def grids(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return the whole grids (nx, ny, nz).

        9 bytes a voxel of the volume: for small volumes and checks.

        Returns
        -------
        tsdf : (nx, ny, nz) float32 array
            1 outside the blocks.
        weight : (nx, ny, nz) float32 array
            0 outside.
        source : (nx, ny, nz) uint8 array
            NO_SOURCE outside.

        Raises
        ------
        MemoryBudgetError
            They would not fit in the memory budget.
        """
        self.volume.check_grids(9, "the fused grids, whole", BLOCK)
        grids = []
        for values, fill in ((self.tsdf, 1.0), (self.weight, 0.0), (self.source, NO_SOURCE)):
            grid = padded_grid(self.volume, fill, values.dtype, BLOCK)
            self.blocks.write(grid, np.moveaxis(values, 0, -1))
            grids.append(np.ascontiguousarray(cropped(self.volume, grid)))
        return tuple(grids)


def fuse(rig: Rig, depths: np.ndarray, masks: np.ndarray, volume: Volume,
         truncation: float | None = None,
         progress: Progress | None = None, cancel=None, workers: int | None = None,
         blocks: Blocks | None = None, colours: np.ndarray | None = None) -> TsdfResult:
    """Fuse the views of frames of a static object into a TSDF volume (see the module docstring).

    Parameters
    ----------
    rig : Rig
    depths : (H, W) or (F, H, W) float array
        Metres, 0 = no reading.
    masks : bool array of the same shape
        The object's pixels.
    volume : Volume
    truncation : float, optional
        Metres (default 3 voxels).
    progress : Progress, optional
        progress(fraction) after each chunk of blocks.
    cancel : threading.Event or callable, optional
        Asks to stop when set or when it returns True.
    workers : int, optional
        Threads (default the CPU count).
    blocks : Blocks, optional
        The blocks of BLOCK^3 voxels to compute (default `surface_blocks`; Blocks.all(volume, BLOCK)
        computes every voxel).
    colours : (H, W, 3) or (F, H, W, 3) uint8 array, optional
        Each frame's colour registered to its depth: the voxels' colours are fused too (each view's
        pixels corrected by Rig.colour_correction, mirrorcore.dense.colour).

    Returns
    -------
    TsdfResult

    Raises
    ------
    Cancelled
        When stopped.
    MirrorscanError
        Mismatched inputs.
    MemoryBudgetError
        The blocks would not fit in the memory budget.
    """
    depths = np.asarray(depths, np.float32)
    depths = depths[None] if depths.ndim == 2 else depths
    if np.size(masks) != depths.size:
        raise MirrorscanError(
            f"fuse: masks of shape {np.shape(masks)} for depth frames of shape {depths.shape}")
    masks = np.asarray(masks, bool).reshape(depths.shape)
    trunc = 3 * volume.voxel if truncation is None else float(truncation)
    if not trunc > 0:
        raise MirrorscanError(f"fuse: the truncation must be positive, got {truncation}")
    frames = [rig_views(rig, d, m) for d, m in zip(depths, masks)]
    tables = [QuadTable.of([views[k].quads for views in frames]) for k in range(len(frames[0]))]
    to_views = [view.to_view for view in frames[0]]
    if blocks is None:
        blocks = surface_blocks(rig.intrinsics, tables, to_views, volume, trunc)
    packed = None if colours is None else [
        packed_padded(image) for image in colour_frames(rig.intrinsics, colours, len(depths))]
    check_memory(blocks.voxels * TSDF_VOXEL_BYTES,
                 f"tsdf: {len(blocks):,} blocks of {BLOCK}^3 voxels of {volume.voxel * 1e3:g} mm "
                 "(use larger voxels or a smaller truncation)")
    cull = cull_depth(np.minimum.reduce([views[0].depth for views in frames]), frames[0][0].shape)
    plan = BlockPlan.of(rig, frames, cull, blocks, trunc)
    blocks = blocks.take(plan.rows)
    tsdf = np.ones((len(blocks), BLOCK, BLOCK, BLOCK), np.float32)
    weight = np.zeros_like(tsdf)
    source = np.full(tsdf.shape, NO_SOURCE, np.uint8)

    def work(item: tuple[slice, int]) -> None:
        rows, code = item
        fuse_blocks(rig, tables, to_views, frames[0], cull, trunc, blocks.take(rows), code,
                     tsdf[rows],
                     weight[rows], source[rows])

    run_chunks(plan.items(), work, progress, cancel, workers)
    kept = np.flatnonzero(weight.reshape(len(blocks), BLOCK ** 3).max(axis=1, initial=0) > 0)
    # C order
    kept = kept[np.argsort(blocks.take(kept).keys)]
    paint = None if packed is None else FusedColour(
        rig, tables, to_views, [view.source for view in frames[0]], trunc, packed)
    return TsdfResult(volume, blocks.take(kept), tsdf[kept], weight[kept], source[kept], trunc,
                      paint)


def surface_blocks(intr: Intrinsics, tables: list[QuadTable], to_views: list[np.ndarray],
                   volume: Volume,
                   truncation: float) -> Blocks:
    """Return the blocks holding a voxel some view may see within `truncation` of its surface.

    For each quad of pixels that shows the surface (sampling.Quads), the axis-aligned box (camera
    frame) of the part of its pixels' frustum between its least depth - truncation and its greatest
    + truncation over the frames.

    Parameters
    ----------
    intr : Intrinsics
    tables : list of QuadTable
        Each view's quads over the frames.
    to_views : list of (3, 4) array
        Each view's extrinsic.
    volume : Volume
    truncation : float
        Metres.

    Returns
    -------
    Blocks
    """
    boxes = [_quad_boxes(intr, table, to_view, truncation) for table,
             to_view in zip(tables, to_views)]
    return Blocks.marked(volume, _covered(volume, np.concatenate([b[0] for b in boxes]),
                                          np.concatenate([b[1] for b in boxes])), BLOCK)


def _quad_boxes(intr: Intrinsics, table: QuadTable, to_view: np.ndarray,
                truncation: float) -> tuple[np.ndarray, np.ndarray]:
    """(k, 3) float64 lower and upper corners, camera frame, of the boxes of `surface_blocks` for
    the quads of a view's table (seen through extrinsic to_view (3, 4)).

    A corner of the frustum piece is z (a, b, 1) in the view's frame, a and b the pixel edges' (x/z,
    y/z), z the near or the far depth; in the camera frame its coordinate i is z (R_i0 a + R_i1 b +
    R_i2) + t_i, (R | t) the inverse of the view's extrinsic: least and greatest over the four (a,
    b) and the two depths (z > 0)."""
    near, far = np.maximum(table.near - truncation, 1e-6), table.far + np.float64(truncation)
    row, col = np.divmod(table.index, intr.width + 2 * BORDER)
    a = [(col - BORDER + du - intr.cx) / intr.fx for du in (-PIXEL_MARGIN, 1 + PIXEL_MARGIN)]
    b = [(row - BORDER + dv - intr.cy) / intr.fy for dv in (-PIXEL_MARGIN, 1 + PIXEL_MARGIN)]
    back = np.linalg.inv(np.vstack([to_view, [0.0, 0.0, 0.0, 1.0]]))
    lo, hi = np.full((len(near), 3), np.inf), np.full((len(near), 3), -np.inf)
    for i in range(3):
        for ai in a:
            for bi in b:
                line = back[i, 0] * ai + back[i, 1] * bi + back[i, 2]
                lo[:, i] = np.minimum(lo[:, i], np.minimum(near * line, far * line))
                hi[:, i] = np.maximum(hi[:, i], np.maximum(near * line, far * line))
    return lo + back[:3, 3], hi + back[:3, 3]


def _covered(volume: Volume, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(volume.block_shape(BLOCK)) bool: the blocks holding a voxel centre inside some box lo..hi
    (n, 3) metres. Each box covers a range of blocks; their union is counted on a grid of
    differences (+1 and -1 at the corners of each range, inclusion-exclusion) summed along the three
    axes."""
    origin, top = np.asarray(volume.origin), np.asarray(volume.shape) - 1
    first = np.ceil((lo - origin) / volume.voxel - PIXEL_MARGIN).astype(np.int64)
    last = np.floor((hi - origin) / volume.voxel + PIXEL_MARGIN).astype(np.int64)
    first, last = np.maximum(first, 0), np.minimum(last, top)
    inside = (first <= last).all(axis=1)
    # [start, stop) per axis
    ends = (first[inside] // BLOCK, last[inside] // BLOCK + 1)
    shape = tuple(b + 1 for b in volume.block_shape(BLOCK))
    # + and - corners
    corners = [[], []]
    for a, b, c in np.ndindex(2, 2, 2):
        corners[(a + b + c) % 2].append((ends[a][:, 0] * shape[1] + ends[b][:, 1]) * shape[
            2] + ends[c][:, 2])
    size = int(np.prod(shape))
    count = np.bincount(np.concatenate(corners[0]), minlength=size).astype(np.int32) - \
        np.bincount(np.concatenate(corners[1]), minlength=size).astype(np.int32)
    count = count.reshape(shape).cumsum(axis=0, dtype=np.int32).cumsum(axis=1).cumsum(axis=2)
    return count[:-1, :-1, :-1] > 0

