"""The built-in demo: the paper's two-mirror rig with a person walking in place, simulated, its
mirrors calibrated from their markers exactly as a user's would be."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from mirrorcore.calibration.fit import calibrate_session
from mirrorcore.io.session import Session
from mirrorcore.sim.export import session_mirrors
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import SimulatedSource

CALIBRATION_FRAMES = 5


def demo_source() -> SimulatedSource:
    """The simulated rig: a person walking, two mirrors at 120°."""
    return SimulatedSource(Simulator(paper_scene(object="figure", distance=3.0), seed=0),
                           "simulated rig (person walking, two mirrors at 120°)")


def calibrated_session(source: SimulatedSource, root: Path) -> Session:
    """A session for a simulated source, with its planes calibrated.

    Markers and boundaries where the simulator draws them, planes calibrated from the markers over
    the median of the background and a few frames (RANSAC + SVD, as for a real rig).

    Parameters
    ----------
    source : SimulatedSource
    root : Path
        The session's folder.

    Returns
    -------
    Session
    """
    rig = source.rig
    background = rig.background()
    depth = np.stack([background.depth] + [rig.frame(i).depth for i in range(CALIBRATION_FRAMES)])
    session = Session(root, rig.intrinsics, session_mirrors(rig, background.truth))
    return calibrate_session(session, depth, np.random.default_rng(0))[0]
