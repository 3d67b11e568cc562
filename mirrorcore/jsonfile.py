"""Reading JSON files (sessions, scenes, truth) with one-line errors that name the file."""
from __future__ import annotations

import json
from pathlib import Path

from .errors import FileFormatError


def read_json(path: str | Path, what: str = "file") -> object:
    """The parsed content of a JSON file; FileFormatError naming the file when it is missing, not UTF-8 or invalid.
    what : how the file is called in the 'no such ...' message ('session file', 'scene file'...)."""
    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"{path}: no such {what}")
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise FileFormatError(f"{path}: not UTF-8 text") from None
    except json.JSONDecodeError as exc:
        raise FileFormatError(f"{path}: invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}") from None
