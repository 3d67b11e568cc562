"""Shared scenes for the dense-reconstruction tests: the paper's sphere (r = 115 mm at 2 m, two
mirrors at 120 deg) on the simulator with its true planes and the mirrors' outlines."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.rig.model import Rig
from mirrorcore.sim.export import true_rig
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.render import GroundTruth
from mirrorcore.sim.sensor import SensorModel
from mirrorcore.sim.simulator import Simulator


@dataclass(frozen=True, eq=False)
class SphereScene:
    rig: Rig
    depth: np.ndarray
    background: np.ndarray
    truth: GroundTruth
    centre: np.ndarray
    radius: float


def sphere_scene(scale: float, sensor: SensorModel, seed: int = 0) -> SphereScene:
    scene = paper_scene(camera=Intrinsics.kinect_v1().scaled(scale))
    sim = Simulator(scene, sensor, seed)
    rig = true_rig(scene)
    frame = sim.frame(0)
    obj = scene.objects[0]
    return SphereScene(
        rig, frame.depth, sim.background().depth, frame.truth, np.asarray(obj.centre), obj.radius
    )
