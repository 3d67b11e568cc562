"""Dense reconstruction of frames of a static object: frames prepared as for Algorithm 1
(mirrorcore.rig.pipeline. prepare_frame), a volume around the raw cloud, then space carving (methods
'paper', 'carve') or volumetric fusion ('tsdf')."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.rig.model import Rig
from mirrorcore.dense.carve import CarveResult, carve
from mirrorcore.dense.tsdf import TsdfResult, fuse
from mirrorcore.dense.volume import Progress, Volume

METHODS = ("paper", "carve", "tsdf")


@dataclass(frozen=True)
class DenseOptions:
    """voxel : edge in metres; margin : metres added around the raw cloud's bounding box; bounds :
    ((3,), (3,)) the box's corners in metres (camera frame) instead of the automatic box; threshold
    : carving's th in metres (default the voxel); truncation : the TSDF's in metres (default 3
    voxels)."""

    voxel: float = 0.002
    margin: float = 0.02
    bounds: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None
    threshold: float | None = None
    truncation: float | None = None


def dense_volume(rig: Rig, depth: np.ndarray, mask: np.ndarray, options: DenseOptions) -> Volume:
    """options.bounds, or the bounding box of the raw cloud (Algorithm 1) of one prepared frame
    grown by the margin."""
    if options.bounds is not None:
        return Volume.from_bounds(*options.bounds, options.voxel)
    return Volume.around(reconstruct_raw(rig, depth, mask).points, options.voxel, options.margin)


def reconstruct_dense(rig: Rig, depths: np.ndarray, masks: np.ndarray, volume: Volume, method: str,
                      options: DenseOptions = DenseOptions(), progress: Progress | None = None,
                      cancel=None, workers: int | None = None) -> CarveResult | TsdfResult:
    """Carve ('paper', 'carve': the first frame) or fuse ('tsdf': every frame) prepared frames (see
    mirrorcore.rig.pipeline.prepare_frame).

    depths, masks : (F, H, W) float metres / bool; workers : threads for the chunks (default the CPU
    count). Raises MirrorscanError for an unknown method, Cancelled when `cancel` (a threading.Event
    or a callable returning True) asks to stop."""
    if method not in METHODS:
        raise MirrorscanError(f"--method: unknown dense method {method!r} (expected one of {', '.join(METHODS)})")
    if method == "tsdf":
        return fuse(rig, depths, masks, volume, options.truncation, progress, cancel, workers)
    return carve(rig, depths[0], masks[0], volume, method, options.threshold, progress, cancel,
                 workers)


def result_geometry(result: CarveResult | TsdfResult) -> tuple[np.ndarray, np.ndarray,
                                                               np.ndarray | None]:
    """What a PLY file holds of a dense result: points (n, 3) float32 metres, camera frame, their
    sources (n,) uint8 and faces (m, 3) int32 or None: the surface voxels' centres of a carving, the
    mesh of a fusion (MirrorscanError when the volume holds no surface)."""
    if isinstance(result, CarveResult):
        return (*result.surface_points(), None)
    mesh = result.mesh()
    return mesh.vertices, mesh.sources, mesh.faces
