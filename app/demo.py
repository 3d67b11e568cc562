"""The built-in demo: the paper's two-mirror rig with a person walking in place, simulated, its
mirrors calibrated from their markers exactly as a user's would be."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from mirrorcore.calibration.colourgain import estimate_gains, with_gains
from mirrorcore.calibration.fit import calibrate_session
from mirrorcore.io.session import Session
from mirrorcore.rig.model import Rig
from mirrorcore.rig.pipeline import object_masks
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
    the median of the background and a few frames (RANSAC + SVD, as for a real rig), and each
    mirror's colour gain measured on those frames (as `mirrorscan calibrate` does).

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
    frames = [rig.frame(i) for i in range(CALIBRATION_FRAMES)]
    depths = np.stack([f.depth for f in frames])
    session = Session(root, rig.intrinsics, session_mirrors(rig, background.truth))
    session = calibrate_session(session, np.concatenate([background.depth[None], depths]),
                                np.random.default_rng(0))[0]
    fitted = Rig.from_session(session)
    masks = object_masks(fitted, depths, background.depth, session.selection)
    colours = np.stack([f.colour for f in frames])
    return with_gains(session, estimate_gains(fitted, depths, masks, colours))
