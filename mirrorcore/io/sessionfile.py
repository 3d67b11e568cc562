"""session.json read and validated in one place (every key typed, naming the file and the key on
error), written atomically with one backup (session.json.bak), and a session's folder: its name
checked, and copied whole to another."""
from __future__ import annotations

import json
import re
import shutil
from dataclasses import fields, replace
from pathlib import Path

from mirrorcore.base.atomic import new_folder, write_atomic
from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.base.jsonfile import finite_number, read_json
from mirrorcore.base.palette import MAX_MIRRORS, MAX_ORDER
from mirrorcore.depth.selection import Selection
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.fields import (read_list, read_paths, read_pixels, read_polygon,
                                  read_relative_path, read_timestamps)
from mirrorcore.io.limits import MAX_FRAMES, MAX_MARKERS, MAX_SESSION_BYTES, check_name
from mirrorcore.io.session import (MAX_COLOUR_GAIN, MAX_MARKER_OFFSET, SESSION_FILE, VERSION,
                                   Session, SessionMirror)

_TOP_KEYS = ("version", "camera", "mirrors", "background", "frames", "selection", "timestamps",
             "colour_frames", "bounces")
_MIRROR_KEYS = ("id", "name", "markers", "boundary", "plane", "region", "marker_offset",
                "marker_offset_std", "colour_gain")


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


def session_from_json(data, folder: Path, where: str | None = None) -> Session:
    """Validate a parsed session.json (see docs/DESIGN.md).

    Parameters
    ----------
    data : object
        The parsed JSON.
    folder : Path
        The session folder that paths are relative to.
    where : str, optional
        What the messages call the file (its path by default).

    Returns
    -------
    Session

    Raises
    ------
    FileFormatError
        Naming the file and the key.
    """
    where = str(Path(folder) / SESSION_FILE) if where is None else where
    if not isinstance(data, dict):
        raise FileFormatError(f"{where}: the top level must be a JSON object")
    missing = [k for k in ("version", "camera", "mirrors", "frames") if k not in data]
    if missing:
        raise FileFormatError(f"{where}: missing key(s) {', '.join(missing)}")
    if data["version"] != VERSION:
        raise FileFormatError(
            f"{where}: unknown version {repr(data['version'])[:40]}; this mirrorscan reads version "
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
            f"{where}: 'id' must be a whole number from 1, got {repr(mirror_id)[:40]}")
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
    offset = finite_number(data.get("marker_offset", 0.0))
    if offset is None or abs(offset) > MAX_MARKER_OFFSET:
        raise FileFormatError(
            f"{where}: 'marker_offset' must be metres from the markers to the reflecting surface, "
            f"within ±{MAX_MARKER_OFFSET:g}, got {repr(data['marker_offset'])[:40]}")
    std = data.get("marker_offset_std")
    if std is not None:
        std = finite_number(std)
        if std is None or not 0 <= std <= MAX_MARKER_OFFSET:
            raise FileFormatError(f"{where}: 'marker_offset_std' must be the metres (0 to "
                                  f"{MAX_MARKER_OFFSET:g}) to which a refinement measured the "
                                  f"glass, got {repr(data['marker_offset_std'])[:40]}")
    extra = {k: v for k, v in data.items() if k not in _MIRROR_KEYS}
    return SessionMirror(data["name"], markers, boundary, plane, mirror_id, region, offset, extra,
                         std, _colour_gain(data.get("colour_gain"), where))


def _colour_gain(gain, where: str) -> tuple[float, float, float] | None:
    """Validate a mirror's colour_gain: None or three numbers in (0, MAX_COLOUR_GAIN]."""
    if gain is None:
        return None
    values = [finite_number(g) for g in gain] if isinstance(gain, list) else []
    if len(values) != 3 or any(g is None or not 0 < g <= MAX_COLOUR_GAIN for g in values):
        raise FileFormatError(f"{where}: 'colour_gain' must be 3 numbers (red, green, blue) "
                              f"above 0 and at most {MAX_COLOUR_GAIN:g}, "
                              f"got {repr(gain)[:40]}")
    return tuple(values)


def _check_ids(mirrors: tuple[SessionMirror, ...], where: str) -> None:
    """Refuse an id given to more than one mirror."""
    ids = [m.id for m in mirrors if m.id]
    if len(set(ids)) != len(ids):
        twice = sorted({i for i in ids if ids.count(i) > 1})
        raise FileFormatError(f"{where}: mirrors: id {twice[0]} is given to more than one mirror")


def check_session(session: Session, known: Session | None = None) -> Session:
    """Check that a session, saved, opens again as itself.

    The session's JSON goes through the reader (`session_from_json`), so that the browser's
    editor refuses exactly what `load_session` would refuse, before it saves.

    Parameters
    ----------
    session : Session
    known : Session, optional
        A session already checked: frame lists that are the very same objects as its own are not
        read again (a million frames take seconds).

    Returns
    -------
    Session
        `session`, unchanged.

    Raises
    ------
    FileFormatError
        In one line naming session.json and the key (as `load_session` would), or the field that
        would read back as another value.
    """
    checked = session
    if known is not None and all(getattr(session, k) is getattr(known, k)
                                 for k in ("frames", "timestamps", "colour_frames")):
        checked = replace(session, frames=(), timestamps=None, colour_frames=None)
    try:
        text = json.dumps(checked.to_json())
    except (TypeError, ValueError) as exc:
        raise FileFormatError(f"{SESSION_FILE}: cannot be written: {exc}") from None
    back = session_from_json(json.loads(text), checked.root, SESSION_FILE)
    differs = next(_differences(checked, back), None)
    if differs is not None:
        key, ours, theirs = differs
        raise FileFormatError(f"{SESSION_FILE}: {key}: {repr(ours)[:80]} would read back as "
                              f"{repr(theirs)[:80]}")
    return session


def _differences(session: Session, back: Session):
    """(key, value, value read back) of every field saved that differs, mirrors field by field."""
    for f in fields(Session):
        ours, theirs = getattr(session, f.name), getattr(back, f.name)
        if f.name == "root" or not f.compare or ours == theirs:
            continue
        if f.name == "mirrors" and len(ours) == len(theirs):
            for i, (m, n) in enumerate(zip(ours, theirs)):
                for g in fields(SessionMirror):
                    if g.compare and getattr(m, g.name) != getattr(n, g.name):
                        yield (f"mirrors[{i}] ({m.name}): {g.name}", getattr(m, g.name),
                               getattr(n, g.name))
        else:
            yield f.name, ours, theirs


# --------------------------------------------------------------------- writing
def save_session(session: Session) -> None:
    """Write the session's session.json atomically, creating its folder.

    The previous version is kept as session.json.bak. What the reader would refuse is not
    written (`check_session`; the frame lists, which the recorder builds, are not read again).

    Parameters
    ----------
    session : Session

    Raises
    ------
    FileFormatError
        When `load_session` would refuse the session or read it back otherwise; nothing written.
    """
    check_session(session, known=session)
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
