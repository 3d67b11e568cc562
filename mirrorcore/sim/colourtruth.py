"""How far a cloud's colours lie from the simulated scene's albedo, per source
(`mirrorscan truth --cloud`).

Each point is measured against the albedo of the surface ITS PIXEL sees: the point, mirrored
back through the true planes of its view (its source label's mirrors, last first), projected to
its pixel, whose true hit point in the frame's ideal render gives the albedo
(`mirrorcore.sim.albedo.surface_albedo`). A depth error moves a point but not its pixel, so
this measures the colour apart from the position (which `surface_error` measures in mm). The
albedo at the point's own position (`true_albedo`) gives a secondary share: a point that a depth
error moved across a checker edge is 100 levels or more off there.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import open3d as o3d

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.base.palette import source_sequence
from mirrorcore.geometry.camera import Intrinsics, project_points
from mirrorcore.geometry.plane import Plane
from mirrorcore.sim.albedo import object_albedo, room_albedo, surface_albedo
from mirrorcore.sim.render import GroundTruth, Renderer
from mirrorcore.sim.scene import Scene
from mirrorcore.sim.truth import objects_raycasting

# levels: a point whose three channels all lie this near the albedo has its surface's colour (one
# that a depth error moved into the next checker cell is at least 100 levels off in a channel)
WITHIN_LEVELS = 10


@dataclass(frozen=True)
class ColourError:
    """The colours of one source's points against the albedo their pixels see, in levels (of
    255).

    Attributes
    ----------
    source : int or None
        The source label (0 direct, j mirror j, ...); None for every point of a cloud without
        labels (taken as seen directly).
    points : int
        The points measured: those whose pixel lies in the image and sees a surface.
    unseen : int
        The source's points left out: their pixel lies outside the image or sees nothing.
    bias : (3,) tuple of float, or None
        Mean of (cloud - albedo) per channel (red, green, blue), levels; > 0: too bright. None
        without a point measured.
    rmse : float or None
        Root mean square of (cloud - albedo) over the points and their three channels, levels.
    ratio : float or None
        rmse over the direct view's (label 0) rmse; None without a direct view measured or
        when its rmse is 0.
    within : float or None
        The fraction of the points whose three channels all lie within WITHIN_LEVELS of their
        pixel's albedo.
    within_at_point : float or None
        The same against the albedo at the point's own position (`true_albedo`): it falls where
        depth errors move points across the checker's edges.
    """

    source: int | None
    points: int
    unseen: int
    bias: tuple[float, float, float] | None
    rmse: float | None
    ratio: float | None
    within: float | None
    within_at_point: float | None


def true_albedo(points: np.ndarray, scene: Scene, t: float = 0.0) -> np.ndarray:
    """Return the scene's albedo at each point: the colour the simulator gives its surface.

    A point takes the albedo of the object whose surface is nearest it
    (`object_albedo(index, point - centre)`, as the simulator colours its renders), or the
    floor's or back wall's colour where one of those planes is nearer than every object.

    Parameters
    ----------
    points : (n, 3) array
        Metres, camera frame.
    scene : Scene
    t : float
        Seconds: the objects as they are then (a walking figure moves).

    Returns
    -------
    (n, 3) float32 array
        RGB levels 0 to 255.

    Raises
    ------
    MirrorscanError
        The scene has no object.
    """
    if not scene.objects:
        raise MirrorscanError("the scene has no object to compare with")
    points = np.asarray(points, np.float32).reshape(-1, 3)
    raycasting, ids = objects_raycasting(scene, t)
    closest = raycasting.compute_closest_points(o3d.core.Tensor(points))
    nearest = closest["geometry_ids"].numpy()

    to_object = np.linalg.norm(points - closest["points"].numpy(), axis=1)
    albedo = np.zeros((len(points), 3), np.float32)
    for index, (obj, geometry) in enumerate(zip(scene.objects, ids)):
        sel = nearest == geometry
        albedo[sel] = object_albedo(index, points[sel] - np.asarray(obj.centre, np.float32))
    room = scene.room
    if room is not None:
        to_floor = np.abs(points[:, 1] - room.floor_y)
        to_wall = np.abs(points[:, 2] - room.back_z)
        on_room = np.minimum(to_floor, to_wall) < to_object
        albedo[on_room] = room_albedo(points[on_room], room)
    return albedo


def has_scene_colour(colours: np.ndarray | None, sources: np.ndarray | None) -> bool:
    """Return whether a cloud's colours can be the scene's.

    Parameters
    ----------
    colours : (n, 3) uint8 array or None
        The vertices' RGB; None for a cloud without colour.
    sources : (n,) integer array or None
        Source labels; None treats the cloud as one source.

    Returns
    -------
    bool
        False without colours, or when every source's points share one colour (the source
        palette, whatever the mirrors' colours in it).
    """
    if colours is None or len(colours) == 0:
        return False
    labels = np.zeros(len(colours), np.int64) if sources is None else np.asarray(sources, np.int64)
    order = np.argsort(labels, kind="stable")
    labels, colours = labels[order], np.asarray(colours)[order]
    # one colour per label: every point matches the first of its label
    first = np.searchsorted(labels, labels)
    return bool(np.any(colours != colours[first]))


def view_pixels(points: np.ndarray, sources: np.ndarray | None, planes: Sequence[Plane],
                camera: Intrinsics) -> np.ndarray:
    """Return the pixel each point was seen at: the point mirrored back through its view's planes.

    A point of label L seen through mirrors (a, ..., z) in the order the camera's ray meets them
    is a virtual point R_a(...R_z(point)): reflected through z's plane first, a's last; that
    projects to its pixel.

    Parameters
    ----------
    points : (n, 3) array
        Metres, camera frame (the real points).
    sources : (n,) integer array or None
        Source labels (`mirrorcore.base.palette`); None: every point seen directly.
    planes : sequence of Plane
        Mirror j's plane at planes[j - 1] (session order).
    camera : Intrinsics

    Returns
    -------
    (n,) int64 array
        Flat (row-major) pixel indices, -1 where the point projects outside the image.

    Raises
    ------
    MirrorscanError
        A label names a mirror that `planes` does not have.
    """
    virtual = np.array(points, np.float64).reshape(-1, 3)
    if sources is not None:
        sources = np.asarray(sources, np.int64)
        for label in np.unique(sources):
            sequence = source_sequence(int(label))
            if any(j > len(planes) for j in sequence):
                raise MirrorscanError(f"the cloud's source label {label} names a mirror the "
                                      f"session does not have ({len(planes)} mirrors)")
            of = sources == label
            for j in reversed(sequence):
                virtual[of] = planes[j - 1].reflect(virtual[of])
    uv, _ = project_points(camera, virtual)
    inside = np.all(np.isfinite(uv), axis=1)
    col, row = np.zeros(len(uv), np.int64), np.zeros(len(uv), np.int64)
    col[inside], row[inside] = np.rint(uv[inside]).astype(np.int64).T
    inside &= (col >= 0) & (col < camera.width) & (row >= 0) & (row < camera.height)
    return np.where(inside, row * camera.width + col, -1)


def colour_errors(points: np.ndarray, sources: np.ndarray | None, colours: np.ndarray,
                  scene: Scene, planes: Sequence[Plane], t: float = 0.0,
                  truth: GroundTruth | None = None) -> list[ColourError]:
    """Measure a cloud's colours against the albedo each point's pixel sees, per source.

    Parameters
    ----------
    points : (n, 3) array
        Metres, camera frame.
    sources : (n,) integer array or None
        Source labels; None gives one ColourError over every point (source None), each taken
        as seen directly.
    colours : (n, 3) uint8 array
        RGB levels of the points.
    scene : Scene
    planes : sequence of Plane
        The true plane of each of the cloud's mirrors (label j: planes[j - 1]).
    t : float
        Seconds: the frame's time (a walking figure moves).
    truth : GroundTruth, optional
        The scene's ideal render at t; rendered when not given.

    Returns
    -------
    list of ColourError
        One per label present, in label order.

    Raises
    ------
    MirrorscanError
        The cloud has no points, the scene no object, or a label names a mirror not in planes.
    """
    if len(points) == 0:
        raise MirrorscanError("the cloud has no points")
    points = np.asarray(points, np.float32).reshape(-1, 3)
    pixels = view_pixels(points, sources, planes, scene.camera)
    if truth is None:
        truth = Renderer(scene).render(t)
    albedo = np.full((len(points), 3), np.nan, np.float32)
    albedo[pixels >= 0] = surface_albedo(scene, truth, pixels[pixels >= 0])
    colours = np.asarray(colours, np.float32).reshape(-1, 3)
    error = colours - albedo
    at_point = np.all(np.abs(colours - true_albedo(points, scene, t)) <= WITHIN_LEVELS, axis=1)
    seen = np.all(np.isfinite(albedo), axis=1)
    labels = np.zeros(len(points), np.int64) if sources is None else np.asarray(sources)
    groups = [(None if sources is None else int(s), labels == s) for s in np.unique(labels)]
    direct = next((np.sqrt(np.mean(error[sel & seen] ** 2)) for s, sel in groups
                   if not s and np.any(sel & seen)), None)
    out = []
    for label, of in groups:
        unseen = int(np.count_nonzero(of & ~seen))
        sel = of & seen
        if not sel.any():
            out.append(ColourError(label, 0, unseen, None, None, None, None, None))
            continue
        rmse = float(np.sqrt(np.mean(error[sel] ** 2)))
        out.append(ColourError(
            label, int(sel.sum()), unseen, tuple(float(b) for b in error[sel].mean(axis=0)),
            rmse, None if not direct else rmse / float(direct),
            float(np.mean(np.all(np.abs(error[sel]) <= WITHIN_LEVELS, axis=1))),
            float(np.mean(at_point[sel]))))
    return out
