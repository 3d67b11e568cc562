"""Benchmark of Algorithm 1 on a 640x480 two-mirror frame of the simulated rig (the walking figure, Kinect noise),
beside Open3D's plain reprojection of the same frame."""
from __future__ import annotations

import numpy as np
import open3d as o3d

from bench import median_ms
from mirrorcore.reconstruct import reconstruct_raw
from mirrorcore.selection import Selection, object_mask
from mirrorcore.sim.export import true_rig
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator


def run() -> dict[str, float]:
    sim = Simulator(paper_scene(object="figure", distance=3.0), seed=0)
    camera = sim.intrinsics
    rig = true_rig(sim.scene)
    depth = sim.frame(0).depth
    mask = object_mask(camera, depth, sim.background().depth, Selection())
    rig.reflection_table  # built once per rig, as the live loop does
    image = o3d.geometry.Image(np.round(depth / camera.depth_scale).astype(np.uint16))
    pinhole = o3d.camera.PinholeCameraIntrinsic(camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy)

    def open3d_reproject():
        cloud = o3d.geometry.PointCloud.create_from_depth_image(image, pinhole, depth_scale=1 / camera.depth_scale,
                                                                depth_trunc=100.0)
        return np.asarray(cloud.points)

    return {
        "alg1_object_ms": median_ms(lambda: reconstruct_raw(rig, depth, mask), repeat=100),
        "alg1_full_frame_ms": median_ms(lambda: reconstruct_raw(rig, depth), repeat=100),
        "open3d_reproject_ms": median_ms(open3d_reproject, repeat=100),
        "alg1_object_points": float(mask.sum()),
        "alg1_full_frame_points": float((depth > 0).sum()),
    }
