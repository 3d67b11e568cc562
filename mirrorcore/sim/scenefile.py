"""A simulated scene's JSON file (the format is in mirrorcore.sim.scene): read with one-line errors
naming the file and the key, and written atomically."""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from mirrorcore.base.atomic import write_atomic
from mirrorcore.base.errors import FileFormatError
from mirrorcore.base.jsonfile import read_json
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.sim.scene import (OBJECT_TYPES, SCENE_VERSION, Room, Scene, SceneMirror,
                                  SceneObject, checked_jitter, checked_offset)

_CAMERA_PRESETS = {"kinect_v1": Intrinsics.kinect_v1, "primesense": Intrinsics.primesense}


def _vec(value, where: str, unit: bool = False) -> tuple[float, float, float]:
    """A 3-vector of finite floats (normalised when `unit`); raises FileFormatError naming
    `where`."""
    try:
        v = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise FileFormatError(f"{where}: must be 3 numbers [x, y, z], got {value!r}") from None
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise FileFormatError(f"{where}: must be 3 finite numbers [x, y, z], got {value!r}")
    if unit:
        norm = np.linalg.norm(v)
        if norm < 1e-12:
            raise FileFormatError(f"{where}: the direction is zero")
        v = v / norm
    return float(v[0]), float(v[1]), float(v[2])


def _positive(value, where: str) -> float:
    """`value` as a positive finite float; FileFormatError naming `where` otherwise."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(
        value) or value <= 0:
        raise FileFormatError(f"{where}: must be a positive number, got {value!r}")
    return float(value)


# --------------------------------------------------------------- JSON reading with one-line errors
def scene_from_json(data, where: str = "scene") -> Scene:
    """Validate a parsed scene file.

    Parameters
    ----------
    data : object
        The parsed JSON.
    where : str
        The file, for the messages.

    Returns
    -------
    Scene

    Raises
    ------
    FileFormatError
        Naming `where` and the offending key.
    """
    if not isinstance(data, dict):
        raise FileFormatError(f"{where}: the top level must be a JSON object")
    for key in ("camera", "mirrors", "objects"):
        if key not in data:
            raise FileFormatError(f"{where}: missing key '{key}'")
    if data.get("version", SCENE_VERSION) != SCENE_VERSION:
        raise FileFormatError(
            f"{where}: unknown version {data['version']!r}; this reads version {SCENE_VERSION}")
    cam = data["camera"]
    if isinstance(cam, str):
        if cam not in _CAMERA_PRESETS:
            raise FileFormatError(
                f"{where}: camera: unknown preset {cam!r} (use {', '.join(_CAMERA_PRESETS)})")
        camera = _CAMERA_PRESETS[cam]()
    else:
        camera = Intrinsics.from_dict(cam, f"{where}: camera")
    for key in ("mirrors", "objects"):
        if not isinstance(data[key], list):
            raise FileFormatError(f"{where}: '{key}' must be a list")
    mirrors = tuple(_mirror(m, f"{where}: mirrors[{i}]") for i, m in enumerate(data["mirrors"]))
    objects = tuple(_object(o, f"{where}: objects[{i}]") for i, o in enumerate(data["objects"]))
    room = data.get("room", Room().to_json())
    if room is not None:
        if not isinstance(room, dict):
            raise FileFormatError(f"{where}: room: must be an object or null")
        room = Room(**{k: _number(room, k, f"{where}: room", getattr(Room, k))
                       for k in ("floor_y", "back_z")},
                    half_width=_positive(room.get("half_width", Room.half_width),
                                         f"{where}: room.half_width"))
    return Scene(camera, mirrors, objects, room,
                 checked_jitter(data.get("click_jitter_px", 0.0), f"{where}: click_jitter_px"))


def _number(data: dict, key: str, where: str, default: float) -> float:
    """data[key] (or `default`) as a finite float; FileFormatError otherwise."""
    value = data.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise FileFormatError(f"{where}.{key}: must be a number, got {value!r}")
    return float(value)


def _require(data, keys: tuple[str, ...], where: str) -> None:
    """Refuse `data` that is not an object or misses one of `keys`."""
    if not isinstance(data, dict):
        raise FileFormatError(f"{where}: must be a JSON object")
    missing = [k for k in keys if k not in data]
    if missing:
        raise FileFormatError(f"{where}: missing key(s) {', '.join(missing)}")


def _mirror(data, where: str) -> SceneMirror:
    """Validate one mirror object of a scene file."""
    _require(data, ("centre", "normal", "up", "width", "height"), where)
    markers = data.get("markers", [])
    try:
        st = np.asarray(markers, dtype=np.float64).reshape(-1, 2)
        if not np.all(np.isfinite(st)) or (len(markers) and np.asarray(markers).ndim != 2):
            raise ValueError
    except (TypeError, ValueError):
        raise FileFormatError(
            f"{where}.markers: must be a list of [s, t] pairs of numbers") from None
    name = data.get("name", where.rsplit("[", 1)[-1].rstrip("]"))
    return SceneMirror(str(name), _vec(data["centre"], f"{where}.centre"),
                       _vec(data["normal"], f"{where}.normal", True),
                  _vec(data["up"], f"{where}.up", True), _positive(data["width"], f"{where}.width"),
                  _positive(data["height"], f"{where}.height"), tuple(map(tuple, st.tolist())),
                  _positive(data.get("marker_size", SceneMirror.marker_size),
                            f"{where}.marker_size"),
                  checked_offset(data.get("marker_offset", 0.0), f"{where}.marker_offset"),
                  _tint(data.get("tint"), f"{where}.tint"))


def _tint(value, where: str) -> tuple[float, float, float] | None:
    """A mirror's tint: None, or 3 reflectances 0 to 1 (red, green, blue); FileFormatError
    naming `where` otherwise."""
    if value is None:
        return None
    tint = _vec(value, where)
    if not all(0 <= c <= 1 for c in tint):
        raise FileFormatError(f"{where}: must be 3 reflectances 0 to 1 (red, green, blue), "
                              f"got {value!r}")
    return tint


def _object(data, where: str) -> SceneObject:
    """Validate one object of a scene file."""
    _require(data, ("type", "centre"), where)
    kind = data["type"]
    if kind not in OBJECT_TYPES:
        raise FileFormatError(
            f"{where}.type: unknown object type {kind!r} (use {', '.join(OBJECT_TYPES)})")
    if kind == "mesh" and not isinstance(data.get("path"), str):
        raise FileFormatError(f"{where}.path: a mesh object needs the path of a mesh file")
    gait = _number(data, "gait_hz", where, 0.0)
    if gait < 0:
        raise FileFormatError(f"{where}.gait_hz: must not be negative, got {gait}")
    return SceneObject(
        kind, _vec(data["centre"], f"{where}.centre"),
        radius=_positive(data.get("radius", SceneObject.radius), f"{where}.radius"),
        height=_positive(data.get("height", SceneObject.height), f"{where}.height"),
        axis=_vec(data.get("axis", SceneObject.axis), f"{where}.axis", unit=True),
        size=tuple(_positive(s, f"{where}.size")
                   for s in _vec(data.get("size", SceneObject.size), f"{where}.size")),
        path=data.get("path"), scale=_positive(data.get("scale", 1.0), f"{where}.scale"),
        gait_hz=gait)


def load_scene(path: str | Path) -> Scene:
    """Read a scene file.

    A relative mesh `path` inside the file is taken relative to the scene file's folder.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Scene

    Raises
    ------
    FileFormatError
        Naming the file (and the key) on any problem.
    """
    path = Path(path)
    scene = scene_from_json(read_json(path, "scene file"), str(path))
    objects = tuple(o if o.path is None or Path(o.path).is_absolute() else
                    replace(o, path=str(path.parent / o.path)) for o in scene.objects)
    return replace(scene, objects=objects)


def save_scene(scene: Scene, path: str | Path) -> None:
    """Write a scene file atomically (UTF-8 JSON, indented).

    Parameters
    ----------
    scene : Scene
    path : str or Path
    """
    write_atomic(path, (json.dumps(scene.to_json(), indent=2) + "\n").encode("utf-8"))

