"""plan.json read and validated in one place: every key the drawing and the report use typed,
each error one line naming the file and the key (docs/DESIGN.md, "Plan folders").

Everything is in the final camera's frame: metres, OpenCV axes (x right, y down, z forward), origin
at the depth camera. `up` gives the floor's direction when the camera is tilted; without it the
camera is level. The camera stands the room's `camera_height` metres above the floor.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

import numpy as np

from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.base.jsonfile import finite_number, read_json
from mirrorcore.base.palette import MAX_MIRRORS
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane

PLAN_FILE = "plan.json"
PLAN_VERSION = 1
SUBJECT_KINDS = ("sphere", "cylinder", "mesh")
# metres: how far a mirror's fourth corner may lie off the plane of the other three
MAX_CORNER_OFF_PLANE = 0.002
MAX_PLAN_BYTES = 16 << 20
# metres (and noise mm): far beyond any room, so that no sum of them overflows
MAX_NUMBER = 1000.0


@dataclass(frozen=True)
class PlanMirror:
    """A flat mirror of the plan.

    Attributes
    ----------
    name : str
    corners : (4, 3) float64
        Metres, camera frame, in order around the outline (read-only).
    """

    name: str
    corners: np.ndarray = field(compare=False)


@dataclass(frozen=True)
class Subject:
    """The subject the plan sees.

    Attributes
    ----------
    kind : str
        'sphere', 'cylinder' or 'mesh'.
    spec : str or None
        The `--subject` it was planned for ('person:1.75'), when given.
    center : (float, float, float) or None
        Sphere: its centre, metres.
    radius : float or None
        Sphere and cylinder, metres.
    axis_xz : (float, float) or None
        Cylinder: the axis x = axis_xz[0], z = axis_xz[1], metres.
    y_range : (float, float) or None
        Cylinder: the axis's extent in y, metres, low to high.
    ends : ((float, float, float), (float, float, float)) or None
        Cylinder: its axis's two ends, metres, when the camera is tilted (the axis then is not
        along y); None: (axis_xz[0], y, axis_xz[1]) for y in y_range.
    path : Path or None
        Mesh: the triangle mesh file (metres, camera frame) inside the plan folder.
    """

    kind: str
    spec: str | None = None
    center: tuple[float, float, float] | None = None
    radius: float | None = None
    axis_xz: tuple[float, float] | None = None
    y_range: tuple[float, float] | None = None
    ends: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None
    path: Path | None = None


@dataclass(frozen=True)
class Room:
    """The room, in the level frame under the camera.

    Attributes
    ----------
    width : float
        Metres, centred on the camera.
    depth : float
        Metres from the camera forward to the back wall.
    height : float or None
        Metres from the floor to the ceiling, None when not limited.
    camera_height : float
        Metres from the floor to the camera.
    """

    width: float
    depth: float
    height: float | None
    camera_height: float


@dataclass(frozen=True)
class Predicted:
    """The plan's predicted figures.

    Attributes
    ----------
    coverage : float
        Share (0 to 1) of the subject's surface area seen by at least one view.
    coverage_2 : float
        Share seen by two or more views.
    per_view : dict of str to float
        Each view's share, by view name ('direct', 'mirror 1', 'mirror 1 then mirror 2').
    noise_mm : dict of str to float or None
        Each view's depth noise (1 sigma, mm) at the subject, same keys as `per_view`; None for a
        view that sees none of it.
    """

    coverage: float
    coverage_2: float
    per_view: dict[str, float]
    noise_mm: dict[str, float | None]


@dataclass(frozen=True)
class Plan:
    """A parsed plan.json.

    Attributes
    ----------
    folder : Path
    camera : Intrinsics
    min_depth, max_depth : float
        The sensor's depth range, metres.
    floor : Plane
        The floor in the camera frame: its normal is `up`, `floor.d` the camera's height.
    mirrors : tuple of PlanMirror
    subject : Subject
    room : Room
    predicted : Predicted
    search : dict
        The search's settings, as written.
    """

    folder: Path
    camera: Intrinsics
    min_depth: float
    max_depth: float
    floor: Plane
    mirrors: tuple[PlanMirror, ...]
    subject: Subject
    room: Room
    predicted: Predicted
    search: dict = field(compare=False)


def load_plan(folder: str | Path) -> Plan:
    """Read and validate a plan folder's plan.json.

    Parameters
    ----------
    folder : str or Path

    Returns
    -------
    Plan

    Raises
    ------
    FileFormatError
        In one line naming the file and the offending key.
    """
    folder = Path(folder)
    data = read_json(folder / PLAN_FILE, f"file (is {folder} a plan folder?)", MAX_PLAN_BYTES)
    return plan_from_json(data, folder)


def plan_from_json(data, folder: Path) -> Plan:
    """Validate a parsed plan.json (see docs/DESIGN.md, "Plan folders").

    Parameters
    ----------
    data : object
        The parsed JSON.
    folder : Path
        The plan folder that the mesh's path is relative to.

    Returns
    -------
    Plan

    Raises
    ------
    FileFormatError
        Naming the file and the key.
    """
    where = str(Path(folder) / PLAN_FILE)
    if not isinstance(data, dict):
        raise FileFormatError(f"{where}: the top level must be a JSON object")
    missing = [k for k in ("camera", "mirrors", "subject", "room", "predicted") if k not in data]
    if missing:
        raise FileFormatError(f"{where}: missing key(s) {', '.join(missing)}")
    if data.get("version", PLAN_VERSION) != PLAN_VERSION:
        raise FileFormatError(f"{where}: unknown version {repr(data['version'])[:40]}; this "
                              f"mirrorscan reads version {PLAN_VERSION}")
    camera, min_depth, max_depth = _camera(data["camera"], f"{where}: camera")
    mirrors = _mirrors(data["mirrors"], f"{where}: mirrors")
    search = data.get("search", {})
    if not isinstance(search, dict):
        raise FileFormatError(f"{where}: search: must be an object")
    room = _room(data["room"], f"{where}: room")
    return Plan(Path(folder), camera, min_depth, max_depth,
                _floor(data.get("up"), room.camera_height, where), mirrors,
                _subject(data["subject"], Path(folder), f"{where}: subject"), room,
                _predicted(data["predicted"], f"{where}: predicted"), search)


def _number(data: dict, key: str, where: str, low: float, high: float = MAX_NUMBER) -> float:
    """A finite number data[key] with low < value <= high."""
    value = finite_number(data.get(key))
    if value is None or not low < value <= high:
        raise FileFormatError(f"{where}: '{key}' must be a number above {low:g} and at most "
                              f"{high:g}, got {repr(data.get(key))[:40]}")
    return value


def _share(data: dict, key: str, where: str) -> float:
    """A finite number data[key] from 0 to 1."""
    value = finite_number(data.get(key))
    if value is None or not 0 <= value <= 1:
        raise FileFormatError(f"{where}: '{key}' must be a share from 0 to 1, got "
                              f"{repr(data.get(key))[:40]}")
    return value


def _noise(data: dict, key: str, where: str) -> float | None:
    """Millimetres from 0 to MAX_NUMBER, or None (null)."""
    if data[key] is None:
        return None
    value = finite_number(data[key])
    if value is None or not 0 <= value <= MAX_NUMBER:
        raise FileFormatError(f"{where}: '{key}' must be millimetres from 0 to {MAX_NUMBER:g} or "
                              f"null, got {repr(data[key])[:40]}")
    return value


def _point(value, n: int, where: str) -> tuple[float, ...]:
    """n finite numbers within ±MAX_NUMBER."""
    numbers = [finite_number(v) for v in value] if isinstance(value, list) else []
    if len(numbers) != n or any(v is None or abs(v) > MAX_NUMBER for v in numbers):
        raise FileFormatError(f"{where}: must be {n} numbers within ±{MAX_NUMBER:g}, got "
                              f"{repr(value)[:60]}")
    return tuple(numbers)


def _object(value, where: str, keys: tuple[str, ...]) -> dict:
    """A JSON object holding `keys`."""
    if not isinstance(value, dict):
        raise FileFormatError(f"{where}: must be an object")
    missing = [k for k in keys if k not in value]
    if missing:
        raise FileFormatError(f"{where}: missing key(s) {', '.join(missing)}")
    return value


def _camera(data, where: str) -> tuple[Intrinsics, float, float]:
    """The camera's intrinsics and its depth range."""
    data = _object(data, where, ("min_depth", "max_depth"))
    camera = Intrinsics.from_dict({k: v for k, v in data.items()
                                   if k not in ("min_depth", "max_depth")}, where)
    min_depth = _number(data, "min_depth", where, 0.0)
    max_depth = _number(data, "max_depth", where, 0.0)
    if max_depth <= min_depth:
        raise FileFormatError(f"{where}: 'max_depth' ({max_depth:g}) must be above 'min_depth' "
                              f"({min_depth:g})")
    return camera, min_depth, max_depth


def _mirrors(value, where: str) -> tuple[PlanMirror, ...]:
    """One or more mirrors, each four corners on a plane in front of the camera."""
    if not isinstance(value, list) or not 1 <= len(value) <= MAX_MIRRORS:
        raise FileFormatError(f"{where}: must be a list of 1 to {MAX_MIRRORS} mirrors")
    mirrors = []
    for i, item in enumerate(value):
        at = f"{where}[{i}]"
        item = _object(item, at, ("corners",))
        name = item.get("name", f"mirror {i + 1}")
        if not isinstance(name, str) or not name.strip() or len(name) > 40:
            raise FileFormatError(f"{at}: 'name' must be text of 1 to 40 characters")
        corners = item["corners"]
        if not isinstance(corners, list) or len(corners) != 4:
            raise FileFormatError(f"{at}: corners: must be 4 points [x, y, z]")
        points = np.array([_point(c, 3, f"{at}: corners[{k}]") for k, c in enumerate(corners)])
        _check_outline(points, f"{at}: corners")
        points.flags.writeable = False
        mirrors.append(PlanMirror(name, points))
    return tuple(mirrors)


def _check_outline(points: np.ndarray, where: str) -> None:
    """Refuse four corners that are not a flat convex outline, in order, of non-zero area."""
    edges = np.roll(points, -1, axis=0) - points
    turns = np.cross(edges, np.roll(edges, -1, axis=0))
    normal = turns.sum(axis=0)
    area = np.linalg.norm(normal) / 2
    if area < 1e-4:
        raise FileFormatError(f"{where}: the 4 corners enclose no area (under 1 cm²); give "
                              "them in order around the outline")
    normal /= 2 * area
    off = 0.0
    for k in range(4):
        # corner k against the plane through the other three
        a, b, c = np.delete(points, k, axis=0)
        n = np.cross(b - a, c - a)
        off = max(off, float(abs((points[k] - a) @ n) / max(np.linalg.norm(n), 1e-12)))
    if off > MAX_CORNER_OFF_PLANE:
        raise FileFormatError(f"{where}: a corner lies {off * 1000:.0f} mm off the plane of the "
                              f"other three (at most {MAX_CORNER_OFF_PLANE * 1000:g})")
    if np.any(turns @ normal <= 0):
        raise FileFormatError(f"{where}: the corners must go around the outline in order")


def _floor(up, camera_height: float, where: str) -> Plane:
    """The floor plane from `up` (the unit up vector in the camera frame) and the camera's height;
    level ([0, -1, 0]) without it."""
    if up is None:
        return Plane((0.0, -1.0, 0.0), camera_height)
    n = np.array(_point(up, 3, f"{where}: up"))
    size = np.linalg.norm(n)
    if not 0.99 < size < 1.01 or n[1] >= 0:
        raise FileFormatError(f"{where}: up: must be a unit vector pointing up (negative y), got "
                              f"{repr(up)[:60]}")
    return Plane(tuple((n / size).tolist()), camera_height)


def _subject(data, folder: Path, where: str) -> Subject:
    """A sphere, a cylinder or a mesh file in the plan folder."""
    data = _object(data, where, ("kind",))
    kind, spec = data["kind"], data.get("spec")
    if spec is not None and (not isinstance(spec, str) or len(spec) > 200):
        raise FileFormatError(f"{where}: 'spec' must be the text of --subject")
    if kind not in SUBJECT_KINDS:
        raise FileFormatError(f"{where}: 'kind' must be one of {', '.join(SUBJECT_KINDS)}, got "
                              f"{repr(kind)[:40]}")
    if kind == "sphere":
        _object(data, where, ("center", "radius"))
        return Subject(kind, spec, center=_point(data["center"], 3, f"{where}: center"),
                       radius=_number(data, "radius", where, 0.0))
    if kind == "cylinder":
        _object(data, where, ("axis_xz", "radius", "y_range"))
        low, high = _point(data["y_range"], 2, f"{where}: y_range")
        if not low < high:
            raise FileFormatError(f"{where}: y_range: must be [low, high] with low < high")
        ends = data.get("ends")
        if ends is not None:
            if not isinstance(ends, list) or len(ends) != 2:
                raise FileFormatError(f"{where}: ends: must be 2 points [x, y, z]")
            ends = tuple(_point(e, 3, f"{where}: ends[{k}]") for k, e in enumerate(ends))
        return Subject(kind, spec, radius=_number(data, "radius", where, 0.0),
                       axis_xz=_point(data["axis_xz"], 2, f"{where}: axis_xz"),
                       y_range=(low, high), ends=ends)
    _object(data, where, ("path",))
    path = data["path"]
    rel = PurePosixPath(path.replace("\\", "/")) if isinstance(path, str) and path else None
    if rel is None or rel.is_absolute() or ".." in rel.parts or "\0" in path:
        raise FileFormatError(f"{where}: path: must be a file name inside the plan folder, got "
                              f"{repr(path)[:60]}")
    if not (folder / rel).is_file():
        raise FileFormatError(f"{where}: path: no such file {folder / rel}")
    return Subject(kind, spec, path=folder / rel)


def _room(data, where: str) -> Room:
    """The room's width, depth, (optional) height and the camera's height in it."""
    data = _object(data, where, ("width", "depth", "camera_height"))
    height = data.get("height")
    room = Room(_number(data, "width", where, 0.0), _number(data, "depth", where, 0.0),
                None if height is None else _number(data, "height", where, 0.0),
                _number(data, "camera_height", where, 0.0))
    if room.height is not None and room.camera_height >= room.height:
        raise FileFormatError(f"{where}: 'camera_height' ({room.camera_height:g}) must be below "
                              f"the ceiling ('height' {room.height:g})")
    return room


def _predicted(data, where: str) -> Predicted:
    """The shares (0 to 1) and each view's noise."""
    data = _object(data, where, ("coverage", "coverage_2", "per_view", "noise_mm"))
    views = {}
    for key in ("per_view", "noise_mm"):
        value = data[key]
        if not isinstance(value, dict) or not value:
            raise FileFormatError(f"{where}: {key}: must be an object of view names to numbers")
        views[key] = {k: _share(value, k, f"{where}: {key}") if key == "per_view"
                      else _noise(value, k, f"{where}: {key}") for k in value}
    if views["per_view"].keys() != views["noise_mm"].keys():
        raise FileFormatError(f"{where}: noise_mm: must name the views of per_view")
    return Predicted(_share(data, "coverage", where), _share(data, "coverage_2", where),
                     views["per_view"], views["noise_mm"])
