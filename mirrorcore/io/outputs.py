"""What a command may write over: never a file that belongs to a session (docs/DESIGN.md, 'Session
folder'), nor one of the command's own inputs. Every command that writes a file a user named calls
check_output first; so should the browser tool's exports."""
from __future__ import annotations

import json
from pathlib import Path, PurePosixPath

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.session import BACKGROUND_FILE, FRAMES_FOLDER, SESSION_FILE, TRUTH_FILE


def check_output(path: str | Path, inputs: tuple[str | Path, ...] = ()) -> Path:
    """Refuse to write a file that belongs to a session, or one of the command's own inputs.

    Every command that writes a file a user named calls this first. A file belongs to the session
    of the nearest folder above it that holds session.json when it is that session.json, its .bak,
    its background, its truth.json, a frame or colour frame it lists, or its frames/ folder and
    anything in it. Paths are compared after resolving symbolic links and '..'.

    Parameters
    ----------
    path : str or Path
        The file to write.
    inputs : tuple of str or Path
        The files or folders the command reads.

    Returns
    -------
    Path
        `path`.

    Raises
    ------
    MirrorscanError
        Naming `path`.
    """
    target = Path(path).resolve()
    if (target / SESSION_FILE).is_file():
        raise MirrorscanError(f"{path}: is a session folder; write the output elsewhere")
    for folder in target.parents:
        if (folder / SESSION_FILE).is_file():
            rel = target.relative_to(folder).as_posix()
            if rel in session_files(folder) or rel.split("/")[0] == FRAMES_FOLDER:
                raise MirrorscanError(
                    f"{path}: would write over {rel} of the session {folder}; write the output "
                                      f"elsewhere (e.g. {folder / 'exports'}/)")
            break
    for given in inputs:
        if target == Path(given).resolve():
            raise MirrorscanError(
                f"{path}: is this command's own input; write the output elsewhere")
    return Path(path)


def session_files(folder: str | Path) -> set[str]:
    """Return the files that belong to the session in a folder.

    They are session.json and its .bak, background.png and truth.json, and the background, frames
    and colour frames that its session.json lists (read leniently: a damaged session.json still
    protects its files by their usual names).

    Parameters
    ----------
    folder : str or Path
        The session folder.

    Returns
    -------
    set of str
        POSIX paths relative to `folder`.
    """
    files = {SESSION_FILE, SESSION_FILE + ".bak", BACKGROUND_FILE, TRUTH_FILE}
    try:
        data = json.loads((Path(folder) / SESSION_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return files
    if not isinstance(data, dict):
        return files
    listed = [data.get("background")] + [p for key in ("frames", "colour_frames")
                                         if isinstance(data.get(key), list) for p in data[key]]
    files.update(PurePosixPath(p.replace("\\", "/")).as_posix() for p in listed
                 if isinstance(p, str) and p)
    return files
