"""Atomic file writes: write beside the target, flush to disk, keep one backup, then rename over the target."""
from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path


def write_atomic(path: str | Path, data: bytes, backup: bool = False) -> None:
    """Replace `path` with `data` so that a reader sees either the old file or the new one, never a partial one.

    backup : keep the previous version as `path` + '.bak' (copied before the rename).
    Raises OSError (full disk, read-only folder...) naming `path`, with the target left untouched.
    """
    path = Path(path)
    try:
        _write_beside(path, data, backup)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from exc


def _write_beside(path: Path, data: bytes, backup: bool) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            os.fchmod(f.fileno(), path.stat().st_mode & 0o7777 if path.exists() else 0o666 & ~current_umask())
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        if backup and path.exists():
            shutil.copy2(path, path.with_name(path.name + ".bak"))
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def current_umask() -> int:
    """The process's file mode creation mask (read by setting it, then restoring it)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask
