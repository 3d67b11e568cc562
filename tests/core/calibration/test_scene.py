"""Calibration without markers (scene.py, search.py): the search, then the refinement, in
rounds; an outline drawn too narrow is named."""
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mirrorcore.base.errors import CalibrationError
from mirrorcore.calibration.planestep import offset_at
from mirrorcore.calibration.scene import calibrate_scene
from mirrorcore.calibration.search import search_plane
from mirrorcore.io.session import Session
from mirrorcore.rig.model import Rig
from mirrorcore.sim.export import session_mirrors
from mirrorcore.sim.sensor import SensorModel
from mirrorcore.sim.simulator import Simulator
from tests.core.calibration.planes import with_planes


def test_scene_search_then_refinement_without_markers(sphere):
    scene, rig, depths, masks = sphere
    centre = np.asarray(scene.objects[0].centre)
    blind = with_planes(rig, [None, None])
    found = search_plane(blind, depths[0], masks[0], 0, np.random.default_rng(0)).plane
    # near enough for the refinement (which comes back from a plane too near the camera), not more
    assert -0.1 < offset_at(found, centre) - offset_at(rig.mirrors[0].plane, centre) < 0.0
    assert found.angle_to(rig.mirrors[0].plane) < 5.0
    sim = Simulator(scene, SensorModel.ideal())
    session = Session(Path("."), rig.intrinsics,
                      tuple(replace(m, markers=())
                            for m in session_mirrors(sim, sim.frame(0).truth)))
    fractions = []
    calibrated, result = calibrate_scene(session, depths, masks, np.random.default_rng(0),
                                         progress=fractions.append)
    # the search tells too
    assert fractions == sorted(fractions) and fractions[-1] == 1.0 and fractions[0] < 0.05
    for mirror, truth in zip(calibrated.mirrors, rig.mirrors):
        assert abs(offset_at(mirror.plane, centre) - offset_at(truth.plane, centre)) < 1e-3
        assert mirror.plane.angle_to(truth.plane) < 0.05
    with pytest.raises(CalibrationError,
                       match=r"mirror 2: the object is not seen in the mirror in this frame \(0 "):
        search_plane(blind, depths[0], masks[0] & (rig.inside_bits != 2), 1,
                     np.random.default_rng(0))
    with pytest.raises(CalibrationError,
                       match=r"mirror 2: the object is not seen directly outside the mirrors' "
                                               r"outlines in this frame \(0 readings there, 100 "
                                               r"needed; [1-9]\d+ more"):
        search_plane(blind, depths[0], masks[0] & (rig.inside_bits != 0), 1,
                     np.random.default_rng(0))


def test_an_outline_drawn_too_narrow_is_named_and_the_other_mirror_is_still_found(sphere):
    """Mirror 1's outline 80 px narrower on its left: part of its image of the sphere lies outside
    every outline, where it could be taken for the object seen directly. Its search says that its
    image spills over its outline; mirror 2's is found as with the right outline."""
    scene, rig, depths, masks = sphere
    boundary = np.array(rig.mirrors[0].boundary, float)
    boundary[boundary[:, 0] < boundary[:, 0].mean(), 0] += 80.0
    narrow = Rig(rig.intrinsics,
                 (replace(rig.mirrors[0], plane=None, boundary=tuple(map(tuple, boundary))),
                                  replace(rig.mirrors[1], plane=None)))
    spilled = masks[0] & (narrow.inside_bits == 0) & (rig.inside_bits != 0) & (depths[0] > 2.3)
    # its image, outside every outline
    assert np.count_nonzero(spilled) > 500
    with pytest.raises(CalibrationError,
                       match=r"^mirror 1: \d+ readings just outside its outline lie beyond the "
                                               r"object seen directly: its image spills over the "
                                               r"outline; draw"):
        search_plane(narrow, depths[0], masks[0], 0, np.random.default_rng(0))
    found = search_plane(narrow, depths[0], masks[0], 1, np.random.default_rng(0)).plane
    centre = np.asarray(scene.objects[0].centre)
    assert -0.1 < offset_at(found, centre) - offset_at(rig.mirrors[1].plane, centre) < 0.0
    assert found.angle_to(rig.mirrors[1].plane) < 5.0
    # calibrated without markers, mirror 2 is found and written, mirror 1 named with why (the
    # refusal of one mirror does not drop the others)
    sim = Simulator(scene, SensorModel.ideal())
    mirrors = [replace(m, markers=(), plane=None) for m in session_mirrors(sim, sim.frame(0).truth)]
    mirrors[0] = replace(mirrors[0], boundary=tuple(map(tuple, boundary)))
    calibrated, result = calibrate_scene(Session(Path("."), rig.intrinsics, tuple(mirrors)), depths,
                                         masks,
                                         np.random.default_rng(0))
    assert [m.index for m in result.mirrors] == [1] and calibrated.mirrors[0].plane is None
    assert [i for i, _ in result.refused] == [
        0] and "its image spills over the outline" in result.refused[0][1]
    assert abs(offset_at(calibrated.mirrors[1].plane, centre) - offset_at(rig.mirrors[
        1].plane, centre)) < 1e-3
