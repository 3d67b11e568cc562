"""Simulated depth sources: the simulated rig as a live camera, and the scene a simulated session
was made from."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from mirrorcore.base.errors import FileFormatError
from mirrorcore.base.jsonfile import finite_number, read_json
from mirrorcore.io.session import TRUTH_FILE, Session
from mirrorcore.sim.export import truth_json
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.scene import Scene
from mirrorcore.sim.scenefile import load_scene, scene_from_json
from mirrorcore.sim.simulator import FPS, Simulator
from mirrorcore.sim.truth import sensor_name
from mirrorcore.sources.base import DepthSource, Frame


class SimulatedSource(DepthSource):
    """The simulated rig as a live source.

    read(i) renders frame i at time i / fps (animated objects, Kinect v1 noise reproducible from the
    rig's seed) with its colour image (the albedo through the mirrors' tints, sim.albedo), so it has
    no frame count but any frame can be asked for. `objects_in_view` False renders the scene without
    its objects, as when the person steps out to capture the background.

    Parameters
    ----------
    rig : Simulator
    name : str
    """

    def __init__(self, rig: Simulator, name: str = "simulated rig"):
        self.rig, self.name = rig, name
        self.intrinsics, self.fps, self.frame_count = rig.intrinsics, rig.fps, None
        self.objects_in_view = True

    @property
    def camera(self) -> bool:
        """False: a rendering, not a physical camera."""
        return False

    @property
    def has_colour(self) -> bool:
        """True: every frame carries its colour image."""
        return True

    def read(self, i: int) -> Frame:
        """Return frame i (see `DepthSource.read`).

        Parameters
        ----------
        i : int
            The frame's index.

        Returns
        -------
        Frame
        """
        if not self.objects_in_view:
            frame = self.rig.render(i / self.fps, np.random.default_rng([self.rig.seed, 2, i]),
                                    False)
        else:
            frame = self.rig.frame(i)
        return Frame(frame.depth, frame.t, colour=frame.colour)

    def background(self) -> np.ndarray:
        """The scene without its objects as (H, W) float32 metres."""
        return self.rig.background().depth

    def truth(self) -> dict:
        """The truth.json object of the rig (sim.export.truth_json): a recording of this source
        can be compared with it (`mirrorscan truth`)."""
        return truth_json(self.rig, sensor_name(self.rig.sensor))


def open_simulated(target: str, session: Session | None) -> SimulatedSource:
    """Open a simulated rig.

    Parameters
    ----------
    target : str
        '' (spec 'sim'): the session's simulated scene when it has a truth.json, else the paper's
        rig with a walking figure at 3 m; a scene file (spec 'sim:SCENE.json').
    session : Session or None

    Returns
    -------
    SimulatedSource

    Raises
    ------
    FileFormatError
        A bad scene file.
    """
    if target:
        return SimulatedSource(Simulator(load_scene(target)), f"simulated {Path(target).name}")
    return SimulatedSource(Simulator(session_scene(session)
                                     or paper_scene(object="figure", distance=3.0)))


def session_scene(session: Session | None) -> Scene | None:
    """Return the simulated scene a session was made from (its truth.json), or None.

    Parameters
    ----------
    session : Session or None

    Returns
    -------
    Scene or None
    """
    truth = session_truth(session)
    return None if truth is None else truth[0]


def session_truth(session: Session | None) -> tuple[Scene, float] | None:
    """Return the simulated scene a session was made from and its frame rate, from its truth.json.

    Parameters
    ----------
    session : Session or None

    Returns
    -------
    (Scene, float) or None
        The scene and its frames per second (frame i shows the scene at i / fps); None without
        truth.json.
    """
    if session is None or not (Path(session.root) / TRUTH_FILE).is_file():
        return None
    path = Path(session.root) / TRUTH_FILE
    data = read_json(path, "truth file")
    if not isinstance(data, dict) or "scene" not in data:
        raise FileFormatError(f"{path}: missing key 'scene'")
    fps = finite_number(data.get("fps", FPS))
    if fps is None or fps <= 0:
        raise FileFormatError(f"{path}: fps must be a positive number, got {data.get('fps')!r}")
    return scene_from_json(data["scene"], f"{path}: scene"), fps
