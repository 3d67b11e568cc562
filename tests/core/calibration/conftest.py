"""Fixtures of the calibration tests."""
import numpy as np
import pytest

from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.sim.export import true_rig
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.sensor import SensorModel
from mirrorcore.sim.simulator import Simulator


# ------------------------------------------------------------------------------- the simulated rig
@pytest.fixture(scope="module")
def sphere():
    """(scene, rig of the true planes, depths (2, H, W), masks (2, H, W)) of the paper's sphere,
    ideal sensor."""
    scene = paper_scene(object="sphere")
    sim = Simulator(scene, SensorModel.ideal(), seed=0)
    rig = true_rig(scene)
    background = sim.background().depth
    depths = np.stack([sim.frame(i).depth for i in range(2)])
    masks = np.stack([prepare_frame(rig, d, background)[1] for d in depths])
    return scene, rig, depths, masks
