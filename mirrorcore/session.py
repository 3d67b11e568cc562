"""The session folder of DESIGN.md: session.json (camera, mirrors, background, frames), loaded with clear errors and
saved atomically with one backup (session.json.bak)."""
from __future__ import annotations

import json
import re
import shutil
from dataclasses import dataclass, field, replace
from pathlib import Path, PurePosixPath

import numpy as np

from .atomic import new_folder, write_atomic
from .camera import Intrinsics
from .depthio import read_depth_png
from .errors import FileFormatError, MirrorscanError
from .jsonfile import read_json
from .plane import Plane
from .polygon import validate_polygon

VERSION = 1
SESSION_FILE = "session.json"
BACKGROUND_FILE = "background.png"   # where a captured or rendered background is saved
_TOP_KEYS = ("version", "camera", "mirrors", "background", "frames")
_MIRROR_KEYS = ("name", "markers", "boundary", "plane")


@dataclass(frozen=True)
class MirrorSpec:
    """One mirror as the user set it up.

    markers : (k, 2) pixel coordinates (u, v) clicked on the mirror's markers
    boundary : (b, 2) pixel polygon of the mirror's outline in the image (empty until drawn)
    plane : the calibrated plane, or None
    extra : keys of the mirror's JSON object that this version does not know, kept as they were
    """

    name: str
    markers: tuple[tuple[float, float], ...] = ()
    boundary: tuple[tuple[float, float], ...] = ()
    plane: Plane | None = None
    extra: dict = field(default_factory=dict, compare=False)

    def to_json(self) -> dict:
        return {"name": self.name, "markers": [list(m) for m in self.markers],
                "boundary": [list(b) for b in self.boundary],
                "plane": None if self.plane is None else self.plane.to_list(), **self.extra}


@dataclass(frozen=True)
class Session:
    """A session folder in memory. Paths in `background` and `frames` are relative to `root` (POSIX style)."""

    root: Path
    camera: Intrinsics
    mirrors: tuple[MirrorSpec, ...] = ()
    background: str | None = None
    frames: tuple[str, ...] = ()
    extra: dict = field(default_factory=dict, compare=False)

    @property
    def path(self) -> Path:
        return Path(self.root) / SESSION_FILE

    def to_json(self) -> dict:
        return {"version": VERSION, "camera": self.camera.to_dict(), "mirrors": [m.to_json() for m in self.mirrors],
                "background": self.background, "frames": list(self.frames), **self.extra}

    def with_mirror(self, index: int, mirror: MirrorSpec) -> "Session":
        """A copy with mirror `index` (0-based) replaced."""
        mirrors = list(self.mirrors)
        mirrors[index] = mirror
        return replace(self, mirrors=tuple(mirrors))

    def read_frame(self, index: int) -> np.ndarray:
        """Frame `index` (0-based, negative counts from the end) as (H, W) float32 metres."""
        if not self.frames:
            raise MirrorscanError(f"{self.path}: the session has no frames")
        if not -len(self.frames) <= index < len(self.frames):
            raise MirrorscanError(f"{self.path}: no frame {index}; the session has {len(self.frames)} "
                                  f"(0 to {len(self.frames) - 1})")
        return self._read(self.frames[index])

    def read_background(self) -> np.ndarray | None:
        """The background frame as (H, W) float32 metres, or None when the session has none."""
        return None if self.background is None else self._read(self.background)

    def _read(self, rel: str) -> np.ndarray:
        return read_depth_png(Path(self.root) / rel, self.camera.depth_scale, self.camera.shape)


def load_session(folder: str | Path) -> Session:
    """Read and validate SESSION/session.json; raises FileFormatError with the file and the offending key."""
    folder = Path(folder)
    return session_from_json(read_json(folder / SESSION_FILE, f"file (is {folder} a session folder?)"), folder)


def session_from_json(data, folder: Path) -> Session:
    """Validate a parsed session.json (see DESIGN.md); `folder` is the session folder that paths are relative to."""
    where = str(Path(folder) / SESSION_FILE)
    if not isinstance(data, dict):
        raise FileFormatError(f"{where}: the top level must be a JSON object")
    missing = [k for k in ("version", "camera", "mirrors", "frames") if k not in data]
    if missing:
        raise FileFormatError(f"{where}: missing key(s) {', '.join(missing)}")
    if data["version"] != VERSION:
        raise FileFormatError(f"{where}: unknown version {data['version']!r}; this mirrorscan reads version {VERSION}")
    camera = Intrinsics.from_dict(data["camera"], f"{where}: camera")
    if not isinstance(data["mirrors"], list):
        raise FileFormatError(f"{where}: 'mirrors' must be a list")
    mirrors = tuple(_mirror_from_json(m, camera, f"{where}: mirrors[{i}]") for i, m in enumerate(data["mirrors"]))
    background = data.get("background")
    if background is not None:
        background = _relative_path(background, folder, f"{where}: background")
    if not isinstance(data["frames"], list):
        raise FileFormatError(f"{where}: 'frames' must be a list of paths")
    frames = tuple(_relative_path(f, folder, f"{where}: frames[{i}]") for i, f in enumerate(data["frames"]))
    extra = {k: v for k, v in data.items() if k not in _TOP_KEYS}
    return Session(Path(folder), camera, mirrors, background, frames, extra)


def _mirror_from_json(data, camera: Intrinsics, where: str) -> MirrorSpec:
    if not isinstance(data, dict):
        raise FileFormatError(f"{where}: a mirror must be a JSON object")
    if not isinstance(data.get("name"), str) or not data["name"].strip():
        raise FileFormatError(f"{where}: 'name' must be a non-empty string")
    where = f"{where} ({data['name']})"
    markers = _pixels(data.get("markers", []), camera, f"{where}: markers")
    boundary = _pixels(data.get("boundary", []), camera, f"{where}: boundary")
    if boundary:
        try:
            validate_polygon(boundary, camera.shape, f"{where}: boundary")
        except MirrorscanError as exc:
            raise FileFormatError(str(exc)) from None
    plane = data.get("plane")
    if plane is not None:
        try:
            plane = Plane.from_abcd(plane, f"{where}: plane", orient=False)
        except MirrorscanError as exc:
            raise FileFormatError(str(exc)) from None
    extra = {k: v for k, v in data.items() if k not in _MIRROR_KEYS}
    return MirrorSpec(data["name"], markers, boundary, plane, extra)


def _pixels(value, camera: Intrinsics, where: str) -> tuple[tuple[float, float], ...]:
    """A list of [u, v] inside the image -> tuple of (u, v) floats."""
    if not isinstance(value, list):
        raise FileFormatError(f"{where}: must be a list of [u, v] pixels")
    out = []
    for i, p in enumerate(value):
        if (not isinstance(p, (list, tuple)) or len(p) != 2
                or not all(isinstance(c, (int, float)) and not isinstance(c, bool) and np.isfinite(c) for c in p)):
            raise FileFormatError(f"{where}[{i}]: must be a pair of numbers [u, v], got {p!r}")
        u, v = float(p[0]), float(p[1])
        if not (-0.5 <= u <= camera.width - 0.5 and -0.5 <= v <= camera.height - 0.5):
            raise FileFormatError(f"{where}[{i}]: pixel ({u:g}, {v:g}) is outside the "
                                  f"{camera.width}x{camera.height} image")
        out.append((u, v))
    return tuple(out)


def _relative_path(value, folder: Path, where: str) -> str:
    """A path relative to the session folder that stays inside it; returned in POSIX form."""
    if not isinstance(value, str) or not value:
        raise FileFormatError(f"{where}: must be a path relative to the session folder")
    rel = PurePosixPath(value.replace("\\", "/"))
    if rel.is_absolute() or ".." in rel.parts or (len(value) > 1 and value[1] == ":"):
        raise FileFormatError(f"{where}: path {value!r} leaves the session folder")
    return str(rel)


def save_session(session: Session) -> None:
    """Write session.json atomically; the previous version is kept as session.json.bak."""
    Path(session.root).mkdir(parents=True, exist_ok=True)
    text = json.dumps(session.to_json(), indent=2) + "\n"
    write_atomic(session.path, text.encode("utf-8"), backup=True)


_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_ .-]{0,99}$")


def session_folder(sessions_dir: str | Path, name: str) -> Path:
    """The folder of session `name` inside `sessions_dir`; refuses names that are empty, too long, or could leave the
    folder (separators, '..', leading dots)."""
    name = name.strip()
    if not _NAME.match(name) or ".." in name:
        raise MirrorscanError(f"session name {name!r}: use letters, digits, spaces, '_', '-' and '.' (not '..'), "
                              "at most 100 characters, starting with a letter, digit or '_'")
    return Path(sessions_dir) / name


def copy_session(session: Session, folder: str | Path) -> Session:
    """Save a session under a new folder with its background and frames; all or nothing. Refuses an existing folder
    that is not empty. Returns the session as it now lives in `folder`."""
    folder = Path(folder)
    with new_folder(folder) as work:
        for rel in ([session.background] if session.background else []) + list(session.frames):
            (work / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(Path(session.root) / rel, work / rel)
        save_session(replace(session, root=work))
    return replace(session, root=folder)
