"""The ready-made objects of the simulated scenes: a command-line object name to a SceneObject on
the optical axis (`make_object`), its default distance, and its middle, half-width and height."""
from __future__ import annotations

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.sim.scene import SceneObject

SPHERE_RADIUS = 0.115       # the paper's sphere (figure 4)
CYLINDER_RADIUS = 0.150     # the paper's cylinder (figure 5)
FIGURE_HEIGHT = 1.75
OBJECT_DISTANCE = 2.0       # metres from the camera to the object by default: the paper's...
# ... and to the figure, which a Kinect sees whole, feet to head, only from about 3 m
FIGURE_DISTANCE = 3.0
UP = np.array([0.0, -1.0, 0.0])


def default_distance(spec: str) -> float:
    """Return the metres from the camera to an object of that name when none is given.

    FIGURE_DISTANCE for the figure (nearer, its head or feet leave the image and the mirrors'
    markers with them), else OBJECT_DISTANCE.

    Parameters
    ----------
    spec : str
        The object's name.

    Returns
    -------
    float
        Metres.
    """
    return FIGURE_DISTANCE if spec == "figure" else OBJECT_DISTANCE


def make_object(spec: str, distance: float | None = None, floor_y: float = 1.0,
                gait_hz: float = 1.0) -> SceneObject:
    """Make a scene object on the optical axis.

    The sphere has the paper's radius 0.115 m, the cylinder 0.15 m (0.6 m tall, vertical), the box
    is a 0.3 m cube; the figure (1.75 m, walking at `gait_hz` strides/s) stands on the floor at
    y = floor_y.

    Parameters
    ----------
    spec : str
        'sphere', 'cylinder', 'box', 'figure' or 'mesh:PATH'.
    distance : float, optional
        Metres from the camera (`default_distance` when None).
    floor_y : float
        Metres below the camera.
    gait_hz : float
        The figure's strides per second.

    Returns
    -------
    SceneObject

    Raises
    ------
    MirrorscanError
        An unknown name.
    """
    distance = default_distance(spec) if distance is None else distance
    centre = (0.0, 0.0, float(distance))
    if spec == "sphere":
        return SceneObject("sphere", centre, radius=SPHERE_RADIUS)
    if spec == "cylinder":
        return SceneObject("cylinder", centre, radius=CYLINDER_RADIUS, height=0.6,
                           axis=(0.0, 1.0, 0.0))
    if spec == "box":
        return SceneObject("box", centre, size=(0.3, 0.3, 0.3))
    if spec == "figure":
        return SceneObject("figure", (0.0, floor_y, float(distance)), height=FIGURE_HEIGHT,
                           gait_hz=gait_hz)
    if spec.startswith("mesh:") and len(spec) > 5:
        return SceneObject("mesh", centre, path=spec[5:])
    raise MirrorscanError(
        f"unknown object {spec!r}: use sphere, cylinder, box, figure or mesh:PATH")


def object_extent(obj: SceneObject) -> tuple[np.ndarray, float, float]:
    """Return the middle of an object, its horizontal half-size and its height.

    A mesh counts as 0.3 m wide.

    Parameters
    ----------
    obj : SceneObject

    Returns
    -------
    middle : (3,) array
        Metres, camera frame.
    half_width : float
        Metres.
    height : float
        Metres.
    """
    centre = np.asarray(obj.centre, dtype=np.float64)
    if obj.type == "figure":
        return centre + UP * obj.height / 2, 0.3 * obj.height / 1.75, obj.height
    half = {"sphere": obj.radius, "cylinder": obj.radius,
            "box": max(obj.size[0], obj.size[2]) / 2}.get(obj.type, 0.15)
    tall = {"sphere": 2 * obj.radius, "cylinder": obj.height, "box": obj.size[1]}.get(obj.type, 0.3)
    return centre, half, tall

