"""Depth sources: where frames come from (the simulated rig, a session's recorded frames), behind one interface."""
from __future__ import annotations

from pathlib import Path
from typing import Protocol

import numpy as np

from .camera import Intrinsics
from .errors import FileFormatError, MirrorscanError
from .jsonfile import read_json
from .session import Session
from .sim.export import TRUTH_FILE
from .sim.layouts import paper_scene
from .sim.scene import Scene, load_scene, scene_from_json
from .sim.source import SimulatedRig


class DepthSource(Protocol):
    """Frames of one depth camera. `frame_count` is None for a live source; `read(i)` gives frame i as (H, W) float32
    metres (0 = no reading) and may block until it arrives; `background()` is the scene without the object, or None."""

    name: str
    intrinsics: Intrinsics
    fps: float
    frame_count: int | None

    def read(self, i: int) -> np.ndarray: ...

    def background(self) -> np.ndarray | None: ...


class SimulatedSource:
    """The simulated rig as a live source (frames at its fps, animated objects)."""

    def __init__(self, rig: SimulatedRig, name: str = "simulated rig"):
        self.rig, self.name = rig, name
        self.intrinsics, self.fps, self.frame_count = rig.intrinsics, rig.fps, None

    def read(self, i: int) -> np.ndarray:
        return self.rig.frame(i).depth

    def background(self) -> np.ndarray:
        return self.rig.background().depth


class SessionSource:
    """A session's recorded frames, seekable, at `fps` frames per second."""

    def __init__(self, session: Session, fps: float = 30.0):
        if not session.frames:
            raise MirrorscanError(f"{session.path}: the session has no frames to play")
        self.session, self.name = session, f"session {Path(session.root).name}"
        self.intrinsics, self.fps, self.frame_count = session.camera, fps, len(session.frames)

    def read(self, i: int) -> np.ndarray:
        return self.session.read_frame(i % self.frame_count)

    def background(self) -> np.ndarray | None:
        return self.session.read_background()


def open_source(spec: str | None, session: Session | None) -> DepthSource:
    """A source from a spec: 'sim' (the paper's rig, or the session's simulated scene when it has a truth.json),
    'sim:SCENE.json', or 'session' (the session's own frames). None picks 'session' for a session with frames, else
    'sim'. Raises MirrorscanError for an unknown spec."""
    if spec is None:
        spec = "session" if session is not None and session.frames else "sim"
    if spec == "session":
        if session is None:
            raise MirrorscanError("--source session: give a SESSION folder")
        return SessionSource(session)
    if spec == "sim":
        return SimulatedSource(SimulatedRig(session_scene(session) or paper_scene(object="figure", distance=3.0)))
    if spec.startswith("sim:"):
        return SimulatedSource(SimulatedRig(load_scene(spec[4:])), f"simulated {Path(spec[4:]).name}")
    raise MirrorscanError(f"unknown source {spec!r}: use sim, sim:SCENE.json or session")


def session_scene(session: Session | None) -> Scene | None:
    """The simulated scene a session was made from (its truth.json), or None."""
    if session is None or not (Path(session.root) / TRUTH_FILE).is_file():
        return None
    path = Path(session.root) / TRUTH_FILE
    data = read_json(path, "truth file")
    if not isinstance(data, dict) or "scene" not in data:
        raise FileFormatError(f"{path}: missing key 'scene'")
    return scene_from_json(data["scene"], f"{path}: scene")
