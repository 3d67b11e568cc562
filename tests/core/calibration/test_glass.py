"""A mirror's glass from its markers (glass.py)."""

import numpy as np
import pytest
from tests.helpers import plane_depth

from mirrorcore.calibration.glass import marker_offset
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane

CAMERA = Intrinsics.kinect_v1()


def test_markers_read_behind_the_silver_give_no_glass():
    """The glass estimated from markers read on a wall at 2 m: 1 mm in front of a plane 1 mm behind
    them, and 0 (not -1 mm: markers cannot stand behind the silver, it is the readings' noise) for a
    plane 1 mm in front of them."""
    wall = Plane((0.0, 0.0, -1.0), 2.0)
    depth = plane_depth(CAMERA, wall).astype(np.float64)
    markers = [(200.0, 200.0), (320.0, 240.0), (440.0, 300.0)]
    glass = marker_offset(CAMERA, depth, markers, Plane((0.0, 0.0, -1.0), 2.001))
    assert glass.offset == pytest.approx(0.001, abs=1e-6) and glass.spread < 1e-6
    assert glass.centroid[2] == pytest.approx(2.0, abs=1e-6)
    assert marker_offset(CAMERA, depth, markers, Plane((0.0, 0.0, -1.0), 1.999)).offset == 0.0
    # the markers read off it unevenly
    tilted = Plane.from_point_normal([0.0, 0.0, 2.0], [0.02, 0.0, -1.0])
    assert marker_offset(CAMERA, depth, markers, tilted).spread > 1e-3
    # a person in front of a fourth marker (0.6 m nearer): that marker is left out, not read as 600
    # mm of glass
    hidden = depth.copy()
    hidden[290:311, 90:111] = 1.4
    glass = marker_offset(CAMERA, hidden, [*markers, (100.0, 300.0)],
                          Plane((0.0, 0.0, -1.0), 2.001))
    assert glass.offset == pytest.approx(0.001, abs=1e-6) and glass.spread < 1e-6
