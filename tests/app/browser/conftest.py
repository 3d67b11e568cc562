"""Fixtures of the headless Chromium tests: the browser tool as shared on a network."""
from __future__ import annotations

import pytest
from mirrorscan.security import new_token
from mirrorscan.server import MirrorscanApp

from mirrorcore.io.session import Session, SessionMirror
from mirrorcore.io.sessionfile import save_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import SimulatedSource


@pytest.fixture(scope="module")
def shared(tmp_path_factory):
    """The browser tool as shared on a network, a new token required, on the simulated paper rig
    (sphere, seed 0, 5 fps), editing a new session of two mirrors in a temporary folder; started,
    for one test module. Its page opens at `app.guard.url`."""
    rig = Simulator(paper_scene(object="sphere"), seed=0, fps=5.0)
    root = tmp_path_factory.mktemp("shared") / "scan"
    session = Session(root, rig.intrinsics, (SessionMirror("mirror 1"), SessionMirror("mirror 2")))
    save_session(session)
    app = MirrorscanApp(session, SimulatedSource(rig), port=0, sessions_dir=root.parent,
                        token=new_token())
    app.start()
    yield app
    app.stop()
