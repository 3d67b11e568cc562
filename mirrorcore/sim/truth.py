"""How far a simulated session's calibration, and a cloud of one of its frames, lie from the
simulator's truth (the scene its truth.json holds): the figures the README's accuracy tables give,
for any session `mirrorscan simulate` wrote or recorded from the simulated source
(`mirrorscan truth`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import open3d as o3d

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import project_points
from mirrorcore.io.session import Session
from mirrorcore.sim.objects import object_geometry
from mirrorcore.sim.presets import object_extent
from mirrorcore.sim.scene import Scene, SceneMirror
from mirrorcore.sim.sensor import SensorModel

# the sensor models truth.json names (SensorModel.from_name)
SENSOR_NAMES = ("kinect", "none", "kinect-noiseless")


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

    The offsets are at the first object's middle (the origin without objects). Which scene mirror
    a session mirror is comes from `true_mirrors`.

    Parameters
    ----------
    session : Session
    scene : Scene

    Returns
    -------
    list of PlaneError
        In session order; empty for a session without mirrors.
    """
    at = object_extent(scene.objects[0])[0] if scene.objects else np.zeros(3)
    out = []
    for mirror, true in zip(session.mirrors, true_mirrors(session, scene)):
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
    raycasting, _ = objects_raycasting(scene, t)
    distances = 1e3 * raycasting.compute_distance(o3d.core.Tensor(np.asarray(
        points, np.float32))).numpy()
    return SurfaceError(len(points), float(np.sqrt(np.mean(distances ** 2))),
                        float(distances.mean()),
                        float(np.percentile(distances, 95)))


def objects_raycasting(scene: Scene, t: float = 0.0
                       ) -> tuple[o3d.t.geometry.RaycastingScene, list[int]]:
    """Open3D's raycasting scene over the meshes of the scene's objects.

    Parameters
    ----------
    scene : Scene
    t : float
        Seconds: the objects as they are then.

    Returns
    -------
    raycasting : open3d.t.geometry.RaycastingScene
    ids : list of int
        The geometry id of each object, in scene order.
    """
    raycasting = o3d.t.geometry.RaycastingScene()
    ids = []
    for obj in scene.objects:
        vertices, faces = object_geometry(obj).mesh_at(t)
        ids.append(raycasting.add_triangles(o3d.core.Tensor(np.asarray(vertices, np.float32)),
                                            o3d.core.Tensor(np.asarray(faces, np.uint32))))
    return raycasting, ids


def true_mirrors(session: Session, scene: Scene) -> list[SceneMirror]:
    """The scene's mirror each of a session's mirrors is.

    When every session mirror has an outline, the one whose middle, in the image, is nearest the
    outline's (a session recorded from the simulated source, its mirrors added in any order, some
    perhaps not yet); otherwise the scene's order, as `mirrorcore.sim.export` writes it.

    Parameters
    ----------
    session : Session
    scene : Scene

    Returns
    -------
    list of SceneMirror
        In session order.

    Raises
    ------
    MirrorscanError
        When the mirrors cannot be matched: more of them than in the scene, or a count that differs
        with a mirror without an outline.
    """
    mirrors = session.mirrors
    if not mirrors:
        return []
    if all(len(m.boundary) for m in mirrors) and len(mirrors) <= len(scene.mirrors):
        middles = np.array([m.corners().mean(axis=0) for m in scene.mirrors])
        uv = project_points(session.camera, middles)[0]
        outlines = np.array([np.mean(m.boundary, axis=0) for m in mirrors])
        nearest = np.argmin(np.linalg.norm(outlines[:, None] - uv[None], axis=2), axis=1)
        if len(set(nearest.tolist())) == len(mirrors):
            return [scene.mirrors[k] for k in nearest]
    if len(mirrors) != len(scene.mirrors):
        raise MirrorscanError(
            f"the session has {len(mirrors)} mirrors, its truth {len(scene.mirrors)}: a "
            "mirror was added or removed since it was simulated")
    return list(scene.mirrors)


def sensor_name(sensor: SensorModel) -> str:
    """The name truth.json gives a sensor model: one of SENSOR_NAMES, or 'custom'.

    Parameters
    ----------
    sensor : SensorModel

    Returns
    -------
    str
    """
    return next((name for name in SENSOR_NAMES if SensorModel.from_name(name) == sensor),
                "custom")


def frame_time(session: Session, frame: int, fps: float) -> float:
    """The simulator's time (seconds) of a session's frame.

    Its timestamp when the session has them (a recording of the simulated source: the simulator's
    own times), else frame / fps (`mirrorscan simulate` writes frame i at i / fps).

    Parameters
    ----------
    session : Session
    frame : int
        0-based.
    fps : float

    Returns
    -------
    float
    """
    stamps = session.timestamps
    if stamps and len(stamps) == len(session.frames):
        return float(stamps[frame])
    return frame / fps
