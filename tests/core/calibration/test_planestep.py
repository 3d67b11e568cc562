"""A plane's step (planestep.py): the reflection's derivative along it."""

import numpy as np
import pytest

from mirrorcore.calibration.planestep import moved_plane, offset_at, reflection_jacobian
from mirrorcore.geometry.plane import Plane


def test_reflection_jacobian_matches_finite_differences():
    rng = np.random.default_rng(0)
    plane = Plane.from_point_normal([0.4, 0.1, 2.6], [-0.5, 0.05, -1.0])
    centre = np.array([0.0, 0.0, 2.0])
    points = rng.uniform([-0.5, -0.5, 2.5], [0.5, 0.5, 3.0], (20, 3))
    direction = rng.normal(size=(20, 3))
    jac = reflection_jacobian(plane, centre, points, direction)
    for k in range(3):
        step = np.zeros(3)
        step[k] = 1e-6
        after = np.einsum("ij,ij->i", direction, moved_plane(plane, centre, step).reflect(points))
        before = np.einsum("ij,ij->i", direction, plane.reflect(points))
        np.testing.assert_allclose((after - before) / 1e-6, jac[:, k], rtol=1e-4, atol=1e-6)
    # the offset step moves the plane along its normal at the centre, the tilts keep it there
    moved = moved_plane(plane, centre, np.array([0.01, -0.02, 0.003]))
    assert offset_at(moved, centre) - offset_at(plane, centre) == pytest.approx(0.003, abs=1e-12)
    assert moved.angle_to(plane) == pytest.approx(np.degrees(np.hypot(0.01, 0.02)), rel=1e-3)
