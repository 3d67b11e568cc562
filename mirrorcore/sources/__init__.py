"""Floor 8, depth sources behind one interface (Frame, DepthSource), chosen by a short spec string:
open_source(spec) and the table of kinds with what each needs on this machine (`mirrorscan
sources`).

Specs: KIND:TARGET[?key=value&...]; options camera=FILE|kinect_v1|primesense,
scale=METRES_PER_UNIT, fps=N, colour=registered|none (the cameras: freenect, openni2, realsense;
default none). A bare path works too: a session folder, a TUM folder (depth.txt), a folder of
PNGs, a .npz, .bag or .oni file.
"""
from __future__ import annotations

import importlib.util
from dataclasses import dataclass
from pathlib import Path
from typing import Callable
from urllib.parse import parse_qsl

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.session import SESSION_FILE, Session
from mirrorcore.io.sessionfile import load_session
from mirrorcore.sources.base import DepthSource, Frame, require
from mirrorcore.sources.devices import (FREENECT_INSTALL, OPENNI2_INSTALL, FreenectSource,
                                        OpenNI2Source, initialise_openni2)
from mirrorcore.sources.files import (ImageSequenceSource, SessionSource, load_camera,
                                      open_png_folder, open_tum)
from mirrorcore.sources.npz import StackSource, open_npz
from mirrorcore.sources.bag import open_bag
from mirrorcore.sources.realsense import REALSENSE_INSTALL, RealSenseSource
from mirrorcore.sources.record import Recorder, new_recording_folder, record
from mirrorcore.sources.sim import SimulatedSource, open_simulated, session_scene, session_truth

__all__ = ["DepthSource", "Frame", "FreenectSource", "ImageSequenceSource", "KINDS",
           "OpenNI2Source", "RealSenseSource", "Recorder", "SessionSource", "SimulatedSource",
           "SourceKind", "StackSource", "new_recording_folder", "open_source", "parse_spec",
           "record", "session_scene", "session_truth"]
_OPTIONS = ("camera", "scale", "fps", "colour")
_COLOUR = ("none", "registered")


@dataclass(frozen=True)
class SourceKind:
    """One kind of source.

    Attributes
    ----------
    name : str
        The kind.
    spec : str
        Its spec form.
    what : str
        What it reads.
    unavailable : callable
        Returns None when the kind can be used here, or a one-line reason why not.
    colour : str
        What it does with colour.
    """

    name: str
    spec: str
    what: str
    unavailable: Callable[[], str | None]
    colour: str = "no colour"


def _library(module: str, install: str) -> Callable[[], str | None]:
    """A check that names what to install when `module` is missing."""
    return lambda: None if importlib.util.find_spec(module.split(".")[
        0]) else f"needs {module}: install {install}"


def _freenect_devices() -> str | None:
    """Why freenect cannot be used here (library missing, no Kinect v1), or None."""
    missing = _library("freenect", FREENECT_INSTALL)()
    if missing:
        return missing
    freenect = require("freenect", "freenect", FREENECT_INSTALL)
    count = freenect.num_devices(freenect.init())
    return None if count else "freenect is installed; no Kinect v1 is plugged in"


def _openni2_devices() -> str | None:
    """Why OpenNI2 cannot be used here (library missing, no device), or None."""
    missing = _library("openni", OPENNI2_INSTALL)()
    if missing:
        return missing
    openni2 = require("openni.openni2", "openni2", OPENNI2_INSTALL)
    try:
        initialise_openni2(openni2, "openni2")
    except MirrorscanError as exc:
        return str(exc)
    if openni2.Device.enumerate_uris():
        return None
    return "OpenNI2 is installed; no device is plugged in (.oni files work)"


def _realsense_devices() -> str | None:
    """Why RealSense cannot be used here (library missing, no camera), or None."""
    missing = _library("pyrealsense2", REALSENSE_INSTALL)()
    if missing:
        return missing
    rs = require("pyrealsense2", "realsense", REALSENSE_INSTALL)
    if rs.context().query_devices().size():
        return None
    return "pyrealsense2 is installed; no camera is plugged in"


_OPT_IN = "colour with ?colour=registered"
KINDS = (
    SourceKind("sim", "sim | sim:SCENE.json", "the simulated rig (live, Kinect v1 noise)",
               lambda: None, "as the simulator renders it"),
    SourceKind("session", "session | SESSION_FOLDER", "a session's recorded frames", lambda: None,
               "colour when the session has colour_frames"),
    SourceKind("dir", "dir:FOLDER",
               "16-bit depth PNGs; camera.json or intrinsic.json beside them, or ?camera=",
               lambda: None),
    SourceKind("tum", "tum:FOLDER", "a TUM RGB-D folder (depth.txt, rgb.txt, metres x 5000)",
               lambda: None, "colour from rgb.txt, nearest stamp within 0.02 s"),
    SourceKind("npz", "npz:FILE", "a .npz stack: depth, K, depth_scale[, timestamps, colour]",
               lambda: None, "colour when the stack has a colour array"),
    SourceKind("bag", "bag:FILE", "a RealSense .bag recording",
               _library("pyrealsense2", REALSENSE_INSTALL),
               "its colour stream aligned to depth, when it has one"),
    SourceKind("freenect", "freenect:INDEX", "a Kinect v1 through libfreenect (live)",
               _freenect_devices, f"{_OPT_IN} (registered depth in mm on the RGB grid)"),
    SourceKind("openni2", "openni2:FILE.oni|URI", "an OpenNI2 device or .oni recording",
               _openni2_devices, f"{_OPT_IN} (depth registered to colour)"),
    SourceKind("realsense", "realsense:SERIAL", "a RealSense camera (live)", _realsense_devices,
               f"{_OPT_IN} (colour aligned to depth)"),
)


def parse_spec(spec: str) -> tuple[str, str, dict[str, str]]:
    """Split a spec 'KIND:TARGET?key=value&...' into its kind, target and options.

    A spec without a known kind is a path; its kind is guessed from what is there (see the module
    docstring).

    Parameters
    ----------
    spec : str

    Returns
    -------
    kind : str
    target : str
    options : dict of str to str

    Raises
    ------
    MirrorscanError
        An unknown kind or option.
    """
    body, _, query = spec.partition("?")
    options = dict(parse_qsl(query, keep_blank_values=True))
    unknown = sorted(set(options) - set(_OPTIONS))
    if unknown:
        raise MirrorscanError(
            f"source {spec!r}: unknown option(s) {', '.join(unknown)}; use {', '.join(_OPTIONS)}")
    kind, colon, target = body.partition(":")
    if colon and kind in {k.name for k in KINDS}:
        return kind, target, options
    if not colon and kind in ("sim", "session"):
        return kind, "", options
    return _guess_kind(Path(body), spec), body, options


def _guess_kind(path: Path, spec: str) -> str:
    """The kind of a spec that names a path, from what is there."""
    suffix = path.suffix.lower()
    if path.is_file() and suffix in (".npz", ".bag", ".oni"):
        return {".npz": "npz", ".bag": "bag", ".oni": "openni2"}[suffix]
    if path.is_dir():
        return "session" if (path / SESSION_FILE).is_file() else "tum" if (
            path / "depth.txt").is_file() else "dir"
    raise MirrorscanError(f"unknown source {spec!r}: use one of {', '.join(k.spec for k in KINDS)} "
                          "(`mirrorscan sources` lists them)")


def open_source(spec: str | None, session: Session | None = None) -> DepthSource:
    """Open the source a spec names (see the module docstring and KINDS).

    Parameters
    ----------
    spec : str or None
        None picks 'session' for a session with frames, else 'sim'.
    session : Session, optional
        The session that 'session' and 'sim' refer to.

    Returns
    -------
    DepthSource

    Raises
    ------
    MirrorscanError
        A missing library or device: what to install or plug in.
    FileFormatError
        A bad file: which and why.
    """
    if spec is None:
        spec = "session" if session is not None and session.frames else "sim"
    kind, target, options = parse_spec(spec)
    fps = _number(options, "fps", spec) or 30.0
    scale = _number(options, "scale", spec)
    camera = load_camera(options["camera"], scale or 0.001) if "camera" in options else None
    colour = options.get("colour", "none")
    if colour not in _COLOUR or (colour != "none"
                                 and kind not in ("freenect", "openni2", "realsense")):
        raise MirrorscanError(f"source {spec!r}: colour={colour} is not read here; the cameras "
                              "take colour=registered (freenect, openni2, realsense)")
    registered = colour == "registered"
    if kind == "sim":
        return open_simulated(target, session)
    if kind == "session":
        if not target and session is None:
            raise MirrorscanError("--source session: give a SESSION folder")
        return SessionSource(load_session(target) if target else session, fps)
    openers = {"dir": lambda: open_png_folder(target, camera, scale, fps),
               "tum": lambda: open_tum(target, camera, scale),
               "npz": lambda: open_npz(target, fps), "bag": lambda: open_bag(target),
               "freenect": lambda: FreenectSource(_index(target, spec), camera,
                                                  colour=registered),
               "openni2": lambda: OpenNI2Source(target, registered),
               "realsense": lambda: RealSenseSource(target, registered)}
    return openers[kind]()


def _number(options: dict[str, str], key: str, spec: str) -> float | None:
    """Option `key` as a positive finite number, None when absent."""
    if key not in options:
        return None
    try:
        value = float(options[key])
    except ValueError:
        value = float("nan")
    if not (value > 0 and value != float("inf")):
        raise MirrorscanError(
            f"source {spec!r}: {key} must be a positive number, got {options[key]!r}")
    return value


def _index(target: str, spec: str) -> int:
    """A freenect device index."""
    if not target.strip().isdigit():
        raise MirrorscanError(f"source {spec!r}: freenect needs a device index (freenect:0)")
    return int(target)
