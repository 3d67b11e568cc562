"""`mirrorscan serve`'s choice of session and source, without starting a server."""

import pytest

from mirrorscan.commands.serve import session_and_source
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.sessionfile import load_session
from mirrorcore.sources import SessionSource, SimulatedSource


def test_no_session_is_the_calibrated_demo_not_saved():
    session, source, autosave = session_and_source(None, None)
    assert isinstance(source, SimulatedSource) and not autosave
    assert len(session.mirrors) == 2 and all(
        m.plane is not None and m.boundary for m in session.mirrors
    )


def test_a_new_folder_starts_an_empty_session_on_the_simulated_rig(tmp_path):
    session, source, autosave = session_and_source(str(tmp_path / "new"), None)
    assert autosave and session.mirrors == () and isinstance(source, SimulatedSource)
    assert load_session(tmp_path / "new").camera == source.intrinsics


def test_a_session_with_frames_replays_them(tmp_path):
    from mirrorscan.cli import main

    assert main(["simulate", str(tmp_path / "s"), "--frames", "2", "--quiet"]) == 0
    session, source, autosave = session_and_source(str(tmp_path / "s"), None)
    assert isinstance(source, SessionSource) and source.frame_count == 2 and autosave
    _, sim, _ = session_and_source(str(tmp_path / "s"), "sim")
    assert isinstance(sim, SimulatedSource)


def test_a_folder_that_is_not_a_session_is_refused(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(
        MirrorscanError, match="not a session folder \\(no session.json\\) and not empty"
    ):
        session_and_source(str(tmp_path), None)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_bounces_become_the_session_setting(tmp_path):
    from mirrorscan.cli import main

    assert main(["simulate", str(tmp_path / "s"), "--quiet"]) == 0
    assert session_and_source(str(tmp_path / "s"), None)[0].bounces == 3
    assert session_and_source(str(tmp_path / "s"), None, 1)[0].bounces == 1
    with pytest.raises(
        MirrorscanError, match="--bounces: the reflections followed must be 1 to 3, got 5"
    ):
        session_and_source(str(tmp_path / "new"), None, 5)
    assert not (tmp_path / "new").exists()
