"""`mirrorscan calibrate` on a session with colour frames also measures each mirror's colour gain
and writes it (within 2 % of the simulator's tints); a session without colour is calibrated as
before, with no gain."""

import json

import numpy as np
import pytest

from mirrorcore.calibration.colourgain import MIN_PAIRS, TOO_FEW_PAIRS, MirrorGain
from mirrorcore.io.sessionfile import load_session
from mirrorscan.cli import main
from mirrorscan.commands import wording
from mirrorscan.commands.wording.calibration import colour_gain
from tests.cli.output import details, headlines


def run_ok(*argv) -> None:
    assert main([str(a) for a in argv]) == 0, argv


def tints(session) -> list[list[float]]:
    """The simulator's tint of each mirror, session order (truth.json)."""
    truth = json.loads((session / "truth.json").read_text())
    return [m["tint"] for m in truth["scene"]["mirrors"]]


@pytest.mark.parametrize("layout", [(), ("--kaleidoscope", "--angle", 72)],
                         ids=["paper", "kaleidoscope-72"])
def test_calibrate_writes_the_colour_gains_within_2_percent_of_the_tints(tmp_path, capsys,
                                                                          layout):
    session = tmp_path / "s"
    run_ok("simulate", session, *layout, "--frames", 4, "--seed", 2, "--quiet")
    capsys.readouterr()
    run_ok("calibrate", session, "--refine", "--quiet", "-v")
    out = capsys.readouterr().out
    lines = headlines(out)
    for m, tint in zip(load_session(session).mirrors, tints(session)):
        assert m.plane is not None
        np.testing.assert_allclose(m.colour_gain, tint, rtol=0.02)
        assert f"{m.name}: colour gain measured; its points show the scene's own colour." in lines
        shown = [line for line in details(out) if line.startswith("reflects ")]
        assert " / ".join(f"{100 * g:.1f}" for g in m.colour_gain) in " ".join(shown)
    assert any(line.startswith("from ") and "pairs of its points" in line
               for line in details(out))


def test_every_method_measures_the_gains_and_a_session_without_colour_gets_none(tmp_path,
                                                                                capsys):
    session = tmp_path / "s"
    run_ok("simulate", session, "--frames", 3, "--seed", 5, "--quiet")
    plain = tmp_path / "plain"
    run_ok("simulate", plain, "--frames", 3, "--seed", 5, "--quiet")
    data = json.loads((plain / "session.json").read_text())
    del data["colour_frames"]
    (plain / "session.json").write_text(json.dumps(data))
    capsys.readouterr()
    # the markers alone (no --refine): the gains with the markers' planes
    run_ok("calibrate", session, "--quiet")
    coloured = capsys.readouterr().out
    for m, tint in zip(load_session(session).mirrors, tints(session)):
        np.testing.assert_allclose(m.colour_gain, tint, rtol=0.02)
    run_ok("calibrate", plain, "--quiet")
    out = capsys.readouterr().out
    assert "colour" not in out
    # the same planes, the same lines but for the gains
    assert [line for line in coloured.splitlines() if "colour gain" not in line] == [
        line.replace(str(plain), str(session)) for line in out.splitlines()]
    assert all(m.colour_gain is None for m in load_session(plain).mirrors)
    assert "colour_gain" not in (plain / "session.json").read_text()
    # --refine alone again: the planes and gains are where they were, nothing is written
    run_ok("calibrate", session, "--refine", "--quiet")
    before = (session / "session.json").read_text()
    run_ok("calibrate", session, "--refine", "--quiet")
    assert "nothing changed" in capsys.readouterr().out
    assert (session / "session.json").read_text() == before


def test_a_mirror_not_measured_says_why_and_what_it_rests_on(capsys):
    missed = MirrorGain(1, "right", None, 12, 3, 4, (0.01, 0.01, 0.02), TOO_FEW_PAIRS)
    wording.show(colour_gain(missed, 10), True)
    out = capsys.readouterr().out
    assert headlines(out) == [
        "right: colour gain not measured: too little of the object is seen both in it and in "
        "another view; its colours stay as they are."
    ]
    assert details(out) == [
        "from 12 pairs of its points with the other views' over 10 frames (3 with the camera's; "
        "4 left out across the texture's edges)",
        f"at least {MIN_PAIRS} pairs needed",
    ]
