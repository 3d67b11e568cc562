"""How far a cloud's colours lie from the simulated scene's albedo, per source
(`mirrorscan truth --cloud`): the albedo of the object nearest each point, at the point
(mirrorcore.sim.albedo), or the room's colour where the point lies on the room."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import open3d as o3d

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.sim.albedo import FLOOR_COLOUR, WALL_COLOUR, object_albedo
from mirrorcore.sim.scene import Scene
from mirrorcore.sim.truth import objects_raycasting

# levels: a point whose three channels all lie this near the albedo has its surface's colour (one
# that a depth error moved into the next checker cell is at least 100 levels off in a channel)
WITHIN_LEVELS = 10


@dataclass(frozen=True)
class ColourError:
    """The colours of one source's points against the scene's albedo, in levels (of 255).

    Attributes
    ----------
    source : int or None
        The source label (0 direct, j mirror j, ...); None for every point of a cloud without
        labels.
    points : int
    bias : (3,) tuple of float
        Mean of (cloud - albedo) per channel (red, green, blue), levels; > 0: too bright.
    rmse : float
        Root mean square of (cloud - albedo) over the points and their three channels, levels.
    within : float
        The fraction of the points whose three channels all lie within WITHIN_LEVELS of the
        albedo.
    """

    source: int | None
    points: int
    bias: tuple[float, float, float]
    rmse: float
    within: float


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
        albedo[on_room] = np.where((to_floor < to_wall)[on_room, None],
                                   np.float32(FLOOR_COLOUR), np.float32(WALL_COLOUR))
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


def colour_errors(points: np.ndarray, sources: np.ndarray | None, colours: np.ndarray,
                  scene: Scene, t: float = 0.0) -> list[ColourError]:
    """Measure a cloud's colours against the scene's albedo, per source.

    Parameters
    ----------
    points : (n, 3) array
        Metres, camera frame.
    sources : (n,) integer array or None
        Source labels; None gives one ColourError over every point (source None).
    colours : (n, 3) uint8 array
        RGB levels of the points.
    scene : Scene
    t : float
        Seconds: the objects as they are then.

    Returns
    -------
    list of ColourError
        One per label present, in label order.

    Raises
    ------
    MirrorscanError
        The cloud has no points, or the scene no object.
    """
    if len(points) == 0:
        raise MirrorscanError("the cloud has no points")
    error = np.asarray(colours, np.float32).reshape(-1, 3) - true_albedo(points, scene, t)
    if sources is None:
        groups = [(None, np.ones(len(error), bool))]
    else:
        sources = np.asarray(sources)
        groups = [(int(s), sources == s) for s in np.unique(sources)]
    return [ColourError(label, int(sel.sum()),
                        tuple(float(b) for b in error[sel].mean(axis=0)),
                        float(np.sqrt(np.mean(error[sel] ** 2))),
                        float(np.mean(np.all(np.abs(error[sel]) <= WITHIN_LEVELS, axis=1))))
            for label, sel in groups]
