"""`mirrorscan plan`: a plan folder that the simulator runs as it is, and one-line refusals of a
bad subject, an impossible room and a bad mirror size; `--serve` serving the plan until stopped."""

import json
import re
import signal
import subprocess
import sys
import urllib.request

import numpy as np
import pytest

from mirrorscan.cli import main
from mirrorcore.sim.scenefile import load_scene
from tests.cli.output import details, headlines


def _refused(capsys, argv, start):
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith(f"mirrorscan plan: error: {start}"), err
    return err


@pytest.mark.parametrize("spec", ["cube:1", "sphere", "sphere:-1", "cylinder:0.2", "person:x"])
def test_a_bad_subject_is_refused_in_one_line(tmp_path, capsys, spec):
    _refused(capsys, ["plan", "-o", str(tmp_path / "p"), "--subject", spec, "--mirrors", "2"],
             "--subject: ")
    assert not (tmp_path / "p").exists()


def test_a_folder_in_use_is_refused_before_the_search(tmp_path, capsys):
    (tmp_path / "p").mkdir()
    (tmp_path / "p" / "x").write_text("")
    _refused(capsys, ["plan", "-o", str(tmp_path / "p"), "--subject", "sphere:0.2",
                      "--mirrors", "2"], f"{tmp_path / 'p'}: already exists")


def test_an_impossible_room_is_refused_in_one_line(tmp_path, capsys):
    err = _refused(capsys, ["plan", "-o", str(tmp_path / "p"), "--subject", "person:1.75",
                            "--mirrors", "2", "--room", "1.0,1.2"], "--room: ")
    assert "cannot hold the subject" in err
    _refused(capsys, ["plan", "-o", str(tmp_path / "p"), "--subject", "sphere:0.2",
                      "--mirrors", "2", "--room", "3,x"], "--room: ")
    _refused(capsys, ["plan", "-o", str(tmp_path / "p"), "--subject", "sphere:0.2",
                      "--mirrors", "2", "--room", "3,3,2", "--camera-height", "2.5"],
             "--camera-height: ")
    _refused(capsys, ["plan", "-o", str(tmp_path / "p"), "--subject", "sphere:0.2",
                      "--mirrors", "2", "--mirror-size", "0.8"], "--mirror-size: ")


def test_plan_folder_holds_plan_scene_drawing_and_report(tmp_path, capsys):
    out = tmp_path / "plan"
    argv = ["plan", "-o", str(out), "--subject", "cylinder:0.15,0.6", "--mirrors", "2",
            "--mirror-size", "0.6,1.0", "--distance", "2.0", "--quiet", "-v"]
    assert main(argv) == 0
    said = capsys.readouterr().out
    assert headlines(said)[0].startswith(f"wrote the plan {out}: it sees ")
    assert any(line.startswith("best symmetric V: ") for line in details(said))
    plan = json.loads((out / "plan.json").read_text())
    assert set(plan["camera"]) >= {"width", "height", "fx", "fy", "cx", "cy", "min_depth",
                                   "max_depth"}
    assert len(plan["mirrors"]) == 2
    assert all(np.shape(m["corners"]) == (4, 3) for m in plan["mirrors"])
    assert plan["subject"]["kind"] == "cylinder" and plan["subject"]["radius"] == 0.15
    predicted = plan["predicted"]
    assert set(predicted["per_view"]) == {"direct", "mirror 1", "mirror 2"}
    assert 0 < predicted["coverage_2"] <= predicted["coverage"] <= 1
    assert predicted["coverage"] >= plan["hand_made"]["predicted"]["coverage"] - 1e-9
    scene = load_scene(out / "scene.json")
    for mirror, written in zip(scene.mirrors, plan["mirrors"]):
        assert np.allclose(mirror.corners(), written["corners"], atol=2e-4)
    # the room, the camera's height and the subject's place in the camera's frame
    R = np.array(plan["level_from_camera"])
    level = np.array([m["corners"] for m in plan["mirrors"]]).reshape(-1, 3) @ R.T
    assert np.all(np.abs(level[:, 0]) <= 1.5 + 1e-3) and np.all(level[:, 2] <= 3.6 + 1e-3)
    assert np.all(level[:, 1] <= 1.0 + 1e-3)
    assert main(["simulate", str(tmp_path / "session"), "--scene", str(out / "scene.json"),
                 "--quiet"]) == 0
    assert (tmp_path / "session" / "session.json").is_file()
    # the drawing and the report a person builds it from
    assert said.splitlines()[0].endswith("build it from drawing.png.")
    svg = (out / "drawing.svg").read_text()
    corners = np.array(plan["mirrors"][0]["corners"])
    sides = [round(1e3 * np.linalg.norm(corners[k + 1] - corners[k])) for k in (0, 1)]
    size = re.search(r'data-key="mirror 1 size">(\d+) x (\d+)<', svg)
    assert size and sorted(int(v) for v in size.groups()) == sorted(sides), (size, sides)
    assert (out / "drawing.png").stat().st_size > 10_000
    assert "mirror 1" in (out / "report.txt").read_text()


def test_serve_shows_the_plan_until_stopped(tmp_path):
    """`--serve` writes the plan folder, serves the page, and stops on SIGTERM with status 130."""
    command = [sys.executable, "-m", "mirrorscan.cli", "plan", "-o", str(tmp_path / "p"),
               "--subject", "sphere:0.2", "--mirrors", "2", "--distance", "1.5", "--quiet",
               "--serve", "--port", "0"]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True)
    try:
        served = ""
        while "the plan is at" not in served:
            served = process.stderr.readline()
            assert served or process.poll() is None, "mirrorscan plan --serve ended"
        url = re.search(r"http://\S+", served).group(0)
        with urllib.request.urlopen(url, timeout=30) as page:
            assert page.status == 200
        assert (tmp_path / "p" / "drawing.png").is_file()
    finally:
        process.send_signal(signal.SIGTERM)
        assert process.wait(timeout=60) == 130
