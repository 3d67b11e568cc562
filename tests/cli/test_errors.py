"""Bad input on the command line: exit status 2, one line naming the file and the problem, nothing
on disk changed."""

import json
import shutil

import cv2
import numpy as np
import pytest

from mirrorscan.cli import main


@pytest.fixture(scope="module")
def pristine(tmp_path_factory):
    root = tmp_path_factory.mktemp("pristine") / "session"
    assert main(["simulate", str(root), "--noise", "none", "--quiet"]) == 0
    return root


@pytest.fixture
def session(pristine, tmp_path):
    root = tmp_path / "session"
    shutil.copytree(pristine, root)
    return root


def snapshot(folder):
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def edit_json(root, change):
    data = json.loads((root / "session.json").read_text())
    change(data)
    (root / "session.json").write_text(json.dumps(data))


def fails(capsys, folder, argv, message):
    """Run argv, expect exit 2 with `message` on a single stderr line, and `folder` unchanged."""
    before = snapshot(folder)
    capsys.readouterr()
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err
    assert snapshot(folder) == before


def test_collinear_markers(session, capsys):
    edit_json(
        session,
        lambda d: d["mirrors"][0].update(markers=[m for m in d["mirrors"][0]["markers"][:3]]),
    )
    fails(
        capsys, session, ["calibrate", session], "mirror 1: markers 1, 2, 3 are (nearly) collinear"
    )


def test_markers_on_invalid_depth(session, capsys):
    edit_json(session, lambda d: d["mirrors"][1].update(markers=[[2, 2], [5, 470], [630, 5]]))
    for name in ["background.png", "frames/000000.png"]:
        depth = cv2.imread(str(session / name), cv2.IMREAD_UNCHANGED)
        depth[:12, :12] = depth[-12:, :12] = depth[:12, -12:] = 0
        cv2.imwrite(str(session / name), depth)
    fails(
        capsys,
        session,
        ["calibrate", session],
        "mirror 2: 0 usable marker(s) of 3, 3 are needed; marker(s) 1, 2, 3 have no depth reading "
        "within 2 px",
    )


def test_corrupt_frame(session, capsys):
    (session / "frames/000000.png").write_bytes(b"\x89PNG\r\n\x1a\nbroken")
    fails(capsys, session, ["calibrate", session], "frames/000000.png: not a readable image")


def test_wrong_size_frame(session, capsys):
    cv2.imwrite(str(session / "frames/000000.png"), np.zeros((240, 320), np.uint16))
    fails(
        capsys, session, ["calibrate", session], "size 320x240 does not match the camera's 640x480"
    )


def test_missing_key(session, capsys):
    edit_json(session, lambda d: d.pop("mirrors"))
    fails(capsys, session, ["calibrate", session], "session.json: missing key(s) mirrors")


def test_self_crossing_boundary(session, capsys):
    edit_json(
        session, lambda d: d["mirrors"][0].update(boundary=[[0, 0], [100, 100], [100, 0], [0, 100]])
    )
    fails(
        capsys,
        session,
        ["calibrate", session],
        "(mirror 1): boundary: the polygon crosses itself (edges 1 and 3)",
    )


def test_reconstruct_needs_a_calibration(session, tmp_path, capsys):
    fails(
        capsys,
        tmp_path,
        ["reconstruct", session, "-o", tmp_path / "out.ply"],
        "mirror 1 has no plane; run `mirrorscan calibrate",
    )
    assert not (tmp_path / "out.ply").exists()


def test_missing_session_and_bad_frame_index(session, tmp_path, capsys):
    fails(
        capsys, tmp_path, ["calibrate", tmp_path / "nowhere"], "nowhere: no such session folder"
    )
    assert main(["calibrate", str(session)]) == 0
    fails(
        capsys,
        tmp_path,
        ["reconstruct", session, "-o", tmp_path / "o.ply", "--frame", "9"],
        "no frame 9; the session has 1 (0 to 0)",
    )


def test_fit_on_a_missing_file(tmp_path, capsys):
    fails(capsys, tmp_path, ["fit", "sphere", tmp_path / "none.ply"], "none.ply: no such file")


def test_unwritable_output_is_one_line(session, tmp_path, capsys):
    assert main(["calibrate", str(session)]) == 0
    (tmp_path / "a_file").write_text("not a folder")
    fails(
        capsys,
        tmp_path,
        ["reconstruct", session, "-o", tmp_path / "a_file" / "o.ply"],
        "a_file/o.ply: Not a directory",
    )
