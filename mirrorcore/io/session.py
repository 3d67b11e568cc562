"""The session folder (docs/DESIGN.md): session.json with every key typed, parsed and validated
here in one place (camera, mirrors, background, frames, and the extensions selection, bounces,
timestamps, colour_frames, a mirror's id, region and marker_offset), saved atomically with one
backup (session.json.bak). Keys that this mirrorscan does not read are kept as they were."""
from __future__ import annotations

import json
import re
import shutil
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from mirrorcore.base.atomic import new_folder, write_atomic
from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.base.jsonfile import read_json
from mirrorcore.base.palette import MAX_MIRRORS, MAX_ORDER
from mirrorcore.depth.files import read_depth_png
from mirrorcore.depth.selection import Selection
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.fields import (Pixels, read_list, read_paths, read_pixels, read_polygon,
                                  read_relative_path, read_timestamps)
from mirrorcore.io.limits import (MAX_FRAMES, MAX_MARKERS, MAX_SESSION_BYTES, check_name)

VERSION = 1
SESSION_FILE = "session.json"
# Where a captured or rendered background is saved.
BACKGROUND_FILE = "background.png"
# The simulator's scene and true planes, beside its session.json.
TRUTH_FILE = "truth.json"
# Every file in it belongs to the session (a recording lists frames as they land).
FRAMES_FOLDER = "frames"
_TOP_KEYS = ("version", "camera", "mirrors", "background", "frames", "selection", "timestamps",
             "colour_frames", "bounces")
_MIRROR_KEYS = ("id", "name", "markers", "boundary", "plane", "region", "marker_offset",
                "marker_offset_std")
# Metres: no mirror's glass is this thick; a larger marker_offset in a file is a mistake.
MAX_MARKER_OFFSET = 0.05


@dataclass(frozen=True)
class SessionMirror:
    """One mirror as the user set it up.

    Attributes
    ----------
    name : str
        Shown to people, unique in the session.
    markers : (k, 2) float
        Pixel coordinates (u, v) clicked on the mirror's markers.
    boundary : (b, 2) float
        Pixel polygon of the mirror's outline in the image (empty until drawn).
    plane : Plane or None
        The calibrated plane (the reflecting surface).
    id : int
        A stable identity (>= 1, unique in the session), kept when other mirrors are removed or
        reordered; 0 until the session gives it one (Session.__post_init__).
    region : (r, 2) float or None
        Pixel polygon on the mirror's frame, for calibration by region.
    marker_offset : float
        Metres from the markers' faces to the reflecting surface (the silver behind the glass),
        along the normal away from the camera; 0 when the markers lie on the reflecting surface.
        |marker_offset| <= MAX_MARKER_OFFSET.
    extra : dict
        Keys of the mirror's JSON object that this mirrorscan does not read, kept as they were.
    marker_offset_std : float or None
        Metres, 1 sigma of a marker_offset that a refinement measured; None when it was typed in
        (or is unset: 0). A refinement measures and replaces an unset or measured glass, never
        one typed in (glass_typed).
    """

    name: str
    markers: Pixels = ()
    boundary: Pixels = ()
    plane: Plane | None = None
    id: int = 0
    region: Pixels | None = None
    marker_offset: float = 0.0
    extra: dict = field(default_factory=dict, compare=False)
    marker_offset_std: float | None = None

    @property
    def glass_set(self) -> bool:
        """Whether the glass was typed in or measured.

        0 measured by a refinement is set; 0 alone is not.
        """
        return self.marker_offset != 0.0 or self.marker_offset_std is not None

    @property
    def glass_typed(self) -> bool:
        """Whether the glass was typed in (set, and not measured by a refinement)."""
        return self.marker_offset != 0.0 and self.marker_offset_std is None

    def marker_name(self, k: int) -> str:
        """Return marker k's name as the tool shows it.

        '2.3' is mirror 2's third (by the mirror's id).

        Parameters
        ----------
        k : int
            0-based marker index.

        Returns
        -------
        str
        """
        return f"{self.id}.{k + 1}"

    @property
    def marker_names(self) -> list[str]:
        """The names of all markers, in order (see `marker_name`)."""
        return [self.marker_name(k) for k in range(len(self.markers))]

    @property
    def marker_plane(self) -> Plane | None:
        """The plane of the markers' faces, or None while uncalibrated.

        The calibrated reflecting surface moved towards the camera by marker_offset (the stickers
        sit on the glass).
        """
        if self.plane is None:
            return None
        return Plane(self.plane.normal, self.plane.d - self.marker_offset)

    def to_json(self) -> dict:
        """The mirror's session.json object, its extra keys included."""
        data = {"id": self.id, "name": self.name, "markers": [list(m) for m in self.markers],
                "boundary": [list(b) for b in self.boundary],
                "plane": None if self.plane is None else self.plane.to_list()}
        if self.region is not None:
            data["region"] = [list(p) for p in self.region]
        if self.marker_offset != 0.0:
            data["marker_offset"] = self.marker_offset
        if self.marker_offset_std is not None:
            data["marker_offset_std"] = self.marker_offset_std
        return {**data, **self.extra}


@dataclass(frozen=True)
class Session:
    """A session folder in memory.

    Mirrors without an id (0) get the smallest unused ones, in order, so that every mirror has a
    stable identity.

    Attributes
    ----------
    root : Path
        The session folder.
    camera : Intrinsics
        The depth camera.
    mirrors : tuple of SessionMirror
        The mirrors, in label order.
    background : str or None
        The background frame's path, relative to `root` (POSIX style).
    frames : tuple of str
        The frames' paths, relative to `root` (POSIX style).
    selection : Selection
        How the object is found in a frame (the defaults unless the file says otherwise).
    timestamps : tuple of float or None
        (n,) seconds, one per frame (a recording has them; without, frames play at i / fps).
    colour_frames : tuple of str or None
        n colour PNG paths relative to `root`, one per frame.
    extra : dict
        Top-level keys this mirrorscan does not read, kept as they were.
    bounces : int
        The most mirrors Algorithm 1 and the dense methods follow a ray through, 1 to MAX_ORDER
        (mirrorcore.rig.model).
    """

    root: Path
    camera: Intrinsics
    mirrors: tuple[SessionMirror, ...] = ()
    background: str | None = None
    frames: tuple[str, ...] = ()
    selection: Selection = Selection()
    timestamps: tuple[float, ...] | None = None
    colour_frames: tuple[str, ...] | None = None
    extra: dict = field(default_factory=dict, compare=False)
    bounces: int = MAX_ORDER

    def __post_init__(self) -> None:
        if any(m.id < 1 for m in self.mirrors):
            object.__setattr__(self, "mirrors", _with_ids(self.mirrors))

    @property
    def path(self) -> Path:
        """The session's session.json."""
        return Path(self.root) / SESSION_FILE

    def to_json(self) -> dict:
        """The session.json object, its extra keys included."""
        data = {"version": VERSION, "camera": self.camera.to_dict(),
                "mirrors": [m.to_json() for m in self.mirrors],
                "background": self.background, "frames": list(self.frames)}
        if self.selection != Selection():
            data["selection"] = self.selection.to_json()
        if self.timestamps is not None:
            data["timestamps"] = list(self.timestamps)
        if self.colour_frames is not None:
            data["colour_frames"] = list(self.colour_frames)
        if self.bounces != MAX_ORDER:
            data["bounces"] = self.bounces
        return {**data, **self.extra}

    def with_mirror(self, index: int, mirror: SessionMirror) -> "Session":
        """Return a copy with one mirror replaced.

        Parameters
        ----------
        index : int
            0-based.
        mirror : SessionMirror

        Returns
        -------
        Session
        """
        mirrors = list(self.mirrors)
        mirrors[index] = mirror
        return replace(self, mirrors=tuple(mirrors))

    def mirror_index(self, mirror_id: int) -> int:
        """Return the position of the mirror with an identity.

        Parameters
        ----------
        mirror_id : int
            The mirror's id.

        Returns
        -------
        int
            0-based.

        Raises
        ------
        MirrorscanError
            There is no such mirror.
        """
        for i, m in enumerate(self.mirrors):
            if m.id == mirror_id:
                return i
        raise MirrorscanError(f"{self.path}: no mirror with id {mirror_id} (it was removed?)")

    def read_frame(self, index: int) -> np.ndarray:
        """Read one frame.

        Parameters
        ----------
        index : int
            0-based, negative counts from the end.

        Returns
        -------
        (H, W) float32 array
            Metres.

        Raises
        ------
        MirrorscanError
            The session has no frames, or no such frame.
        FileFormatError
            The frame's file is missing or unreadable.
        """
        if not self.frames:
            raise MirrorscanError(f"{self.path}: the session has no frames")
        if not -len(self.frames) <= index < len(self.frames):
            raise MirrorscanError(
                f"{self.path}: no frame {index}; the session has {len(self.frames)} "
                                  f"(0 to {len(self.frames) - 1})")
        return self._read(self.frames[index])

    def spread_frames(self, most: int) -> np.ndarray:
        """Pick up to `most` frame indices, evenly spaced over the session's frames.

        Parameters
        ----------
        most : int

        Returns
        -------
        (k,) int array
            Empty without frames.
        """
        if not self.frames:
            return np.zeros(0, int)
        return np.unique(np.linspace(0, len(self.frames) - 1,
                                     min(len(self.frames), most)).astype(int))

    def read_frames(self, indices) -> np.ndarray:
        """Read frames (`read_frame` each).

        Parameters
        ----------
        indices : (k,) integer array_like

        Returns
        -------
        (k, H, W) float32 array
            Metres.
        """
        return np.stack([self.read_frame(int(i)) for i in indices])

    def read_background(self) -> np.ndarray | None:
        """Read the background frame as (H, W) float32 metres, or None when the session has none."""
        return None if self.background is None else self._read(self.background)

    def _read(self, rel: str) -> np.ndarray:
        """Read the depth PNG at a path relative to the session folder, in metres."""
        return read_depth_png(Path(self.root) / rel, self.camera.depth_scale, self.camera.shape)


def _with_ids(mirrors: tuple[SessionMirror, ...]) -> tuple[SessionMirror, ...]:
    """Give the mirrors without an id (0) the smallest ids not taken, in order."""
    taken = {m.id for m in mirrors if m.id >= 1}
    free = (k for k in range(1, len(mirrors) + len(taken) + 1) if k not in taken)
    return tuple(m if m.id >= 1 else replace(m, id=next(free)) for m in mirrors)


# --------------------------------------------------------------------- reading
def load_session(folder: str | Path) -> Session:
    """Read and validate a session folder's session.json.

    Parameters
    ----------
    folder : str or Path
        The session folder.

    Returns
    -------
    Session

    Raises
    ------
    FileFormatError
        Naming the file and the offending key.
    """
    folder = Path(folder)
    return session_from_json(read_json(folder / SESSION_FILE,
                                       f"file (is {folder} a session folder?)",
                                       MAX_SESSION_BYTES), folder)


def session_from_json(data, folder: Path) -> Session:
    """Validate a parsed session.json (see docs/DESIGN.md).

    Parameters
    ----------
    data : object
        The parsed JSON.
    folder : Path
        The session folder that paths are relative to.

    Returns
    -------
    Session

    Raises
    ------
    FileFormatError
        Naming the file and the key.
    """
    where = str(Path(folder) / SESSION_FILE)
    if not isinstance(data, dict):
        raise FileFormatError(f"{where}: the top level must be a JSON object")
    missing = [k for k in ("version", "camera", "mirrors", "frames") if k not in data]
    if missing:
        raise FileFormatError(f"{where}: missing key(s) {', '.join(missing)}")
    if data["version"] != VERSION:
        raise FileFormatError(
            f"{where}: unknown version {str(data['version'])[:40]}; this mirrorscan reads version "
                              f"{VERSION}")
    camera = Intrinsics.from_dict(data["camera"], f"{where}: camera")
    mirrors = tuple(_mirror_from_json(m, camera, f"{where}: mirrors[{i}]")
                    for i,
                    m in enumerate(read_list(data["mirrors"], f"{where}: mirrors", MAX_MIRRORS,
                                                    "mirrors")))
    _check_ids(mirrors, where)
    background = data.get("background")
    if background is not None:
        background = read_relative_path(background, folder, f"{where}: background")
    frames = read_paths(data["frames"], folder, f"{where}: frames", MAX_FRAMES)
    timestamps = data.get("timestamps")
    if timestamps is not None:
        timestamps = read_timestamps(timestamps, len(frames), f"{where}: timestamps")
    colour_frames = data.get("colour_frames")
    if colour_frames is not None:
        colour_frames = read_paths(colour_frames, folder, f"{where}: colour_frames", MAX_FRAMES)
        if len(colour_frames) != len(frames):
            raise FileFormatError(
                f"{where}: colour_frames: {len(colour_frames)} paths for {len(frames)} frames")
    bounces = data.get("bounces", MAX_ORDER)
    if isinstance(bounces, bool) or not isinstance(bounces, int) or not 1 <= bounces <= MAX_ORDER:
        raise FileFormatError(
            f"{where}: bounces: must be a whole number from 1 to {MAX_ORDER}, got {bounces!r}")
    extra = {k: v for k, v in data.items() if k not in _TOP_KEYS}
    return Session(Path(folder), camera, mirrors, background, frames,
                   Selection.from_json(data.get("selection"), f"{where}: selection"), timestamps,
                   colour_frames, extra,
                   bounces)


def _mirror_from_json(data, camera: Intrinsics, where: str) -> SessionMirror:
    """Validate one mirror object of session.json."""
    if not isinstance(data, dict):
        raise FileFormatError(f"{where}: a mirror must be a JSON object")
    try:
        check_name(data.get("name"), f"{where}: name")
    except MirrorscanError as exc:
        raise FileFormatError(str(exc)) from None
    where = f"{where} ({data['name']})"
    mirror_id = data.get("id", 0)                # none yet: the session gives it one
    if "id" in data and (isinstance(mirror_id, bool) or not isinstance(mirror_id, int)
                         or not 1 <= mirror_id < 2**31):
        raise FileFormatError(
            f"{where}: 'id' must be a whole number from 1, got {str(mirror_id)[:40]}")
    markers = read_pixels(data.get("markers", []), camera, f"{where}: markers", MAX_MARKERS)
    boundary = read_polygon(data.get("boundary", []), camera, f"{where}: boundary")
    region = data.get("region")
    if region is not None:
        region = read_polygon(region, camera, f"{where}: region")
    plane = data.get("plane")
    if plane is not None:
        try:
            plane = Plane.from_abcd(plane, f"{where}: plane", orient=False)
        except MirrorscanError as exc:
            raise FileFormatError(str(exc)) from None
    offset = data.get("marker_offset", 0.0)
    if (isinstance(offset, bool) or not isinstance(offset, (int, float)) or not np.isfinite(offset)
            or abs(offset) > MAX_MARKER_OFFSET):
        raise FileFormatError(
            f"{where}: 'marker_offset' must be metres from the markers to the reflecting surface, "
                              f"within ±{MAX_MARKER_OFFSET:g}, got {offset!r}")
    std = data.get("marker_offset_std")
    if std is not None and (isinstance(std, bool) or not isinstance(std, (int, float))
                            or not 0 <= std
                            <= MAX_MARKER_OFFSET):          # NaN fails the comparison too
        raise FileFormatError(f"{where}: 'marker_offset_std' must be the metres (0 to "
                              f"{MAX_MARKER_OFFSET:g}) to which "
                              f"a refinement measured the glass, got {std!r}")
    extra = {k: v for k, v in data.items() if k not in _MIRROR_KEYS}
    return SessionMirror(data["name"], markers, boundary, plane, mirror_id, region, float(offset),
                         extra,
                         None if std is None else float(std))


def _check_ids(mirrors: tuple[SessionMirror, ...], where: str) -> None:
    """Refuse an id given to more than one mirror."""
    ids = [m.id for m in mirrors if m.id]
    if len(set(ids)) != len(ids):
        twice = sorted({i for i in ids if ids.count(i) > 1})
        raise FileFormatError(f"{where}: mirrors: id {twice[0]} is given to more than one mirror")


# --------------------------------------------------------------------- writing
def save_session(session: Session) -> None:
    """Write the session's session.json atomically, creating its folder.

    The previous version is kept as session.json.bak.

    Parameters
    ----------
    session : Session
    """
    Path(session.root).mkdir(parents=True, exist_ok=True)
    text = json.dumps(session.to_json(), indent=2) + "\n"
    write_atomic(session.path, text.encode("utf-8"), backup=True)


_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_ .-]{0,99}$")


def session_folder(sessions_dir: str | Path, name: str) -> Path:
    """Return the folder of a session inside the sessions folder.

    Parameters
    ----------
    sessions_dir : str or Path
        The folder that holds the sessions.
    name : str
        The session's name.

    Returns
    -------
    Path

    Raises
    ------
    MirrorscanError
        The name is empty, too long, or could leave the folder (separators, '..', leading dots).
    """
    name = name.strip()
    if not _NAME.match(name) or ".." in name:
        raise MirrorscanError(
            f"session name {name!r}: use letters, digits, spaces, '_', '-' and '.' (not '..'), "
                              "at most 100 characters, starting with a letter, digit or '_'")
    return Path(sessions_dir) / name


def copy_session(session: Session, folder: str | Path) -> Session:
    """Save a session under a new folder with its background, frames and colour frames.

    All or nothing.

    Parameters
    ----------
    session : Session
    folder : str or Path
        The new folder; it must not exist or be empty.

    Returns
    -------
    Session
        The session as it now lives in `folder`.

    Raises
    ------
    MirrorscanError
        `folder` exists and is not empty.
    """
    folder = Path(folder)
    with new_folder(folder) as work:
        for rel in ([session.background] if session.background else []) + list(session.frames) \
                + list(session.colour_frames or ()):
            (work / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(Path(session.root) / rel, work / rel)
        save_session(replace(session, root=work))
    return replace(session, root=folder)
