"""Benchmark of dense reconstruction: carving and TSDF fusion of a 200^3 volume (2 mm voxels over 40 cm) around the
simulated sphere (640x480 Kinect frame with noise, two mirrors at 120 deg), with each one's peak memory."""
from __future__ import annotations

import tracemalloc
from typing import Callable

import numpy as np

from bench import median_ms
from mirrorcore.dense.carve import carve
from mirrorcore.dense.tsdf import fuse
from mirrorcore.dense.volume import Volume
from mirrorcore.pipeline import prepare_frame
from mirrorcore.sim.export import true_rig
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator


def peak_mb(fn: Callable[[], object]) -> float:
    """Peak of the memory traced (numpy arrays included) while fn() runs, MB."""
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 1e6
    finally:
        tracemalloc.stop()


def run() -> dict[str, float]:
    sim = Simulator(paper_scene(object="sphere"), seed=0)
    rig = true_rig(sim.scene)
    depth, mask = prepare_frame(rig, sim.frame(0).depth, sim.background().depth)
    centre = np.asarray(sim.scene.objects[0].centre)
    volume = Volume.from_bounds(centre - 0.2, centre + 0.2, 0.002)
    carving = lambda: carve(rig, depth, mask, volume)                  # noqa: E731
    fusion = lambda: fuse(rig, depth, mask, volume).mesh()             # noqa: E731
    return {
        "carve_ms": median_ms(carving, repeat=5, warmup=1),
        "tsdf_ms": median_ms(fusion, repeat=5, warmup=1),
        "carve_peak_mb": peak_mb(carving),
        "tsdf_peak_mb": peak_mb(fusion),
        "dense_voxels": float(volume.size),
    }
