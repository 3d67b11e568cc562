"""Benchmark of carving.

A 300^3 volume (1.33 mm voxels over 40 cm; `carve_ms`) and a 200^3 one (2 mm over the same box;
`carve_200_ms`) around the simulated sphere (640x480 Kinect
frame with noise, two mirrors at 120 deg), with the peak memory at 300^3. The scene and the memory
tracer serve bench.tsdf too.
"""

from __future__ import annotations

import tracemalloc
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from mirrorscan.bench import interleaved_ms
from mirrorcore.dense.carve import carve
from mirrorcore.dense.volume import Volume
from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.rig.model import Rig
from mirrorcore.geometry.shapes import FitErrors, Sphere
from mirrorcore.sim.export import true_rig
from mirrorcore.sim.albedo import object_albedo
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator

BOX = 0.4  # metres: the edge of the cube around the sphere


@dataclass(frozen=True)
class SphereFrames:
    """Prepared frames of the simulated sphere.

    Attributes
    ----------
    rig : Rig
    depths : np.ndarray, shape (F, H, W)
        Metres.
    masks : np.ndarray, shape (F, H, W), bool
    centre : np.ndarray, shape (3,)
        The sphere's centre, metres, camera frame.
    radius : float
        Metres.
    colours : np.ndarray, shape (F, H, W, 3), uint8
        The frames' colour (the rig's colour gains are the mirrors' tints).
    """

    rig: Rig
    depths: np.ndarray
    masks: np.ndarray
    centre: np.ndarray
    radius: float
    colours: np.ndarray

    def volume(self, n: int) -> Volume:
        """n^3 voxels over the box of edge BOX around the sphere.

        Parameters
        ----------
        n : int

        Returns
        -------
        Volume
        """
        return Volume.from_bounds(self.centre - BOX / 2, self.centre + BOX / 2, BOX / n)

    def rmse_mm(self, points: np.ndarray) -> float:
        """RMS distance of points to the true sphere.

        Parameters
        ----------
        points : np.ndarray, shape (n, 3)
            Metres.

        Returns
        -------
        float
            mm.
        """
        return (
            1e3
            * FitErrors.from_deviations(
                Sphere(tuple(self.centre), self.radius).deviations(points)
            ).rmse
        )


    def colour_rmse_levels(self, points: np.ndarray, colours: np.ndarray) -> float:
        """RMS difference of colours to the sphere's albedo at their points.

        Parameters
        ----------
        points : np.ndarray, shape (n, 3)
            Metres.
        colours : np.ndarray, shape (n, 3), uint8

        Returns
        -------
        float
            Levels of 255, over the three channels.
        """
        error = colours.astype(float) - object_albedo(0, points - self.centre)
        return float(np.sqrt(np.mean(error**2)))


def sphere_frames(count: int = 1, seed: int = 0) -> SphereFrames:
    """Frames of the paper's sphere scene, ready for Algorithm 1.

    Parameters
    ----------
    count : int, optional
        Frames to simulate.
    seed : int, optional
        The simulator's seed.

    Returns
    -------
    SphereFrames
    """
    sim = Simulator(paper_scene(object="sphere"), seed=seed)
    rig = replace(true_rig(sim.scene), colour_gains=tuple(m.tint for m in sim.scene.mirrors))
    background = sim.background().depth
    shot = [sim.frame(i) for i in range(count)]
    prepared = [prepare_frame(rig, frame.depth, background) for frame in shot]
    sphere = sim.scene.objects[0]
    return SphereFrames(
        rig,
        np.stack([p[0] for p in prepared]),
        np.stack([p[1] for p in prepared]),
        np.asarray(sphere.centre, float),
        float(sphere.radius),
        np.stack([frame.colour for frame in shot]),
    )


def peak_mb(fn: Callable[[], object]) -> float:
    """Peak of the memory traced (numpy arrays included) while fn() runs.

    Parameters
    ----------
    fn : callable
        Called with no arguments.

    Returns
    -------
    float
        MB.
    """
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 1e6
    finally:
        tracemalloc.stop()


def run() -> dict[str, float]:
    """Carving one frame of the sphere in 300^3 and 200^3 voxels: times and peak memory.

    Returns
    -------
    dict of str to float
        {figure name: value}; names ending in _ms are median milliseconds.
    """
    frames = sphere_frames()
    rig, depth, mask = frames.rig, frames.depths[0], frames.masks[0]
    small, large = frames.volume(200), frames.volume(300)
    times = interleaved_ms(
        {
            "carve_ms": lambda: carve(rig, depth, mask, large),
            "carve_200_ms": lambda: carve(rig, depth, mask, small),
        },
        repeat=5,
        warmup=1,
    )
    return {
        **times,
        "carve_peak_mb": peak_mb(lambda: carve(rig, depth, mask, large)),
        "dense_voxels": float(large.size),
    }
