"""What fixes a refined plane (fixing.py): the camera or mirrors fixed themselves; a mirror
nothing fixes is refused by name."""

import numpy as np
import pytest

from mirrorcore.base.errors import CalibrationError
from mirrorcore.calibration.fixing import fixed_by
from mirrorcore.calibration.refine import refine_planes
from mirrorcore.calibration.residuals import Residuals
from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.sim.export import true_rig
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.sensor import SensorModel
from mirrorcore.sim.simulator import Simulator


def test_a_box_facing_the_camera_shares_no_surface_with_the_mirrors():
    """The camera sees the box's front, the mirrors its sides and back: the planes are not
    determined, and the refusal says so by name."""
    scene = paper_scene(object="box")
    sim = Simulator(scene, SensorModel.ideal(), seed=0)
    rig = true_rig(scene)
    depth = sim.frame(0).depth
    mask = prepare_frame(rig, depth, sim.background().depth)[1]
    with pytest.raises(CalibrationError, match="mirror [12]: .* too little"):
        refine_planes(rig, depth[None], mask[None])


def _comparisons(*pairs: tuple[int, int, int]) -> Residuals:
    """Residuals with `count` comparisons of view a's readings against view b's, for each (a, b,
    count)."""
    pair = np.array([(a, b) for a, b, count in pairs for _ in range(count)]).reshape(-1, 2)
    zeros = np.zeros(len(pair))
    return Residuals(np.zeros((len(pair), 3)), zeros, zeros + 1.0, pair)


def test_a_mirror_is_fixed_by_the_camera_or_by_mirrors_fixed_themselves():
    """The middle mirror of an arc shares little with the camera and much with the mirrors beside
    it, which the camera fixes; a cluster of mirrors that the camera fixes none of is refused,
    whatever they share (a box)."""
    arc = _comparisons((1, 0, 150), (0, 1, 150), (3, 0, 300), (2, 0, 20), (2, 1, 400), (3, 2, 100),
                       (2, 3, 100))
    assert fixed_by(arc, [1, 2, 3], ["left", "middle", "right"], 3) == {1: 300, 3: 300, 2: 620}
    # held mirrors fix it too
    assert fixed_by(arc, [2], ["middle"], 3) == {2: 620}
    # a search's guesses: each fixed by the views held, not through the other guesses
    # the mirrors beside it, calibrated
    assert fixed_by(arc, [2], ["middle"], 3, held_only=True) == {2: 620}
    with pytest.raises(CalibrationError,
                       match=r"^middle: .*\(20 readings agree over 3 frame\(s\), 200 are needed; a "
                                               r"plane found without markers must be fixed by the "
                                               r"camera or by "
                                               r"mirrors calibrated before it\); click markers on "
                                               r"it and fit it, then "
                                               r"refine from the object$") as refused:
        fixed_by(arc, [1, 2, 3], ["left", "middle", "right"], 3, held_only=True)
    assert refused.value.mirrors == ("middle",)
    box = _comparisons((1, 0, 18), (1, 2, 5000), (2, 3, 5000), (3, 0, 10))
    with pytest.raises(CalibrationError,
                       match=r"^left, middle and right: the camera and the mirrors see too little "
                                               r"of the same surface to determine their planes "
                                               r"\(left: 18, middle: 0 "
                                               r"and right: 10 readings agree over 10 frame\(s\), "
                                               r"200 are needed; the "
                                               r"readings they share with one another \(left: "
                                               r"5,000, middle: 10,000 "
                                               r"and right: 5,000\) fix nothing, as the camera "
                                               r"fixes none of them\); "
                                               r"refine on") as refused:
        # every mirror named, not the first
        fixed_by(box, [1, 2, 3], ["left", "middle", "right"], 10)
    assert refused.value.mirrors == ("left", "middle", "right")
    with pytest.raises(CalibrationError,
                       match=r"\(10 readings agree over 10 frame\(s\), 200 are needed\); refine"):
        fixed_by(_comparisons((1, 0, 10)), [1], ["left"], 10)
