"""What a batch reconstruction computes: the job (session, output folder, method, its options,
temporal smoothing), each frame's output file name, and the fingerprint of everything the output
files depend on."""
from __future__ import annotations

import hashlib
from dataclasses import dataclass, field, replace
from pathlib import Path

from mirrorcore.dense import METHODS, DenseOptions
from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.io.session import Session

BATCH_METHODS = ("raw", *METHODS)
# what a cloud's red, green and blue carry: the scene's colour (from the colour frames), or the
# source colours
COLOURS = ("scene", "source")


@dataclass(frozen=True)
class BatchJob:
    """One PLY file per frame of a session's recording.

    Attributes
    ----------
    session : Path
        The session folder (calibrated).
    out : Path
        The output folder (created when missing).
    method : str
        'raw' (Algorithm 1, a cloud), 'paper' / 'carve' (a carved cloud), 'tsdf' (a mesh); each
        frame alone.
    options : DenseOptions
        The dense methods' voxel, margin, bounds, threshold and truncation (unused by 'raw').
    temporal : int
        N > 0 smooths each frame's depth with its N neighbours on each side where the scene is
        static (mirrorcore.depth.temporal); 0 = off.
    bounces : int or None
        The most mirrors in turn a camera ray is followed through (None: the session's setting).
    colour : str or None
        'scene': the frames' red, green and blue carry the scene's colour (each mirror's colour
        gain undone); 'source': the source colours; None: the session has no colour frames (see
        `for_session`), the source colours.
    """

    session: Path
    out: Path
    method: str = "raw"
    options: DenseOptions = field(default_factory=DenseOptions)
    temporal: int = 0
    bounces: int | None = None
    colour: str | None = "scene"

    def __post_init__(self) -> None:
        if self.method not in BATCH_METHODS:
            raise MirrorscanError(f"--method: unknown method {self.method!r} (expected one of "
                                  f"{', '.join(BATCH_METHODS)})")
        if isinstance(self.temporal, bool) or not isinstance(
            self.temporal, int) or self.temporal < 0:
            raise MirrorscanError(
                f"--temporal: expected a whole number of neighbour frames >= 0, got "
                                  f"{self.temporal!r}")
        if self.colour is not None and self.colour not in COLOURS:
            raise MirrorscanError(f"--colour: expected one of {', '.join(COLOURS)}, got "
                                  f"{self.colour!r}")
        object.__setattr__(self, "session", Path(self.session))
        object.__setattr__(self, "out", Path(self.out))

    @property
    def scene_colour(self) -> bool:
        """True when the frames' PLY files carry the scene's colour."""
        return self.colour == "scene"

    def for_session(self, session: Session) -> BatchJob:
        """Return this job with colour None when `session` has no colour frames.

        Parameters
        ----------
        session : Session

        Returns
        -------
        BatchJob
        """
        return self if session.colour_frames is not None else replace(self, colour=None)

    def settings(self) -> dict:
        """Return the choices that shape the output, as JSON.

        {'method': ..., 'options': {the dense options the method uses, 'temporal', 'bounces'
        when set, 'colour' ('scene' or 'source') on a session with colour frames}}.
        """
        options: dict = {}
        if self.method != "raw":
            o = self.options
            options.update(voxel=o.voxel, margin=o.margin, threshold=o.threshold,
                           bounds=None if o.bounds is None else [list(o.bounds[0]), list(o.bounds[
                               1])])
            if self.method == "tsdf":
                options.update(truncation=o.truncation)
        options["temporal"] = self.temporal
        if self.bounces is not None:
            options["bounces"] = self.bounces
        if self.colour is not None:
            options["colour"] = self.colour
        return {"method": self.method, "options": options}


def exports_folder(session_root: str | Path, method: str = "raw", temporal: int = 0) -> Path:
    """Return the folder the browser tool writes a session's batch into.

    SESSION/exports/frames-METHOD (with '-temporalN' when smoothed), beside its other exports
    (docs/DESIGN.md, session folder).

    Parameters
    ----------
    session_root : str or Path
    method : str
    temporal : int

    Returns
    -------
    Path
    """
    return Path(session_root) / "exports" / (f"frames-{method}" + (
        f"-temporal{temporal}" if temporal else ""))


def output_names(session: Session) -> tuple[str, ...]:
    """Return each frame's PLY file name: its image's stem + '.ply'.

    'frames/000123.png' gives '000123.ply'.

    Parameters
    ----------
    session : Session

    Returns
    -------
    tuple of str

    Raises
    ------
    MirrorscanError
        Two frames share a stem (their files would collide).
    """
    names = tuple(f"{Path(f).stem}.ply" for f in session.frames)
    if len(set(names)) != len(names):
        seen: dict[str, str] = {}
        for frame, name in zip(session.frames, names):
            if name in seen:
                raise MirrorscanError(
                    f"{session.path}: frames {seen[name]} and {frame} would both be written as "
                                      f"{name}")
            seen[name] = frame
    return names


def session_inputs(session: Session, colour: bool = False) -> dict:
    """Return what the output depends on in the session, as JSON.

    The calibration (the camera; each mirror's plane and boundary, in session order; the mirrors
    followed in turn), the object selection, the background image's SHA-256 and the frames' paths
    (their count and a SHA-256 of the list); with `colour`, the mirrors' colour gains
    (calibration.colour_gains) and a SHA-256 of the colour frames' paths (colour_frames).

    Parameters
    ----------
    session : Session
    colour : bool, optional
        The output carries the scene's colour (BatchJob.scene_colour).

    Returns
    -------
    dict
    """
    mirrors = [{"plane": None if m.plane is None else m.plane.to_list(),
                "boundary": [list(p) for p in m.boundary]}
               for m in session.mirrors]
    background = None
    if session.background is not None:
        path = Path(session.root) / session.background
        if not path.is_file():
            raise FileFormatError(f"{path}: no such depth image")
        background = hashlib.sha256(path.read_bytes()).hexdigest()
    frames = _list_digest(session.frames)
    inputs = {"calibration": {"camera": session.camera.to_dict(), "mirrors": mirrors,
                            "bounces": session.bounces},
            "selection": session.selection.to_json(), "background_sha256": background,
            "frames": {"count": len(session.frames), "sha256": frames}}
    if colour:
        inputs["calibration"]["colour_gains"] = [
            None if m.colour_gain is None else list(m.colour_gain) for m in session.mirrors]
        inputs["colour_frames"] = {"sha256": _list_digest(session.colour_frames or ())}
    return inputs


def _list_digest(paths) -> str:
    """The SHA-256 (hex) of a list of paths, one a line."""
    return hashlib.sha256("\n".join(paths).encode("utf-8")).hexdigest()


def differences(old: dict, new: dict, prefix: str = "") -> list[str]:
    """List the keys (dotted paths) whose values differ between two JSON objects.

    With the old and new values when they are single numbers or strings (None as 'none'), for
    example ['method (raw -> tsdf)', 'calibration.mirrors'].

    Parameters
    ----------
    old, new : dict
    prefix : str
        Prepended to the keys.

    Returns
    -------
    list of str
    """
    found = []
    for key in sorted(set(old) | set(new)):
        a, b = old.get(key), new.get(key)
        name = f"{prefix}{key}"
        if a == b:
            continue
        if isinstance(a, dict) and isinstance(b, dict):
            found += differences(a, b, f"{name}.")
        elif all(isinstance(x, (int, float, str, type(None))) for x in (a, b)):
            found.append(f"{name} ({'none' if a is None else a} -> {'none' if b is None else b})")
        else:
            found.append(name)
    return found
