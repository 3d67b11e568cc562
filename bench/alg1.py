"""Benchmark of Algorithm 1, beside Open3D's plain reprojection, and through several mirrors.

A 640x480 two-mirror frame of the simulated rig (the walking figure, Kinect noise), beside Open3D's
plain reprojection of the same frame (the four measured in turn, one with the frame's colour
through the mirrors' colour gains), and on a frame of two hinged
mirrors at 72 degrees, where rays go on through a second mirror (the kaleidoscope), with the time to
trace them and to prepare that frame (select the object, smooth it, fit the views through two
mirrors)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import open3d as o3d

from mirrorscan.bench import interleaved_ms, median_ms
from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.rig.model import Rig
from mirrorcore.depth.selection import Selection, object_mask
from mirrorcore.sim.export import true_rig
from mirrorcore.sim.layouts import kaleidoscope_scene, paper_scene
from mirrorcore.sim.simulator import Simulator


def run() -> dict[str, float]:
    """Algorithm 1 on the object and on the full frame, beside Open3D's reprojection of the frame.

    The walking figure at 3 m in the paper's rig, then the kaleidoscope's figures.

    Returns
    -------
    dict of str to float
        {figure name: value}; names ending in _ms are median milliseconds.
    """
    sim = Simulator(paper_scene(object="figure", distance=3.0), seed=0)
    camera = sim.intrinsics
    rig = true_rig(sim.scene)
    frame = sim.frame(0)
    depth, colour = frame.depth, frame.colour
    mask = object_mask(camera, depth, sim.background().depth, Selection())
    tinted = replace(rig, colour_gains=tuple(m.tint for m in sim.scene.mirrors))
    # built once per rig, as the live loop does
    rig.reflection_table, tinted.reflection_table, tinted.colour_correction
    image = o3d.geometry.Image(np.round(depth / camera.depth_scale).astype(np.uint16))
    pinhole = o3d.camera.PinholeCameraIntrinsic(
        camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy
    )

    def open3d_reproject():
        cloud = o3d.geometry.PointCloud.create_from_depth_image(
            image, pinhole, depth_scale=1 / camera.depth_scale, depth_trunc=100.0
        )
        return np.asarray(cloud.points)

    figures = interleaved_ms(
        {
            "alg1_object_ms": lambda: reconstruct_raw(rig, depth, mask),
            "alg1_colour_object_ms": lambda: reconstruct_raw(tinted, depth, mask, colour),
            "alg1_full_frame_ms": lambda: reconstruct_raw(rig, depth),
            "open3d_reproject_ms": open3d_reproject,
        },
        repeat=100,
    )
    return {
        **figures,
        "alg1_object_points": float(mask.sum()),
        "alg1_full_frame_points": float((depth > 0).sum()),
        **_kaleidoscope(),
    }


def _kaleidoscope() -> dict[str, float]:
    """Algorithm 1 through up to 3 mirrors: two hinged mirrors at 72 degrees.

    The walking figure between them; the time to build the rig's per-pixel tables (tracing every
    ray through the mirrors' outlines), and prepare_frame on that frame (selection, smoothing, and
    the local quadratic fits of the pixels seen through two mirrors).
    """
    sim = Simulator(kaleidoscope_scene(72.0, object="figure", distance=3.0), seed=0)
    rig = true_rig(sim.scene)
    depth, background = sim.frame(0).depth, sim.background().depth
    mask = object_mask(sim.intrinsics, depth, background, Selection())

    rig.reflection_table
    cloud = reconstruct_raw(rig, depth, mask)
    return {
        "alg1_kaleidoscope_object_ms": median_ms(
            lambda: reconstruct_raw(rig, depth, mask), repeat=100
        ),
        "alg1_kaleidoscope_multi_points": float(np.count_nonzero(cloud.sources > 2)),
        "prepare_kaleidoscope_ms": median_ms(
            lambda: prepare_frame(rig, depth, background), repeat=30
        ),
        "alg1_tables_ms": median_ms(
            lambda: Rig(rig.intrinsics, rig.mirrors, rig.bounces).reflection_table,
            repeat=5,
            warmup=1,
        ),
    }
