"""Reading JSON files (sessions, scenes, truth) with one-line errors that name the file."""
from __future__ import annotations

import json
import math
from pathlib import Path

from mirrorcore.base.errors import FileFormatError

# no file mirrorscan reads as JSON comes near; a larger one is refused before reading
MAX_JSON_BYTES = 64 << 20


def read_json(path: str | Path, what: str = "file", max_bytes: int = MAX_JSON_BYTES) -> object:
    """Read and parse a JSON file.

    Parameters
    ----------
    path : str or Path
        The file.
    what : str
        How the file is called in the 'no such ...' message ('session file', 'scene file'...).
    max_bytes : int
        The largest file read, checked before reading.

    Returns
    -------
    object
        The parsed content.

    Raises
    ------
    FileFormatError
        Naming the file when it is missing, larger than `max_bytes`, not UTF-8, invalid, nested too
        deeply or holding a number too long to read.
    """
    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"{path}: no such {what}")
    size = path.stat().st_size
    if size > max_bytes:
        raise FileFormatError(
            f"{path}: {size:,} bytes, more than the {max_bytes:,} such a file may have")
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise FileFormatError(f"{path}: not UTF-8 text") from None
    except json.JSONDecodeError as exc:
        raise FileFormatError(
            f"{path}: invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}") from None
    except RecursionError:
        raise FileFormatError(f"{path}: nested too deeply to read") from None
    except ValueError as exc:      # an integer of more than 4300 digits
        raise FileFormatError(f"{path}: unreadable number ({exc})") from None


def finite_number(value) -> float | None:
    """Return a parsed JSON (or YAML) number as a finite float, or None.

    Parameters
    ----------
    value : object
        The parsed value.

    Returns
    -------
    float or None
        None for what is not a number, a boolean, infinite, NaN, or an integer too large for a
        float.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        number = float(value)
    except OverflowError:
        return None
    return number if math.isfinite(number) else None
