"""How far a simulated session's calibration, and a cloud of one of its frames, lie from the
simulator's truth (the scene its truth.json holds): the figures the README's accuracy tables give,
for any session `mirrorscan simulate` wrote (`mirrorscan truth`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import open3d as o3d

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.session import Session
from mirrorcore.sim.objects import object_geometry
from mirrorcore.sim.presets import object_extent
from mirrorcore.sim.scene import Scene


@dataclass(frozen=True)
class PlaneError:
    """One mirror's plane against its true plane.

    Measured at the object's middle (presets.object_extent: a figure's is half its height above the
    floor point between its feet).

    Attributes
    ----------
    name : str
    offset_mm : float or None
        Along the normal, mm (> 0: the plane too far from the camera); None while it has no plane.
    tilt_deg : float or None
        Degrees; None while it has no plane.
    glass_mm : float
        The session's marker_offset, mm.
    true_glass_mm : float
        The true one, mm.
    """

    name: str
    offset_mm: float | None
    tilt_deg: float | None
    glass_mm: float
    true_glass_mm: float


@dataclass(frozen=True)
class SurfaceError:
    """A cloud's distances to the true surfaces of the scene's objects, mm.

    Attributes
    ----------
    points : int
    rmse_mm, mean_mm, p95_mm : float
        RMSE, mean and 95th percentile, mm.
    """

    points: int
    rmse_mm: float
    mean_mm: float
    p95_mm: float


def plane_errors(session: Session, scene: Scene) -> list[PlaneError]:
    """Measure each mirror of a session against the scene's mirror in the same place.

    Session order is the scene's order, as `mirrorcore.sim.export` writes it; the offsets are at the
    first object's middle (the origin without objects).

    Parameters
    ----------
    session : Session
    scene : Scene

    Returns
    -------
    list of PlaneError
    """
    if len(session.mirrors) != len(scene.mirrors):
        raise MirrorscanError(
            f"the session has {len(session.mirrors)} mirrors, its truth {len(scene.mirrors)}: a "
                              "mirror was added or removed since it was simulated")
    at = object_extent(scene.objects[0])[0] if scene.objects else np.zeros(3)
    out = []
    for mirror, true in zip(session.mirrors, scene.mirrors):
        plane = mirror.plane
        out.append(PlaneError(
            mirror.name,
            None if plane is None else 1e3 * float(plane.signed_distance(
                at) - true.plane.signed_distance(at)),
            None if plane is None else plane.angle_to(true.plane),
            1e3 * mirror.marker_offset, 1e3 * true.marker_offset))
    return out


def surface_error(points: np.ndarray, scene: Scene, t: float = 0.0) -> SurfaceError:
    """Measure the distances of points to the nearest surface of the scene's objects.

    By Open3D's raycasting scene over their meshes (the sphere's icosphere lies within 0.1 mm of
    the true sphere).

    Parameters
    ----------
    points : (n, 3) array
        Metres, camera frame.
    scene : Scene
    t : float
        Seconds: the objects as they are then (a walking figure moves).

    Returns
    -------
    SurfaceError
    """
    if not scene.objects:
        raise MirrorscanError("the scene has no object to compare with")
    if len(points) == 0:
        raise MirrorscanError("the cloud has no points")
    raycasting = o3d.t.geometry.RaycastingScene()
    for obj in scene.objects:
        vertices, faces = object_geometry(obj).mesh_at(t)
        raycasting.add_triangles(o3d.core.Tensor(np.asarray(vertices, np.float32)),
                                 o3d.core.Tensor(np.asarray(faces, np.uint32)))
    distances = 1e3 * raycasting.compute_distance(o3d.core.Tensor(np.asarray(
        points, np.float32))).numpy()
    return SurfaceError(len(points), float(np.sqrt(np.mean(distances ** 2))),
                        float(distances.mean()),
                        float(np.percentile(distances, 95)))
