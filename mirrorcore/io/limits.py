"""What a session may hold: checked where a session is read (session.session_from_json) and
where it is edited (check_limits, which the browser's editor calls before it saves), so that a
session that was saved always opens."""
from __future__ import annotations

import unicodedata
from typing import TYPE_CHECKING

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.base.palette import MAX_MIRRORS
from mirrorcore.geometry.polygon import MAX_VERTICES
from mirrorcore.io.fields import encodable

if TYPE_CHECKING:
    from mirrorcore.io.session import Session

# Per mirror; a calibration needs 3 and uses a 5x5 window around each.
MAX_MARKERS = 500
# Per boundary or region (mirrorcore.geometry.polygon).
MAX_POLYGON_VERTICES = MAX_VERTICES
# Characters of a mirror's name.
MAX_NAME_LENGTH = 100
# Frames of a session: 9 hours at 30 fps.
MAX_FRAMES = 1_000_000
# Bytes of session.json itself; a million frames listed take about 30 MB.
MAX_SESSION_BYTES = 64 << 20


def check_name(name, where: str = "mirror name") -> str:
    """Check a mirror's name.

    Parameters
    ----------
    name : object
        Must be a string of 1 to MAX_NAME_LENGTH characters (not only spaces), writable as UTF-8,
        without control characters.
    where : str
        Named in the error.

    Returns
    -------
    str
        The name.

    Raises
    ------
    MirrorscanError
        Naming `where`.
    """
    if not isinstance(name, str) or not name.strip():
        raise MirrorscanError(f"{where}: must be a non-empty string")
    if len(name) > MAX_NAME_LENGTH:
        raise MirrorscanError(f"{where}: {len(name):,} characters, more than the "
                              f"{MAX_NAME_LENGTH} a name may have")
    if not encodable(name) or any(unicodedata.category(c) == "Cc" for c in name):
        raise MirrorscanError(f"{where}: {name[:40]!r} holds characters that cannot be shown or "
                              "saved (control characters or lone surrogates)")
    return name


def check_limits(session: Session) -> Session:
    """Check a session against the limits that reading it applies.

    MAX_MIRRORS, MAX_MARKERS, MAX_POLYGON_VERTICES, names and MAX_FRAMES, so that an edit that
    would make a session unreadable is refused before it is saved.

    Parameters
    ----------
    session : Session

    Returns
    -------
    Session
        The session, unchanged.

    Raises
    ------
    MirrorscanError
        Naming the session file, the mirror and the limit.
    """
    where = str(session.path)
    if len(session.mirrors) > MAX_MIRRORS:
        raise MirrorscanError(f"{where}: {len(session.mirrors)} mirrors, more than the "
                              f"{MAX_MIRRORS} a session may hold")
    for i, m in enumerate(session.mirrors):
        at = f"{where}: mirrors[{i}]"
        check_name(m.name, f"{at}: name")
        if len(m.markers) > MAX_MARKERS:
            raise MirrorscanError(f"{at} ({m.name}): {len(m.markers)} markers, more than the "
                                  f"{MAX_MARKERS} a mirror may have")
        for key, polygon in (("boundary", m.boundary), ("region", m.region or ())):
            if len(polygon) > MAX_POLYGON_VERTICES:
                raise MirrorscanError(f"{at} ({m.name}): {key}: {len(polygon):,} vertices, more "
                                      f"than the {MAX_POLYGON_VERTICES:,} a polygon may have")
    if len(session.frames) > MAX_FRAMES:
        raise MirrorscanError(f"{where}: {len(session.frames):,} frames, more than the "
                              f"{MAX_FRAMES:,} a session may hold")
    return session
