"""Volumetric fusion: a truncated signed distance (TSDF) volume fusing the camera's view and every mirror's view of
one or more depth frames of a static object, and its surface mesh.

Each mirror is a virtual camera whose extrinsic is the reflection through its plane (det -1): a voxel v is seen by
mirror j at the reflected point v_j, projected with the camera's intrinsics and compared with the measured (virtual)
depth there; a sequence of mirrors the camera sees through in turn is one more, with the composition of their
reflections as its extrinsic (mirrorcore.dense.views). Open3D's TSDF integration takes a 4x4 extrinsic, but it is not
used here: fusing in numpy keeps the per-view weights and the per-voxel source of the best view, and needs no assumption
on how Open3D treats det -1.

Per view, only the object's pixels of that view count (the camera's object pixels that no mirror claims; a mirror's
object pixels inside its boundary and behind its plane, see mirrorcore.views). A voxel at depth z (in the view's
frame) on a pixel with depth d gets sdf = d - z, used when sdf > -truncation and clipped to truncation, with the
weight (1 m / z)^4: the inverse variance of a structured-light camera, whose noise grows with z^2 (mirror views are
farther, hence noisier). Voxels the camera sees empty by more than the truncation even in its 3x3 neighbourhood, and
voxels behind a mirror, are not computed (weight 0).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MirrorscanError
from ..rig import Rig
from .mesh import Mesh, marching_cubes
from .views import View, direct_pixels, in_front_of_mirrors, rig_views, sample, transform
from .volume import NO_SOURCE, Progress, Volume, run_slabs


@dataclass(frozen=True, eq=False)
class TsdfResult:
    """tsdf : (nx, ny, nz) float32 in [-1, 1] (signed distance / truncation, > 0 in front of the surface; 1 where
    weight is 0); weight : (nx, ny, nz) float32 sum of the weights; source : (nx, ny, nz) uint8 the view (0 camera,
    j mirror j, from 33 a sequence of mirrors) of the largest single weight, NO_SOURCE where weight is 0; truncation
    in metres."""

    volume: Volume
    tsdf: np.ndarray
    weight: np.ndarray
    source: np.ndarray
    truncation: float

    def mesh(self) -> Mesh:
        """The zero level set by marching cubes over the voxels with weight > 0; each vertex takes the source of its
        nearest voxel. Raises MirrorscanError when there is no surface in the volume."""
        return marching_cubes(self.volume, self.tsdf, self.weight > 0, self.source)


def fuse(rig: Rig, depths: np.ndarray, masks: np.ndarray, volume: Volume, truncation: float | None = None,
         progress: Progress | None = None, cancel=None, workers: int | None = None) -> TsdfResult:
    """Fuse the views of one or more frames of a static object into a TSDF volume (see the module docstring).

    depths : (H, W) or (F, H, W) float metres, 0 = no reading; masks : the same shape, bool, the object's pixels;
    truncation : metres (default 3 voxels); progress(fraction) after each slab; cancel : a threading.Event or a
    callable returning True to stop. Raises Cancelled when stopped, MirrorscanError on mismatched inputs.
    """
    depths = np.asarray(depths, np.float32)
    depths = depths[None] if depths.ndim == 2 else depths
    if np.size(masks) != depths.size:
        raise MirrorscanError(f"fuse: masks of shape {np.shape(masks)} for depth frames of shape {depths.shape}")
    masks = np.asarray(masks, bool).reshape(depths.shape)
    trunc = 3 * volume.voxel if truncation is None else float(truncation)
    if not trunc > 0:
        raise MirrorscanError(f"fuse: the truncation must be positive, got {truncation}")
    frames = [rig_views(rig, d, m) for d, m in zip(depths, masks)]
    cull = np.minimum.reduce([views[0].cull_depth for views in frames])
    tsdf = np.ones(volume.shape, np.float32)
    weight = np.zeros(volume.shape, np.float32)
    source = np.full(volume.shape, NO_SOURCE, np.uint8)

    def work(slab: slice) -> None:
        _fuse_slab(rig, frames, cull, volume, trunc, slab, tsdf, weight, source)

    run_slabs(volume, work, progress, cancel, workers)
    return TsdfResult(volume, tsdf, weight, source, trunc)


def _fuse_slab(rig: Rig, frames: list[tuple[View, ...]], cull: np.ndarray, volume: Volume, trunc: float, slab: slice,
               tsdf: np.ndarray, weight: np.ndarray, source: np.ndarray) -> None:
    """Fuse every view of every frame into one slab of the grids, in place."""
    z = volume.axes()[2].astype(np.float32)
    local = np.flatnonzero(z >= cull[direct_pixels(rig.intrinsics, volume, slab)] - np.float32(trunc))
    index, points = volume.slab_points(slab, local)
    keep = in_front_of_mirrors(rig, points)
    index, points = index[keep], points[:, keep]
    total = np.zeros(points.shape[1], np.float32)
    sum_w = np.zeros(points.shape[1], np.float32)
    best_w = np.zeros(points.shape[1], np.float32)
    best_source = np.full(points.shape[1], NO_SOURCE, np.uint8)
    for views in frames:
        for view in views:
            p = transform(view, points)
            d, surface = sample(rig.intrinsics, view, p)
            with np.errstate(invalid="ignore", divide="ignore"):
                sdf = d - p[2]
                w = np.where(surface & (sdf > -trunc), np.float32(1) / np.square(np.square(p[2])), 0)
                total += w * np.minimum(np.where(w > 0, sdf, 0) / np.float32(trunc), 1)
            sum_w += w
            better = w > best_w
            best_w = np.where(better, w, best_w)
            best_source[better] = view.source
    seen = sum_w > 0
    tsdf.reshape(-1)[index[seen]] = total[seen] / sum_w[seen]
    weight.reshape(-1)[index[seen]] = sum_w[seen]
    source.reshape(-1)[index[seen]] = best_source[seen]
