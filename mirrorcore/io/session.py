"""The session folder (docs/DESIGN.md): a session and its mirrors, every key of session.json
typed (camera, mirrors, background, frames, and the extensions selection, bounces, timestamps,
colour_frames, a mirror's id, region and marker_offset); sessionfile reads, validates and saves
it. Keys that this mirrorscan does not read are kept as they were."""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.base.palette import MAX_ORDER
from mirrorcore.depth.files import read_colour, read_depth_png
from mirrorcore.depth.selection import Selection
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.fields import Pixels

VERSION = 1
SESSION_FILE = "session.json"
# Where a captured or rendered background is saved.
BACKGROUND_FILE = "background.png"
# The simulator's scene and true planes, beside its session.json.
TRUTH_FILE = "truth.json"
# Every file in it belongs to the session (a recording lists frames as they land).
FRAMES_FOLDER = "frames"
# Metres: no mirror's glass is this thick; a larger marker_offset in a file is a mistake.
MAX_MARKER_OFFSET = 0.05
# A mirror's colour gain per channel lies in (0, MAX_COLOUR_GAIN]: a mirror reflects at most all
# of the light, and an exposure that differs between views may brighten a little.
MAX_COLOUR_GAIN = 2.0


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
    colour_gain : (3,) tuple of float or None
        The fraction of red, green and blue the mirror reflects, as measured where the direct view
        and the mirror's view see the same surface (a level seen through the mirror is the level
        seen directly times the gain); None until measured (taken as 1). Each in
        (0, MAX_COLOUR_GAIN].
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
    colour_gain: tuple[float, float, float] | None = None

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
        if self.colour_gain is not None:
            data["colour_gain"] = list(self.colour_gain)
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

    def read_colour(self, index: int) -> np.ndarray | None:
        """Read one frame's colour image.

        Parameters
        ----------
        index : int
            0-based, negative counts from the end (a frame `read_frame` reads).

        Returns
        -------
        (H, W, 3) uint8 array or None
            RGB registered to the depth; None when the session has no colour frames.

        Raises
        ------
        FileFormatError
            The colour file is missing or unreadable.
        """
        if self.colour_frames is None:
            return None
        return read_colour(Path(self.root) / self.colour_frames[index], self.camera)

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

