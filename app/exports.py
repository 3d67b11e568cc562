"""Exports of the browser tool: PLY bytes (the scene's colours when the cloud has them) downloaded
by the tab and, for a saved session, kept in its exports/ folder under a name that never overwrites
an earlier export (time-stamped, numbered if needed)."""
from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import viser

from mirrorcore.base.atomic import write_atomic
from mirrorcore.io.outputs import check_output
from mirrorcore.io.ply import encode_ply
from mirrorcore.rig.cloud import Cloud

EXPORTS = "exports"


def free_name(folder: Path, stem: str, suffix: str = ".ply") -> Path:
    """A new file's path: folder/stem-YYYYmmdd-HHMMSS.ply, or with -2, -3... when that file exists.

    The name is reserved by creating the file empty, exclusively, so that two exports in the same
    second never share a name. The folder is made when missing.

    Parameters
    ----------
    folder : Path
    stem : str
    suffix : str, optional

    Returns
    -------
    Path

    Raises
    ------
    FileExistsError
        When no free name is found.
    """
    folder.mkdir(parents=True, exist_ok=True)
    base = f"{stem}-{time.strftime('%Y%m%d-%H%M%S')}"
    for k in range(1, 10_000):
        path = folder / (base + (f"-{k}" if k > 1 else "") + suffix)
        try:
            os.close(os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
            return path
        except FileExistsError:
            continue
    raise FileExistsError(f"{folder}: no free name for {stem}; export again in a second")


def cloud_ply(cloud: Cloud) -> bytes:
    """Encode a cloud as PLY: red, green, blue its scene's colours (Cloud.rgb) when it has them.

    Parameters
    ----------
    cloud : Cloud

    Returns
    -------
    bytes
        The PLY file (docs/DESIGN.md layout); the source colours for a cloud without rgb.
    """
    rgb = None if cloud.rgb is None else np.ascontiguousarray(cloud.rgb)
    return encode_ply(cloud.points, cloud.sources, colours=rgb)


def export_ply(session_root: Path | None, stem: str, data: bytes,
               client: viser.ClientHandle | None) -> Path | None:
    """Send PLY bytes to `client` as a download and keep them in the session's exports/ folder.

    Parameters
    ----------
    session_root : Path or None
        The session's folder; None keeps nothing.
    stem : str
        The file name's start.
    data : bytes
        The PLY file.
    client : viser.ClientHandle or None
        The tab to send the download to, if any.

    Returns
    -------
    Path or None
        The path written, or None.
    """
    saved = None
    if session_root is not None:
        saved = check_output(free_name(Path(session_root) / EXPORTS, stem))
        write_atomic(saved, data)
    if client is not None:
        client.send_file_download((saved.name if saved else f"{stem}.ply"), data,
                                  save_immediately=True)
    return saved
