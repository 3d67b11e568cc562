"""Atomic writes: a file written beside its target, flushed, then renamed over it (one backup kept);
a folder built under a hidden name beside its target, then renamed into place."""
from __future__ import annotations

import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from mirrorcore.base.errors import MirrorscanError


def write_atomic(path: str | Path, data: bytes, backup: bool = False, durable: bool = True) -> None:
    """Replace a file so that a reader sees either the old file or the new one, never a partial one.

    Parameters
    ----------
    path : str or Path
        The file to replace.
    data : bytes
        Its new content.
    backup : bool
        Keep the previous version as `path` + '.bak' (itself replaced atomically, before the
        rename).
    durable : bool
        Flush the data to the disk (fsync) before the rename, so that a power cut cannot leave a
        partial file under the name. False leaves that to the caller (`make_durable`), who may rely
        on the file surviving a power cut only once that returned; the write is atomic for every
        process that reads it either way (a batch's frames are flushed by the manifest's writer,
        just before the manifest lists them).

    Raises
    ------
    OSError
        Full disk, read-only folder...; names `path`, with the target left untouched.
    """
    path = Path(path)
    try:
        _write_beside(path, data, backup, durable)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from exc


def make_durable(path: str | Path) -> None:
    """Flush a file written with ``write_atomic(durable=False)`` to the disk.

    Parameters
    ----------
    path : str or Path
        The file to flush.

    Raises
    ------
    OSError
        Naming `path`.
    """
    try:
        fd = os.open(path, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from exc


def _write_beside(path: Path, data: bytes, backup: bool, durable: bool) -> None:
    """Write `data` to a temporary file beside `path`, then rename it over `path`."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            os.fchmod(f.fileno(),
                      path.stat().st_mode & 0o7777 if path.exists() else 0o666 & ~current_umask())
            f.write(data)
            f.flush()
            if durable:
                os.fsync(f.fileno())
        if backup and path.exists():
            _link_or_copy(path, tmp + ".bak")
            os.replace(tmp + ".bak", path.with_name(path.name + ".bak"))
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        Path(tmp + ".bak").unlink(missing_ok=True)
        raise


def _link_or_copy(source: Path, target: str) -> None:
    """Make a second name for `source`: a hard link, or a copy where there are no hard links.

    A hard link is instant and keeps the old version once `source` is replaced. The backup is then
    renamed into place: a process killed while making it leaves the previous backup, never a
    partial one.
    """
    try:
        os.link(source, target)
    except OSError:
        shutil.copy2(source, target)


def current_umask() -> int:
    """The process's file mode creation mask (read by setting it, then restoring it)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextmanager
def new_folder(path: str | Path) -> Iterator[Path]:
    """Build a folder all or nothing.

    Parameters
    ----------
    path : str or Path
        The folder to build; it must not exist or be an empty folder.

    Yields
    ------
    Path
        A hidden temporary folder beside `path`, renamed to `path` when the block ends normally and
        removed when it raises (Ctrl-C included).

    Raises
    ------
    MirrorscanError
        `path` exists and is not an empty folder.
    """
    path = Path(path)
    if path.exists() and (not path.is_dir() or any(path.iterdir())):
        raise MirrorscanError(f"{path}: already exists and is not an empty folder")
    path.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent))
    try:
        os.chmod(work, 0o777 & ~current_umask())   # mkdtemp makes it private; the folder is not
        yield work
        if path.exists():
            path.rmdir()
        os.replace(work, path)
    finally:
        shutil.rmtree(work, ignore_errors=True)    # gone already after the rename
