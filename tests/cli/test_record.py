"""Recording sources into session folders: record then replay gives the same frames bit for bit;
Ctrl-C and cancel keep a valid session, and so does an error after the first frame; the `record` and
`sources` commands."""

import numpy as np
import pytest

from mirrorscan.cli import main
from mirrorcore.depth.files import encode_depth_png
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.sessionfile import load_session
from mirrorcore.sim.export import write_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import (KINDS, Frame, Recorder, SessionSource, SimulatedSource,
                                open_source, record)


@pytest.fixture(scope="module")
def rig():
    return Simulator(paper_scene(object="sphere", distance=2.0), seed=1)


def test_recording_a_simulated_session_replays_bit_for_bit(rig, tmp_path):
    write_session(rig, tmp_path / "sim", 3, progress=False)
    original = open_source(str(tmp_path / "sim"))
    copy = record(original, tmp_path / "copy")
    replay = SessionSource(load_session(tmp_path / "copy"))
    assert replay.frame_count == 3 and copy.camera == original.intrinsics
    for i in range(3):
        a, b = original.read(i), replay.read(i)
        np.testing.assert_array_equal(a.depth, b.depth)
        assert a.timestamp == b.timestamp
        assert (tmp_path / "sim" / original.session.frames[i]).read_bytes() == (
            tmp_path / "copy" / copy.frames[i]
        ).read_bytes()
    np.testing.assert_array_equal(replay.background(), original.background())


def test_record_command_on_the_live_simulator(rig, tmp_path, capsys):
    assert main(["record", "sim", str(tmp_path / "live"), "--frames", "3", "--quiet"]) == 0
    assert "recorded 3 frames" in capsys.readouterr().out
    session = load_session(tmp_path / "live")
    assert session.timestamps == pytest.approx([0, 1 / 30, 2 / 30]) and session.background
    live = SimulatedSource(Simulator(paper_scene(object="figure", distance=3.0)))
    for i, frame in enumerate(SessionSource(session)):  # 1 mm units on disk
        assert encode_depth_png(frame.depth, 0.001) == encode_depth_png(live.read(i).depth, 0.001)
    assert main(["record", "sim", str(tmp_path / "live"), "--frames", "1"]) == 2
    assert "live: is a session folder" in capsys.readouterr().err
    assert main(["record", "sim", str(tmp_path / "x"), "--seconds", "0"]) == 2
    assert not (tmp_path / "x").exists()


class _Interrupted(SimulatedSource):
    """The simulator, with Ctrl-C pressed (with `error`: an error raised) as frame `at` is read."""

    def __init__(self, rig, at: int, error: bool = False):
        super().__init__(rig)
        self.at, self.error = at, error

    def read(self, i: int) -> Frame:
        if i == self.at:
            raise MirrorscanError("camera unplugged") if self.error else KeyboardInterrupt
        return super().read(i)


def test_ctrl_c_and_errors_keep_a_valid_session_of_what_was_recorded(rig, tmp_path):
    with pytest.raises(KeyboardInterrupt):
        record(_Interrupted(rig, 2), tmp_path / "kept", seconds=10)
    assert len(load_session(tmp_path / "kept").frames) == 2
    with pytest.raises(MirrorscanError, match="camera unplugged"):  # after 2 frames: they are kept
        record(_Interrupted(rig, 2, error=True), tmp_path / "unplugged")
    assert len(load_session(tmp_path / "unplugged").frames) == 2
    # before any frame: nothing is left
    with pytest.raises(MirrorscanError, match="camera unplugged"):
        record(_Interrupted(rig, 0, error=True), tmp_path / "gone")
    assert not (tmp_path / "gone").exists()


def test_seconds_limit_and_the_threaded_recorder(rig, tmp_path):
    session = record(SimulatedSource(rig), tmp_path / "s", seconds=0.1)  # frames at 0, 1/30, 2/30
    assert len(session.frames) == 3
    recorder = Recorder(SimulatedSource(rig), tmp_path / "r").start()
    while recorder.frames < 2 and not recorder.done:
        recorder._thread.join(0.05)
    session = recorder.stop()
    assert (
        recorder.done and len(session.frames) >= 2 and len(load_session(tmp_path / "r").frames) >= 2
    )


def test_sources_command_lists_every_kind(capsys):
    assert main(["sources"]) == 0
    out = capsys.readouterr().out
    for spec in (
        "sim:SCENE.json",
        "dir:FOLDER",
        "tum:FOLDER",
        "npz:FILE",
        "bag:FILE",
        "freenect:INDEX",
        "openni2:FILE.oni|URI",
        "realsense:SERIAL",
    ):
        assert spec in out
    assert "available" in out
    # what each kind does with colour
    for kind in KINDS:
        assert kind.colour in out
