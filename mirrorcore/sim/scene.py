"""Simulated scenes: frozen dataclasses for mirrors (with markers), objects and the room (their
JSON file is read and written by scenefile).

Everything is in the camera frame (docs/DESIGN.md): metres, OpenCV axes (x right, y down, z
forward), origin at the depth camera. "Up" in the room is -y. A scene file is JSON:

    {"version": 1,
     "camera": {"width": 640, ...} or "kinect_v1" or "primesense", "mirrors": [{"name": "mirror 1",
     "centre": [x, y, z], "normal": [nx, ny, nz], "up": [ux, uy, uz],
                  "width": 0.6, "height": 1.0, "markers": [[s, t], ...], "marker_size": 0.04,
                  "marker_offset": 0.0, "tint": [0.84, 0.88, 0.86]}],
     "objects": [{"type": "sphere", "centre": [0, 0, 2], "radius": 0.115}, ...],
     "room": {"floor_y": 1.0, "back_z": 4.2, "half_width": 4.0} or null,
     "click_jitter_px": 0.0}

A mirror's `centre` and `normal` give its reflecting surface (the silver), whose `normal` points to
the reflective side, which must face the camera; `up` is the direction of its height (made
orthogonal to the normal); marker (s, t) are offsets in metres from the mirror's centre along its
right (up x normal) and up axes; markers are matte squares of side `marker_size` whose faces are
`marker_offset` metres in front of the reflecting surface (0 to 0.05: stickers on the glass of a
back-silvered mirror). `tint` (optional) is the fraction of each colour channel (red, green, blue; 0
to 1) the mirror reflects; without it mirror j gets DEFAULT_TINTS[(j - 1) % 3], ordinary mirrors of
82-89 %, slightly green or blue. `click_jitter_px` (optional) is the radial RMS in pixels of the
random error of each marker click in the session made from the scene (sim/export.py).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from mirrorcore.base.errors import FileFormatError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane

SCENE_VERSION = 1
OBJECT_TYPES = ("sphere", "cylinder", "box", "mesh", "figure")
# metres: the least a marker's face stands in front of the glass (no coplanar faces)
MARKER_LIFT = 1e-4
MAX_MARKER_OFFSET = 0.05      # metres
# (red, green, blue) reflectance of mirrors without a `tint`: mirror j gets [(j - 1) % 3]
DEFAULT_TINTS = ((0.84, 0.88, 0.86), (0.82, 0.85, 0.89), (0.87, 0.89, 0.85))


@dataclass(frozen=True)
class SceneMirror:
    """A flat rectangular mirror with matte square markers stuck on its glass.

    Attributes
    ----------
    name : str
    centre : (float, float, float)
        Metres, camera frame.
    normal : (float, float, float)
        Unit, the reflective side, facing the camera.
    up : (float, float, float)
        Unit, the direction of `height` (orthogonal to normal).
    width, height : float
        Metres.
    markers : tuple of (float, float)
        (s, t) metres from the centre along `right` and `up`.
    marker_size : float
        Side of a marker, metres.
    marker_offset : float
        Metres from the reflecting surface to the markers' faces, towards the camera (>= 0).
    tint : (float, float, float) or None
        The fraction of red, green and blue the mirror reflects (0 to 1); None takes the scene's
        default for the mirror's place (DEFAULT_TINTS).
    """

    name: str
    centre: tuple[float, float, float]
    normal: tuple[float, float, float]
    up: tuple[float, float, float]
    width: float
    height: float
    markers: tuple[tuple[float, float], ...] = ()
    marker_size: float = 0.04
    marker_offset: float = 0.0
    tint: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        n = np.asarray(self.normal, dtype=np.float64)
        n /= np.linalg.norm(n)
        up = np.asarray(self.up, dtype=np.float64)
        up = up - np.dot(up, n) * n
        if np.linalg.norm(up) < 1e-9:
            raise FileFormatError(f"{self.name}: 'up' must not be parallel to the normal")
        object.__setattr__(self, "normal", tuple(float(x) for x in n))
        object.__setattr__(self, "up", tuple(float(x) for x in up / np.linalg.norm(up)))
        if np.dot(n, -np.asarray(self.centre)) <= 0:
            raise FileFormatError(
                f"{self.name}: the reflective side (normal) faces away from the camera")

    @property
    def axes(self) -> np.ndarray:
        """(3, 3) float64 rows: right, up, normal (a right-handed orthonormal frame)."""
        n, up = np.asarray(self.normal), np.asarray(self.up)
        return np.stack([np.cross(up, n), up, n])

    @property
    def plane(self) -> Plane:
        """The true mirror plane (docs/DESIGN.md: unit normal towards the camera, d > 0)."""
        return Plane.from_point_normal(self.centre, self.normal)

    def local_to_camera(self, st: np.ndarray) -> np.ndarray:
        """Map points on the glass to the camera frame.

        Parameters
        ----------
        st : (k, 2) array
            Metres on the glass (right, up).

        Returns
        -------
        (k, 3) float64 array
            Metres, camera frame.
        """
        st = np.asarray(st, dtype=np.float64).reshape(-1, 2)
        return np.asarray(self.centre) + st @ self.axes[:2]

    def corners(self) -> np.ndarray:
        """(4, 3) float64 corners in order around the rectangle (a simple polygon in any view)."""
        w, h = self.width / 2, self.height / 2
        return self.local_to_camera([[-w, -h], [w, -h], [w, h], [-w, h]])

    @property
    def marker_lift(self) -> float:
        """Metres from the silver to the marker faces: max(marker_offset, MARKER_LIFT)."""
        return max(self.marker_offset, MARKER_LIFT)

    def marker_centres(self) -> np.ndarray:
        """Return the (k, 3) float64 centres of the markers' faces, metres, camera frame.

        They lie marker_lift in front of the reflecting surface.
        """
        st = np.asarray(self.markers, dtype=np.float64).reshape(-1, 2)
        return self.local_to_camera(st) + self.marker_lift * np.asarray(self.normal)

    def to_json(self) -> dict:
        """The mirror's scene-file object."""
        return {"name": self.name, "centre": list(self.centre), "normal": list(self.normal),
                "up": list(self.up),
                "width": self.width, "height": self.height,
                "markers": [list(m) for m in self.markers],
                "marker_size": self.marker_size, "marker_offset": self.marker_offset,
                "tint": None if self.tint is None else list(self.tint)}


@dataclass(frozen=True)
class SceneObject:
    """An object in front of the mirrors.

    Attributes
    ----------
    type : str
        One of OBJECT_TYPES.
    centre : (float, float, float)
        Metres, camera frame: the sphere's centre, the middle of a cylinder's axis, a box's centre,
        where a mesh's bounding-box centre goes, the point on the floor between a figure's feet.
    radius : float
        Sphere/cylinder radius, metres.
    height : float
        Cylinder length or figure height, metres.
    axis : (float, float, float)
        Unit cylinder axis.
    size : (float, float, float)
        Box edges along x, y, z, metres.
    path : str or None
        Mesh file (any format trimesh reads), its coordinates taken as camera-frame axes.
    scale : float
        Metres per unit of the mesh.
    gait_hz : float
        Strides per second of a figure walking in place (0 = standing still).
    """

    type: str
    centre: tuple[float, float, float]
    radius: float = 0.115
    height: float = 0.5
    axis: tuple[float, float, float] = (0.0, 1.0, 0.0)
    size: tuple[float, float, float] = (0.3, 0.3, 0.3)
    path: str | None = None
    scale: float = 1.0
    gait_hz: float = 0.0

    @property
    def animated(self) -> bool:
        """True for a figure that walks (gait_hz > 0)."""
        return self.type == "figure" and self.gait_hz > 0

    def to_json(self) -> dict:
        """Only the keys that matter for this type."""
        keys = {"sphere": ("radius",), "cylinder": ("radius", "height", "axis"), "box": ("size",),
                "mesh": ("path", "scale"), "figure": ("height", "gait_hz")}[self.type]
        out = {"type": self.type, "centre": list(self.centre)}
        out.update({k: (list(v) if isinstance(v, tuple) else v) for k in keys
                    for v in [getattr(self, k)]})
        return out


@dataclass(frozen=True)
class Room:
    """A floor and a back wall, each 2 * half_width wide.

    Attributes
    ----------
    floor_y : float
        The floor is the plane y = floor_y, metres below the camera.
    back_z : float
        The back wall is the plane z = back_z, metres.
    half_width : float
        Metres.
    """

    floor_y: float = 1.0
    back_z: float = 4.2
    half_width: float = 4.0

    def to_json(self) -> dict:
        """The room's scene-file object."""
        return {"floor_y": self.floor_y, "back_z": self.back_z, "half_width": self.half_width}


@dataclass(frozen=True)
class Scene:
    """A depth camera, its mirrors, the objects and the room.

    Attributes
    ----------
    camera : Intrinsics
    mirrors : tuple of SceneMirror
        Session order: mirror j is mirrors[j - 1]; one without a tint gets DEFAULT_TINTS[(j - 1)
        % 3].
    objects : tuple of SceneObject
    room : Room or None
    click_jitter_px : float
        Radial RMS error (pixels) of the marker clicks in a session made from the scene.
    """

    camera: Intrinsics
    mirrors: tuple[SceneMirror, ...]
    objects: tuple[SceneObject, ...] = ()
    room: Room | None = field(default_factory=Room)
    click_jitter_px: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "mirrors", tuple(
            m if m.tint is not None else replace(m, tint=DEFAULT_TINTS[j % len(DEFAULT_TINTS)])
            for j, m in enumerate(self.mirrors)))

    def to_json(self) -> dict:
        """The scene file's object."""
        return {"version": SCENE_VERSION, "camera": self.camera.to_dict(),
                "mirrors": [m.to_json() for m in self.mirrors],
                "objects": [o.to_json() for o in self.objects],
                "room": None if self.room is None else self.room.to_json(),
                "click_jitter_px": self.click_jitter_px}

    def with_markers(self, marker_offset: float | None = None,
                     click_jitter_px: float | None = None) -> "Scene":
        """Return a copy with every mirror's marker_offset and/or the click jitter replaced.

        Parameters
        ----------
        marker_offset : float, optional
            Metres; None keeps.
        click_jitter_px : float, optional
            Pixels; None keeps.

        Returns
        -------
        Scene
        """
        mirrors = self.mirrors if marker_offset is None else tuple(
            replace(m, marker_offset=checked_offset(marker_offset, "marker offset"))
            for m in self.mirrors)
        jitter = (
            self.click_jitter_px
            if click_jitter_px is None
            else checked_jitter(click_jitter_px, "click jitter")
        )
        return replace(self, mirrors=mirrors, click_jitter_px=jitter)


def checked_offset(value, where: str) -> float:
    """A marker offset in metres, 0 to MAX_MARKER_OFFSET; FileFormatError naming `where`
    otherwise."""
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not np.isfinite(value)
        or not 0 <= value <= MAX_MARKER_OFFSET
    ):
        raise FileFormatError(
            f"{where}: must be 0 to {MAX_MARKER_OFFSET:g} metres (markers in front of the "
            f"reflecting surface), got {value!r}"
        )
    return float(value)


def checked_jitter(value, where: str) -> float:
    """A click jitter in pixels, 0 to 50; FileFormatError naming `where` otherwise."""
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not np.isfinite(value)
        or not 0 <= value <= 50
    ):
        raise FileFormatError(f"{where}: must be 0 to 50 pixels, got {value!r}")
    return float(value)
