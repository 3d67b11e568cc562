"""Benchmark of the refinement of two mirrors' planes.

One 640x480 frame of the simulated rig (Kinect noise), from planes fitted to markers 3 mm in front
of the silver and clicked 2 px off: on the walking figure (the surfaces, `refine_ms`) and on the
paper's sphere (its centres, `refine_sphere_ms`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mirrorscan.bench import median_ms
from mirrorcore.calibration.fit import calibrate_session
from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.calibration.refine import refine_planes
from mirrorcore.rig.model import Rig
from mirrorcore.io.session import Session
from mirrorcore.sim.export import session_mirrors
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator


def run() -> dict[str, float]:
    """The time to refine the planes on one frame: the figure at 3 m, the sphere at 2 m.

    The points the refinement reads are in the figures ending in _points.

    Returns
    -------
    dict of str to float
        {figure name: value}; names ending in _ms are median milliseconds.
    """
    out = {}
    for obj, distance, name in (("figure", 3.0, "refine"), ("sphere", 2.0, "refine_sphere")):
        sim = Simulator(paper_scene(object=obj, distance=distance).with_markers(0.003, 2.0), seed=0)
        frame, background = sim.frame(0), sim.background().depth
        session = Session(Path("."), sim.intrinsics, session_mirrors(sim, frame.truth))
        rig = Rig.from_session(
            calibrate_session(
                session, np.stack([frame.depth, background]), np.random.default_rng(0)
            )[0]
        )
        mask = prepare_frame(rig, frame.depth, background)[1]
        out[f"{name}_ms"] = median_ms(
            lambda: refine_planes(rig, frame.depth[None], mask[None]), repeat=5, warmup=1
        )
        out[f"{name}_points"] = float(mask.sum())
    return out
