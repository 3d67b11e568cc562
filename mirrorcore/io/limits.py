"""What a session may hold: checked where a session is read (sessionfile.session_from_json),
which the browser's editor runs on every change before it saves (sessionfile.check_session), so
that a session that was saved always opens."""
from __future__ import annotations

import unicodedata

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.polygon import MAX_VERTICES
from mirrorcore.io.fields import encodable

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
