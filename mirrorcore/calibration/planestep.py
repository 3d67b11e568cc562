"""A mirror plane's step in the refinement: tilt about two axes in the plane (radians) and offset
along its normal at the object's centre (metres), so that tilt and offset stay apart at the object,
where they matter; and the derivative of a reflected point along that step."""
from __future__ import annotations

import numpy as np

from mirrorcore.geometry.plane import Plane


def tangent_basis(n: np.ndarray) -> np.ndarray:
    """Two unit vectors orthogonal to a unit normal and to each other.

    Parameters
    ----------
    n : (3,) float
        Unit vector.

    Returns
    -------
    (2, 3) float64
    """
    e1 = np.cross(n, np.eye(3)[int(np.argmin(np.abs(n)))])
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(n, e1)])


def offset_at(plane: Plane, point) -> float:
    """Return the signed distance of a point from the plane, > 0 on the camera's side.

    Parameters
    ----------
    plane : Plane
    point : (3,) array
        Metres, camera frame.

    Returns
    -------
    float
        Metres.
    """
    return float(plane.signed_distance(np.asarray(point, dtype=np.float64)))


def moved_plane(plane: Plane, centre: np.ndarray, step: np.ndarray) -> Plane:
    """The plane after one step.

    Parameters
    ----------
    plane : Plane
    centre : (3,) float
        Metres, camera frame: where the offset is measured.
    step : (3,) float
        Tilts about the two tangent_basis vectors (radians), then the offset along the normal at
        `centre` (metres).

    Returns
    -------
    Plane
    """
    basis = tangent_basis(plane.n)
    n = plane.n + step[0] * basis[0] + step[1] * basis[1]
    n /= np.linalg.norm(n)
    return Plane.from_abcd([*n, offset_at(plane, centre) + step[2] - float(n @ centre)])


def reflection_jacobian(plane: Plane, centre: np.ndarray, points: np.ndarray,
                        direction: np.ndarray) -> np.ndarray:
    """d(direction . reflect(points)) / d(step) of moved_plane at step 0, direction held fixed.

    reflect(P) = P - 2 s n with s = n . P + d.

    Parameters
    ----------
    plane : Plane
    centre : (3,) float
        Metres, where the step's offset is measured.
    points : (m, 3) float
        Metres, camera frame.
    direction : (m, 3) float
        Unit directions along which each residual is measured.

    Returns
    -------
    (m, 3) float64
    """
    basis = tangent_basis(plane.n)
    s = plane.signed_distance(points)
    along_n = direction @ plane.n
    tilt = -2.0 * (((points - centre) @ basis.T) * along_n[:, None]
                   + s[:, None] * (direction @ basis.T))
    return np.column_stack([tilt, -2.0 * along_n])


def shift_at(before: Plane, after: Plane, point) -> float:
    """Measure how far the plane moved at a point, along its normal, > 0 away from the camera.

    Parameters
    ----------
    before, after : Plane
    point : (3,) array
        Metres, camera frame.

    Returns
    -------
    float
        Metres.
    """
    return offset_at(after, point) - offset_at(before, point)
