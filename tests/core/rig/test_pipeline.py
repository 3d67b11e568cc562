"""A frame prepared for Algorithm 1 (mirrorcore.rig.pipeline): the object's pixels of several
frames at once."""
import numpy as np

from mirrorcore.depth.selection import Selection
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.rig.pipeline import object_masks, prepare_frame
from mirrorcore.sim.export import true_rig
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator

CAMERA = Intrinsics.kinect_v1().scaled(0.5)


def test_object_masks_are_the_masks_prepare_frame_gives_each_frame():
    scene = paper_scene(object="sphere", camera=CAMERA)
    sim = Simulator(scene, seed=1)
    rig, background = true_rig(scene), sim.background().depth
    depths = np.stack([sim.frame(i).depth for i in range(2)])
    selection = Selection()
    masks = object_masks(rig, depths, background, selection)
    assert masks.shape == depths.shape and masks.dtype == bool and masks.any()
    for depth, mask in zip(depths, masks):
        np.testing.assert_array_equal(mask, prepare_frame(rig, depth, background, selection)[1])
