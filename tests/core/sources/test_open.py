"""Depth sources and the shipped demo session."""
from pathlib import Path

import numpy as np
import pytest

from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.geometry.fitting import fit_sphere
from mirrorcore.rig.pipeline import object_cloud
from mirrorcore.rig.model import Rig
from mirrorcore.io.sessionfile import load_session
from mirrorcore.sources import SessionSource, SimulatedSource, open_source, session_scene

DEMO = Path(__file__).resolve().parents[3] / "sessions" / "demo"


def test_shipped_demo_session_is_calibrated_and_scans_the_sphere():
    session = load_session(DEMO)
    assert len(session.mirrors) == 2 and all(m.plane is not None for m in session.mirrors)
    source = open_source(None, session)
    assert isinstance(source, SessionSource) and source.frame_count == len(session.frames) == 5
    cloud, _ = object_cloud(Rig.from_session(session), source.read(0).depth, source.background(),
                            session.selection)
    assert (np.bincount(cloud.sources, minlength=3) > 1000).all()
    fit = fit_sphere(cloud.points, np.random.default_rng(0))
    assert abs(fit.shape.radius - 0.115) < 0.002


def test_session_replay_loops_and_sim_follows_the_sessions_scene():
    session = load_session(DEMO)
    replay = SessionSource(session)
    np.testing.assert_array_equal(replay.read(6).depth, replay.read(1).depth)
    sim = open_source("sim", session)
    assert isinstance(sim, SimulatedSource) and sim.frame_count is None
    assert sim.rig.scene == session_scene(session)
    assert sim.read(0).depth.shape == (480, 640)


def test_bad_source_specs_are_refused_by_name(tmp_path):
    with pytest.raises(MirrorscanError, match="unknown source 'kinect'"):
        open_source("kinect", None)
    with pytest.raises(MirrorscanError, match="--source session: give a SESSION folder"):
        open_source("session", None)
    with pytest.raises(FileFormatError, match="nope.json: no such scene file"):
        open_source(f"sim:{tmp_path / 'nope.json'}", None)
