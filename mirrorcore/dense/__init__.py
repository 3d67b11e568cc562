"""Floor 7, dense reconstruction of frames of a static object: frames prepared as for Algorithm 1
(mirrorcore.rig.pipeline.prepare_frame), a volume around the raw cloud (volume, blocks), then
space carving (methods 'paper', 'carve'; carve) or volumetric fusion ('tsdf'; tsdf, blockfusion,
mesh), with the views through the mirrors as virtual cameras (views, sampling, windows).

    volume = dense_volume(rig, depths[0], masks[0], DenseOptions(voxel=0.004))
    result = reconstruct_dense(rig, depths, masks, volume, "tsdf")
    points, sources, faces, colours = result_geometry(result)
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.rig.model import Rig
from mirrorcore.dense.carve import CarveResult, carve
from mirrorcore.dense.colour import colour_frames
from mirrorcore.dense.tsdf import TsdfResult, fuse
from mirrorcore.dense.volume import Progress, Volume

__all__ = ["METHODS", "CarveResult", "DenseOptions", "TsdfResult", "Volume", "carve",
           "dense_volume", "fuse", "reconstruct_dense", "result_geometry"]

METHODS = ("paper", "carve", "tsdf")


@dataclass(frozen=True)
class DenseOptions:
    """The options of a dense reconstruction.

    Attributes
    ----------
    voxel : float
        Edge in metres.
    margin : float
        Metres added around the raw cloud's bounding box.
    bounds : ((3,), (3,)) float or None
        The box's corners in metres (camera frame) instead of the automatic box.
    threshold : float or None
        Carving's th in metres (default the voxel).
    truncation : float or None
        The TSDF's in metres (default 3 voxels).
    """

    voxel: float = 0.002
    margin: float = 0.02
    bounds: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None
    threshold: float | None = None
    truncation: float | None = None


def dense_volume(rig: Rig, depth: np.ndarray, mask: np.ndarray, options: DenseOptions) -> Volume:
    """Return the volume to reconstruct in.

    options.bounds, or the bounding box of the raw cloud (Algorithm 1) of one prepared frame, grown
    by the margin.

    Parameters
    ----------
    rig : Rig
    depth : (H, W) float array
        Metres.
    mask : (H, W) bool array
        The object's pixels.
    options : DenseOptions

    Returns
    -------
    Volume

    Raises
    ------
    MirrorscanError
        No bounds and no points.
    MemoryBudgetError
        The volume would not fit in the memory budget.
    """
    if options.bounds is not None:
        return Volume.from_bounds(*options.bounds, options.voxel)
    return Volume.around(reconstruct_raw(rig, depth, mask).points, options.voxel, options.margin)


def reconstruct_dense(rig: Rig, depths: np.ndarray, masks: np.ndarray, volume: Volume, method: str,
                      options: DenseOptions = DenseOptions(), progress: Progress | None = None,
                      cancel=None, workers: int | None = None,
                      colours: np.ndarray | None = None) -> CarveResult | TsdfResult:
    """Carve ('paper', 'carve': the first frame) or fuse ('tsdf': every frame) prepared frames.

    Parameters
    ----------
    rig : Rig
    depths, masks : (F, H, W) float metres / bool
        Frames prepared by mirrorcore.rig.pipeline.prepare_frame.
    volume : Volume
    method : str
        One of METHODS.
    options : DenseOptions
    progress : callable, optional
    cancel : threading.Event or callable, optional
        Asks to stop when set or when it returns True.
    workers : int, optional
        Threads for the chunks (default the CPU count).
    colours : (F, H, W, 3) uint8 array, optional
        The frames' colour registered to their depth: the result is coloured too (each view's
        pixels corrected by Rig.colour_correction; mirrorcore.dense.colour).

    Returns
    -------
    CarveResult or TsdfResult

    Raises
    ------
    MirrorscanError
        For an unknown method.
    Cancelled
        When `cancel` asks to stop.
    """
    if method not in METHODS:
        raise MirrorscanError(f"--method: unknown dense method {method!r} (expected one of "
                              f"{', '.join(METHODS)})")
    if method == "tsdf":
        return fuse(rig, depths, masks, volume, options.truncation, progress, cancel, workers,
                    colours=colours)
    colour = None if colours is None else colour_frames(rig.intrinsics, colours, len(depths))[0]
    return carve(rig, depths[0], masks[0], volume, method, options.threshold, progress, cancel,
                 workers, colour)


def result_geometry(result: CarveResult | TsdfResult) -> tuple[
    np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]:
    """Return what a PLY file holds of a dense result.

    The surface voxels' centres of a carving, the mesh of a fusion.

    Parameters
    ----------
    result : CarveResult or TsdfResult

    Returns
    -------
    points : (n, 3) float32 array
        Metres, camera frame.
    sources : (n,) uint8 array
    faces : (m, 3) int32 array or None
    colours : (n, 3) uint8 array or None
        The vertices' colours of a result made with colour images.

    Raises
    ------
    MirrorscanError
        When the volume holds no surface.
    """
    if isinstance(result, CarveResult):
        return (*result.surface_points(), None, result.colours)
    mesh = result.mesh()
    return mesh.vertices, mesh.sources, mesh.faces, mesh.colours
