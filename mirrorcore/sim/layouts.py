"""Ready-made scenes: the paper's two mirrors in a V behind the object (`paper_scene`), a hinged
pair that meets at the apex (`kaleidoscope_scene`: views through several mirrors in turn), and three
or more mirrors on an arc around it (`arc_scene`), each around an object of
mirrorcore.sim.presets."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.sim.placement import markers_in_view
from mirrorcore.sim.presets import UP, make_object, object_extent
from mirrorcore.sim.scene import Room, Scene, SceneMirror
from mirrorcore.sim.sensor import SensorModel

MIRROR_SIZE = (0.6, 1.0)    # width, height, metres
MARKER_SIZE = 0.04
APEX_GAP = 0.02             # clearance between a V mirror's inner edge and the apex, metres
# between the inner edges of a hinged pair (kaleidoscope_scene) and their apex, metres
HINGE_GAP = 0.002
# width of each mirror of a hinged pair, metres: past the object's images in it
HINGED_WIDTH = 1.4
# default gap between the object and each mirror of a hinged pair, metres
HINGED_CLEARANCE = 0.135
# a hinged pair is seen obliquely: larger markers keep several pixels wide in the image
HINGED_MARKER_SIZE = 0.08


def corner_markers(width: float, height: float) -> tuple[tuple[float, float], ...]:
    """Six markers near the corners and the middles of the top and bottom edges (spread, not
    collinear)."""
    s, t = 0.42 * width, 0.42 * height
    return ((-s, -t), (0.0, -t), (s, -t), (-s, t), (0.0, t), (s, t))


def _mirror(name: str, centre: np.ndarray, normal: np.ndarray, size: tuple[float, float],
            marker_size: float = MARKER_SIZE) -> SceneMirror:
    """A vertical SceneMirror of `size` at `centre`, facing `normal`, with markers."""
    return SceneMirror(name, tuple(centre.tolist()), tuple(normal.tolist()), tuple(UP.tolist()),
                       size[0], size[1],
                  corner_markers(*size), marker_size)


def _v_frame(angle_deg: float, target: np.ndarray, mirror_distance: float, turn_deg: float = 0.0):
    """The V of two vertical mirrors behind `target`: its apex (3,) and, per mirror (left, right),
    the unit normal to its reflective side and the unit direction `along` its glass from the apex
    towards the camera's side. The V's bisector points from the camera to the target, turned by
    `turn_deg` about the vertical (positive: apex to +x)."""
    if not 10.0 <= angle_deg <= 175.0:
        raise MirrorscanError(
            f"--angle: the angle between the mirrors must be within 10 to 175 degrees, "
                              f"got {angle_deg:g}")
    half, turn = np.radians(angle_deg) / 2, np.radians(turn_deg)
    toward = target * [1.0, 0.0, 1.0]                  # horizontal: the mirrors stand vertical
    toward /= np.linalg.norm(toward)
    across = np.cross(toward, UP)
    across /= np.linalg.norm(across)                  # +x for a target on the optical axis
    forward = np.cos(turn) * toward + np.sin(turn) * across
    side = np.cos(turn) * across - np.sin(turn) * toward
    apex = target + forward * mirror_distance / np.sin(half)
    sides = [(-sign * np.cos(half) * side - np.sin(half) * forward,           # normal
              sign * np.sin(half) * side - np.cos(half) * forward)            # along
             for sign in (-1.0, 1.0)]
    return apex, sides


def v_mirrors(angle_deg: float, target: np.ndarray, mirror_distance: float,
              size: tuple[float, float] = MIRROR_SIZE) -> tuple[SceneMirror, SceneMirror]:
    """Place two vertical mirrors in a V behind a target, apex on the far side.

    Each plane is `mirror_distance` metres from the target; each mirror is centred where the
    camera's ray to the target's virtual image crosses its plane (kept clear of the apex). Mirror 1
    is on the left (-x), mirror 2 right.

    Parameters
    ----------
    angle_deg : float
        Degrees between the mirrors' surfaces.
    target : (3,) array
        Metres, camera frame.
    mirror_distance : float
        Metres.
    size : (float, float)
        (width, height) of each mirror, metres.

    Returns
    -------
    (SceneMirror, SceneMirror)
    """
    apex, sides = _v_frame(angle_deg, target, mirror_distance)
    mirrors = []
    for j, (normal, along) in enumerate(sides):
        # virtual image of the target
        image = target - 2 * mirror_distance * normal
        crossing = image * np.dot(normal, apex) / np.dot(normal, image)
        s = max(float(np.dot(crossing - apex, along)), size[0] / 2 + APEX_GAP)
        mirrors.append(_mirror(f"mirror {j + 1}", apex + s * along, normal, size))
    return tuple(mirrors)


def hinged_mirrors(angle_deg: float, target: np.ndarray, mirror_distance: float,
                   size: tuple[float, float],
                   turn_deg: float) -> tuple[SceneMirror, SceneMirror]:
    """Place two vertical mirrors that meet at the apex of a V behind a target (the kaleidoscope).

    Mirror 1 is on the left, mirror 2 right.

    Parameters
    ----------
    angle_deg : float
        Degrees between the mirrors' surfaces.
    target : (3,) array
        Metres, camera frame.
    mirror_distance : float
        Metres from the target to each mirror.
    size : (float, float)
        (width, height) of each mirror, metres, from HINGE_GAP off the apex outwards.
    turn_deg : float
        Degrees the V is turned about the vertical (see `_v_frame`).

    Returns
    -------
    (SceneMirror, SceneMirror)
    """
    apex, sides = _v_frame(angle_deg, target, mirror_distance, turn_deg)
    return tuple(_mirror(f"mirror {j + 1}", apex + (HINGE_GAP + size[0] / 2) * along, normal, size,
                         HINGED_MARKER_SIZE) for j, (normal, along) in enumerate(sides))


def arc_mirrors(n_mirrors: int, target: np.ndarray, radius: float, span_deg: float,
                clearance: float,
                size: tuple[float, float] = MIRROR_SIZE) -> tuple[SceneMirror, ...]:
    """Place mirrors on an arc around a target, left to right.

    Each faces the half-way direction between the camera and the target, so the camera sees the
    target's image in the mirror's middle. A mirror whose image would hide behind the real object
    (within 25 deg of straight behind) is raised by `clearance` and tilted down to it.

    Parameters
    ----------
    n_mirrors : int
    target : (3,) array
        Metres, camera frame.
    radius : float
        Metres.
    span_deg : float
        Degrees spanned, centred on the far side.
    clearance : float
        Metres.
    size : (float, float)
        (width, height) of each mirror, metres.

    Returns
    -------
    tuple of SceneMirror
    """
    mirrors = []
    for j, phi in enumerate(np.radians(np.linspace(-span_deg / 2, span_deg / 2, n_mirrors))):
        centre = target + radius * np.array([np.sin(phi), 0.0, np.cos(phi)])
        if abs(phi) < np.radians(25.0):
            centre = centre + UP * clearance
        normal = -centre / np.linalg.norm(centre) + (target - centre) / np.linalg.norm(
            target - centre)
        mirrors.append(_mirror(f"mirror {j + 1}", centre, normal / np.linalg.norm(normal), size))
    return tuple(mirrors)


def paper_scene(angle_deg: float = 120.0, n_mirrors: int = 2, object: str = "sphere",
                distance: float | None = None,
                mirror_distance: float | None = None, camera: Intrinsics | None = None,
                room: Room | None = Room(),
                gait_hz: float = 1.0) -> Scene:
    """Build the paper's setup (its figure 2).

    A Kinect v1 (640x480), the object on the optical axis, two mirrors in a V behind it, a floor 1 m
    below the camera and a back wall.

    Parameters
    ----------
    angle_deg : float
        Degrees between the mirrors.
    n_mirrors : int
        More than 2 gives `arc_scene` instead.
    object : str
        As `make_object`.
    distance : float, optional
        Metres to the object (`presets.default_distance` when None).
    mirror_distance : float, optional
        Metres from the object's middle (default: its half-width + 0.25 m).
    camera : Intrinsics, optional
        Default Kinect v1.
    room : Room or None
    gait_hz : float
        The figure's strides per second.

    Returns
    -------
    Scene
    """
    if n_mirrors < 2:
        raise MirrorscanError(f"--mirrors: at least 2 mirrors are needed, got {n_mirrors}")
    if n_mirrors > 2:
        return arc_scene(n_mirrors, object, distance, camera=camera, room=room, gait_hz=gait_hz)
    obj = make_object(object, distance, room.floor_y if room else Room.floor_y, gait_hz)
    target, half, tall = object_extent(obj)
    md = half + 0.25 if mirror_distance is None else mirror_distance
    size = (max(MIRROR_SIZE[0], 4 * half), max(MIRROR_SIZE[1], 1.1 * tall))
    return Scene(camera or Intrinsics.kinect_v1(), v_mirrors(angle_deg, target, md, size), (obj,),
                 room)


def arc_scene(n_mirrors: int = 3, object: str = "sphere", distance: float | None = None,
              radius: float | None = None,
              span_deg: float | None = None, camera: Intrinsics | None = None,
              room: Room | None = Room(),
              gait_hz: float = 1.0) -> Scene:
    """Build a scene with three or more mirrors on an arc behind the object (see `arc_mirrors`).

    A mirror of which the camera sees fewer than 3 markers has the hidden ones moved to where it
    sees them (placement.markers_in_view).

    Parameters
    ----------
    n_mirrors : int
    object : str
        As `make_object`.
    distance : float, optional
        Metres to the object.
    radius : float, optional
        Metres; default the object's half-width + 0.45 m.
    span_deg : float, optional
        Degrees; default 60 per gap between mirrors (at most 200).
    camera : Intrinsics, optional
    room : Room or None
    gait_hz : float
        The figure's strides per second.

    Returns
    -------
    Scene
    """
    if n_mirrors < 2:
        raise MirrorscanError(f"--mirrors: at least 2 mirrors are needed, got {n_mirrors}")
    obj = make_object(object, distance, room.floor_y if room else Room.floor_y, gait_hz)
    target, half, tall = object_extent(obj)
    span = min(60.0 * (n_mirrors - 1), 200.0) if span_deg is None else span_deg
    size = (max(MIRROR_SIZE[0], 4 * half), max(MIRROR_SIZE[1], 1.1 * tall))
    mirrors = arc_mirrors(n_mirrors, target, half + 0.45 if radius is None else radius, span,
                          3 * half, size)
    return markers_in_view(Scene(camera or Intrinsics.kinect_v1(), mirrors, (obj,), room),
                           SensorModel.kinect_v1().max_range)


def kaleidoscope_placement(angle_deg: float, half_width: float) -> tuple[float, float]:
    """Return where the object stands in a hinged pair by default.

    When 180 / angle is a whole number, an image of the object through several mirrors lies
    straight behind it, hidden from the camera; then, from 90 degrees up, the object moves sideways
    by its half-width (offset), and below, the V is turned by a quarter of the angle (turning a
    90-degree V shows one mirror so obliquely that its markers calibrate it poorly, and moving the
    object at 60 degrees hides its images through two mirrors instead). Otherwise neither.

    Parameters
    ----------
    angle_deg : float
        Degrees between the mirrors.
    half_width : float
        The object's half-width, metres.

    Returns
    -------
    turn_deg : float
    offset : float
        Metres.
    """
    ratio = 180.0 / angle_deg
    if abs(ratio - round(ratio)) > 1e-9:
        return 0.0, 0.0
    return (0.0, half_width) if angle_deg >= 90.0 else (angle_deg / 4, 0.0)


def kaleidoscope_scene(angle_deg: float = 72.0, object: str = "sphere",
                       distance: float | None = None,
                       mirror_distance: float | None = None, turn_deg: float | None = None,
                       offset: float | None = None, camera: Intrinsics | None = None,
                       room: Room | None = Room(),
                       gait_hz: float = 1.0) -> Scene:
    """Build the paper's scene with a hinged pair of mirrors (`hinged_mirrors`) instead of its V.

    The mirrors meet at the apex, so that below about 90 degrees the camera sees the object through
    two and three mirrors in turn (the kaleidoscope).

    Parameters
    ----------
    angle_deg : float
        Degrees between the mirrors.
    object : str
        As `make_object`.
    distance : float, optional
        Metres to the object.
    mirror_distance : float, optional
        Metres from the object's middle to each mirror; default its half-width + HINGED_CLEARANCE.
    turn_deg : float, optional
        The V turned about the vertical, degrees.
    offset : float, optional
        Metres the object stands to the side of the V's bisector (+x: towards mirror 2).
    camera : Intrinsics, optional
    room : Room or None
    gait_hz : float
        The figure's strides per second.

    Returns
    -------
    Scene

    Notes
    -----
    `turn_deg` and `offset` default to `kaleidoscope_placement`.
    """
    obj = make_object(object, distance, room.floor_y if room else Room.floor_y, gait_hz)
    target, half, tall = object_extent(obj)
    md = half + HINGED_CLEARANCE if mirror_distance is None else mirror_distance
    default_turn, default_offset = kaleidoscope_placement(angle_deg, half)
    turn = default_turn if turn_deg is None else turn_deg
    shift = np.array([default_offset if offset is None else offset, 0.0, 0.0])
    obj = replace(obj, centre=tuple((np.asarray(obj.centre) + shift).tolist()))
    size = (max(HINGED_WIDTH, 4 * half), max(MIRROR_SIZE[1], 1.1 * tall))
    return Scene(camera or Intrinsics.kinect_v1(),
                 hinged_mirrors(angle_deg, target, md, size, turn), (obj,), room)

