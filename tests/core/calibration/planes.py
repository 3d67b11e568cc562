"""Planes moved and rigs with other planes, for the tests of the calibration."""
from dataclasses import replace

import numpy as np

from mirrorcore.calibration.planestep import moved_plane
from mirrorcore.geometry.plane import Plane
from mirrorcore.rig.model import Rig


def with_planes(rig: Rig, planes) -> Rig:
    """The rig with its mirrors' planes replaced, in order."""
    return Rig(rig.intrinsics, tuple(replace(m, plane=p) for m, p in zip(rig.mirrors, planes)))


def nearer(plane: Plane, point, metres: float, tilt_deg: float = 0.0) -> Plane:
    """The plane moved `metres` towards the camera at `point` (3,) and tilted by `tilt_deg`."""
    return moved_plane(plane, np.asarray(point), np.array([np.radians(tilt_deg), 0.0, -metres]))
