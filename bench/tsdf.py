"""Benchmark of TSDF fusion against Open3D's.

The sparse numpy fusion (mirrorcore.dense.tsdf) and Open3D's VoxelBlockGrid integrating the same
views (the camera and each mirror's virtual camera, with its det -1 extrinsic) of the same frames of
the simulated sphere, both with a truncation of 3 voxels and their meshes extracted, timed
interleaved: one frame at 200^3 voxels (2 mm over 40 cm), five frames, and the traced peak memory at
300^3 (1.33 mm). Each mesh's RMSE to the true sphere is reported beside. tsdf_fuse_ms and
open3d_integrate_ms time the fusion alone (one frame, 200^3), without the meshes. tsdf_colour_ms is
tsdf_ms fusing the frame's colour too (the mirrors' gains applied) and its mesh with vertex
colours, timed in the same run; tsdf_colour_rmse_levels the RMS difference of those colours to the
sphere's albedo at the vertices (levels of 255).
"""

from __future__ import annotations

import numpy as np
import open3d as o3d
import open3d.core as o3c

from mirrorscan.bench import interleaved_ms
from mirrorscan.bench.carve import SphereFrames, peak_mb, sphere_frames
from mirrorcore.dense.tsdf import fuse
from mirrorcore.dense.views import rig_views
from mirrorcore.dense.volume import Volume

TRUNCATION_VOXELS = 3
O3D_BLOCK = 8  # voxels along an Open3D block's edge
O3D_BLOCKS = 40_000  # Open3D's initial block count (its hash map grows when needed)
# the mesh over the voxels some view saw (Open3D adds 1 per view; its default is 3)
O3D_MIN_WEIGHT = 0.5


def open3d_tsdf(frames: SphereFrames, volume: Volume, count: int, mesh: bool = True):
    """Open3D's VoxelBlockGrid fusing the views of the first `count` frames, then its mesh.

    Each view's depth where it shows the object, 0 elsewhere; voxels of volume.voxel, depth up to
    4 m.

    Parameters
    ----------
    frames : SphereFrames
    volume : Volume
        Its voxel size is used.
    count : int
        Frames to fuse.
    mesh : bool, optional
        Extract the mesh; without it, the grid.

    Returns
    -------
    open3d.t.geometry.TriangleMesh or VoxelBlockGrid
        The mesh in the camera frame, metres.
    """
    intr = frames.rig.intrinsics
    intrinsic = o3c.Tensor([[intr.fx, 0, intr.cx], [0, intr.fy, intr.cy], [0, 0, 1]], o3c.float64)
    grid = o3d.t.geometry.VoxelBlockGrid(
        ("tsdf", "weight"),
        (o3c.float32, o3c.float32),
        ((1,), (1,)),
        volume.voxel,
        O3D_BLOCK,
        O3D_BLOCKS,
        o3c.Device("CPU:0"),
    )
    for depth, mask in zip(frames.depths[:count], frames.masks[:count]):
        for view in rig_views(frames.rig, depth, mask):
            image = (
                np.where(view.surface[:-1], view.depth[:-1], 0)
                .reshape(view.shape)
                .astype(np.float32)
            )
            image = o3d.t.geometry.Image(o3c.Tensor(image))
            extrinsic = o3c.Tensor(np.vstack([view.to_view, [0, 0, 0, 1]]), o3c.float64)
            blocks = grid.compute_unique_block_coordinates(
                image, intrinsic, extrinsic, 1.0, 4.0, float(TRUNCATION_VOXELS)
            )
            grid.integrate(blocks, image, intrinsic, extrinsic, 1.0, 4.0, float(TRUNCATION_VOXELS))
    return grid.extract_triangle_mesh(weight_threshold=O3D_MIN_WEIGHT) if mesh else grid


def ours(frames: SphereFrames, volume: Volume, count: int, mesh: bool = True,
         colour: bool = False):
    """The sparse fusion's mesh of the first `count` frames (truncation TRUNCATION_VOXELS voxels).

    Parameters
    ----------
    frames : SphereFrames
    volume : Volume
    count : int
        Frames to fuse.
    mesh : bool, optional
        Extract the mesh; without it, the fused result.
    colour : bool, optional
        Fuse the frames' colour too.

    Returns
    -------
    Mesh or the fused result
    """
    fused = fuse(
        frames.rig,
        frames.depths[:count],
        frames.masks[:count],
        volume,
        TRUNCATION_VOXELS * volume.voxel,
        colours=frames.colours[:count] if colour else None,
    )
    return fused.mesh() if mesh else fused


def run() -> dict[str, float]:
    """The sparse fusion beside Open3D's on the sphere: times, peak memory and RMSE.

    Returns
    -------
    dict of str to float
        {figure name: value}; names ending in _ms are median milliseconds.
    """
    frames = sphere_frames(5)
    small, large = frames.volume(200), frames.volume(300)
    times = interleaved_ms(
        {
            "tsdf_ms": lambda: ours(frames, small, 1),
            "tsdf_colour_ms": lambda: ours(frames, small, 1, colour=True),
            "open3d_tsdf_ms": lambda: open3d_tsdf(frames, small, 1),
            "tsdf_5_ms": lambda: ours(frames, small, 5),
            "open3d_tsdf_5_ms": lambda: open3d_tsdf(frames, small, 5),
            "tsdf_fuse_ms": lambda: ours(frames, small, 1, mesh=False),
            "open3d_integrate_ms": lambda: open3d_tsdf(frames, small, 1, mesh=False),
        },
        repeat=15,
        warmup=1,
    )
    coloured = ours(frames, small, 1, colour=True)
    return {
        **times,
        "tsdf_colour_rmse_levels": frames.colour_rmse_levels(coloured.vertices, coloured.colours),
        "tsdf_peak_mb": peak_mb(lambda: ours(frames, large, 1)),
        "tsdf_rmse_mm": frames.rmse_mm(ours(frames, small, 1).vertices),
        "open3d_tsdf_rmse_mm": frames.rmse_mm(
            open3d_tsdf(frames, small, 1).vertex.positions.numpy()
        ),
        "tsdf_5_rmse_mm": frames.rmse_mm(ours(frames, small, 5).vertices),
        "open3d_tsdf_5_rmse_mm": frames.rmse_mm(
            open3d_tsdf(frames, small, 5).vertex.positions.numpy()
        ),
    }
