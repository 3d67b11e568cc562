"""Benchmark of the simulated rig.

One 640x480 Kinect v1 frame of the walking figure with two mirrors, with noise.
"""

from __future__ import annotations

import itertools

from mirrorscan.bench import median_ms
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator


def run() -> dict[str, float]:
    """The simulator's time to render one frame of the walking figure at 3 m.

    Returns
    -------
    dict of str to float
        {figure name: value}; names ending in _ms are median milliseconds.
    """
    rig = Simulator(paper_scene(object="figure", distance=3.0), seed=0)
    frames = itertools.count()
    return {"sim_frame_ms": median_ms(lambda: rig.frame(next(frames)), repeat=30)}
