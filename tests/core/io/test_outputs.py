"""No command writes over a file that belongs to a session, or over its own input: `reconstruct
-o SESSION/session.json` is refused, the session and its calibration stay whole."""
from __future__ import annotations

import json
import os
import shutil
import time

import pytest

from mirrorscan.cli import main
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.outputs import check_output
from mirrorcore.io.sessionfile import load_session


@pytest.fixture
def session(tmp_path):
    root = tmp_path / "scan"
    shutil.copytree("sessions/demo", root)
    return root


def snapshot(folder):
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def refused(capsys, folder, argv, message="would write over"):
    before = snapshot(folder)
    capsys.readouterr()
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err, err
    assert snapshot(folder) == before


@pytest.mark.parametrize("target",
                         ["session.json", "session.json.bak", "background.png", "truth.json",
                                    "frames/000000.png", "frames/new.png",
                                    "exports/../session.json", "."])
def test_reconstruct_never_writes_over_a_session_file(session, capsys, target):
    (session / "session.json.bak").write_bytes((session / "session.json").read_bytes())
    (session / "exports").mkdir()
    refused(capsys, session, ["reconstruct", session, "-o", session / target],
            "is a session folder" if target == "." else "would write over")


def test_the_calibration_survives_a_wrong_output_and_the_next_calibrate(session, capsys):
    """The issue's sequence: reconstruct -o SESSION/session.json, then calibrate: the planes are
    still there."""
    planes = [m.plane for m in load_session(session).mirrors]
    refused(capsys, session, ["reconstruct", session, "-o", session / "session.json"])
    assert main(["calibrate", str(session)]) == 0
    backup = json.loads((session / "session.json.bak").read_text())
    assert [m["plane"] for m in backup["mirrors"]] == [p.to_list() for p in planes]


def test_a_symbolic_link_to_a_session_file_is_refused(session, tmp_path, capsys):
    link = tmp_path / "cloud.ply"
    link.symlink_to(session / "frames" / "000001.png")
    refused(capsys, session, ["reconstruct", session, "-o", link])


def test_dense_and_every_frame_outputs_are_guarded_too(session, capsys):
    refused(capsys, session,
            ["reconstruct", session, "-o", session / "background.png", "--method", "carve",
                              "--voxel", "0.01"])
    refused(capsys, session, ["reconstruct", session, "-o", session, "--frame", "all"],
            "is a session folder")


def test_outputs_beside_or_inside_exports_are_written(session, tmp_path, capsys):
    (session / "exports").mkdir()
    assert main(["reconstruct", str(session), "-o", str(session / "exports" / "cloud.ply")]) == 0
    assert main(["reconstruct", str(session), "-o", str(tmp_path / "cloud.ply")]) == 0
    assert (session / "exports" / "cloud.ply").read_bytes() == (tmp_path / "cloud.ply").read_bytes()
    load_session(session)


def test_experiment_refuses_before_its_minutes_of_work(session, capsys):
    t0 = time.perf_counter()
    refused(capsys, session,
            ["experiment", "angle", "-o", session / "frames" / "000000", "--quiet"])
    assert time.perf_counter() - t0 < 5


def test_simulate_and_record_never_target_a_session_file(session, capsys):
    refused(capsys, session, ["simulate", session / "frames" / "000002.png", "--quiet"])
    refused(capsys, session, ["record", "sim", session / "frames", "--frames", "1", "--quiet"])


def test_a_damaged_session_still_protects_its_files(session, tmp_path):
    (session / "session.json").write_text("{ not json")
    for rel in ("session.json", "background.png", "frames/000000.png", "truth.json"):
        with pytest.raises(MirrorscanError, match=f"would write over {rel} of the session"):
            check_output(session / rel)
    assert check_output(session / "exports" / "a.ply") == session / "exports" / "a.ply"
    scene = tmp_path / "scene.json"
    scene.write_text("{}")
    with pytest.raises(MirrorscanError, match="is this command's own input"):
        check_output(tmp_path / "x" / ".." / "scene.json", (scene,))


def test_a_frame_listed_outside_frames_is_protected(session):
    data = json.loads((session / "session.json").read_text())
    os.rename(session / "frames" / "000002.png", session / "extra.png")
    data["frames"][2] = "extra.png"
    (session / "session.json").write_text(json.dumps(data))
    with pytest.raises(MirrorscanError, match="extra.png of the session"):
        check_output(session / "extra.png")


def test_one_frame_is_not_written_over_a_batch_record(session, tmp_path, capsys):
    """A frame's PLY is not written over a batch folder's manifest.json or lock, which the next
    run of the batch needs."""
    out = tmp_path / "frames"
    assert main(["reconstruct", str(session), "-o", str(out), "--frame", "all", "--workers",
                 "1"]) == 0
    for name in ("manifest.json", ".mirrorscan-batch.lock"):
        if (out / name).exists():
            refused(capsys, out, ["reconstruct", session, "-o", out / name, "--frame", 0],
                    f"would write over the record of the batch in {out}")
    assert (out / "manifest.json").exists()
    assert main(["reconstruct", str(session), "-o", str(out), "--frame", "all", "--workers",
                 "1"]) == 0
