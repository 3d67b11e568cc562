"""Every refusal of the command line is one line naming the option, status 2, nothing written: the
numbers checked where they are parsed (mirrorscan.commands.numbers), never an empty result."""

import json
import shutil

import pytest

from mirrorscan.cli import main


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    root = tmp_path_factory.mktemp("refusals") / "session"
    assert main(["simulate", str(root), "--noise", "none", "--quiet"]) == 0
    assert main(["calibrate", str(root), "--quiet"]) == 0
    return root


def refused(capsys, argv, option, where=None):
    """Run argv: status 2, one stderr line naming `option`, `where` (a path) not written."""
    capsys.readouterr()
    assert main([str(a) for a in argv]) == 2
    # as a terminal shows it: a progress bar cleared by carriage returns leaves nothing
    err = "\n".join(line.rsplit("\r", 1)[-1] for line in capsys.readouterr().err.split("\n"))
    assert err.count("\n") == 1 and err.startswith(f"mirrorscan {argv[0]}: error: "), err
    assert option in err, err
    assert "Traceback" not in err
    if where is not None:
        assert not where.exists()
    return err


@pytest.mark.parametrize("command", ["calibrate", "simulate", "fit"])
def test_a_negative_seed_is_refused(calibrated, tmp_path, capsys, command):
    argv = {"calibrate": ["calibrate", calibrated],
            "simulate": ["simulate", tmp_path / "s", "--quiet"],
            "fit": ["fit", "sphere", tmp_path / "x.ply"]}[command]
    err = refused(capsys, [*argv, "--seed", "-1"], "--seed: expected a whole number >= 0, got -1")
    assert f"(see mirrorscan {command} --help)" in err


@pytest.mark.parametrize("argv, option", [
    (["--temporal", "-1"], "--temporal: expected a whole number >= 0, got -1"),
    (["--voxel", "1e-30", "--method", "carve"], "--voxel: expected a number of metres from"),
    (["--voxel", "1e9", "--method", "tsdf"], "--voxel: expected a number of metres from"),
    (["--voxel", "nan", "--method", "carve"], "--voxel:"),
    (["--margin", "-0.1", "--method", "carve"], "--margin:"),
    (["--threshold", "0", "--method", "carve"], "--threshold: expected a number of metres > 0"),
    (["--truncation", "inf", "--method", "tsdf"], "--truncation:"),
    (["--bounces", "4"], "--bounces: expected a whole number from 1 to 3, got 4"),
    (["--frames", "0", "--method", "tsdf"], "--frames: expected a whole number >= 1, got 0"),
    (["--frames-per-task", "0", "--frame", "all"], "--frames-per-task:"),
])
def test_reconstruct_refuses_numbers_out_of_range(calibrated, tmp_path, capsys, argv, option):
    out = tmp_path / "out.ply"
    refused(capsys, ["reconstruct", calibrated, "-o", out, *argv], option, out)


def test_reconstruct_refuses_an_empty_result(calibrated, tmp_path, capsys):
    out = tmp_path / "out.ply"
    # a box far from the object: nothing to carve in it
    err = refused(capsys, ["reconstruct", calibrated, "-o", out, "--method", "carve",
                           "--bounds", "5", "5", "5", "5.2", "5.2", "5.2", "--voxel", "0.05"],
                  "the carved surface is empty, nothing written", out)
    assert str(out) in err


@pytest.mark.parametrize("mirrors", ["0", "1", "33", "50"])
def test_simulate_refuses_a_mirror_count_the_other_commands_refuse(tmp_path, capsys, mirrors):
    refused(capsys, ["simulate", tmp_path / "s", "--mirrors", mirrors, "--quiet"],
            f"--mirrors: expected a whole number from 2 to 32, got {mirrors}", tmp_path / "s")


@pytest.mark.parametrize("argv, option", [
    (["--distance", "nan"], "--distance:"),
    (["--frames", "0"], "--frames: expected a whole number from 1 to 1,000,000, got 0"),
    (["--marker-offset", "-1"], "--marker-offset: expected a number of mm from 0 to 50, got -1"),
    (["--click-jitter", "99"], "--click-jitter: expected a number of pixels from 0 to 50"),
])
def test_simulate_refuses_numbers_out_of_range(tmp_path, capsys, argv, option):
    refused(capsys, ["simulate", tmp_path / "s", "--quiet", *argv], option, tmp_path / "s")


@pytest.mark.parametrize("argv, option", [
    (["fit", "sphere", "x.ply", "--threshold", "0"], "--threshold: expected a number of mm > 0"),
    (["fit", "cylinder", "x.ply", "--max-radius", "-5"], "--max-radius:"),
    (["experiment", "temporal", "--neighbours", "0"], "--neighbours: expected a whole number >= 1"),
    (["experiment", "angle", "--seeds", "0"], "--seeds: expected a whole number >= 1, got 0"),
    (["reconstruct", "s", "-o", "x.ply", "--frames", "two"], "--frames: expected a whole number"),
    (["serve", "--port", "99999"], "--port: expected a whole number from 0 to 65535, got 99999"),
])
def test_other_numbers_are_refused_where_parsed(tmp_path, capsys, monkeypatch, argv, option):
    monkeypatch.chdir(tmp_path)
    refused(capsys, argv, option)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("index", ['"3"', "null", "0.5"])
def test_a_manifest_frame_index_that_is_not_a_whole_number_is_refused(
        calibrated, tmp_path, capsys, index):
    session = tmp_path / "session"
    shutil.copytree(calibrated, session)
    out = tmp_path / "out"
    argv = ["reconstruct", session, "-o", out, "--frame", "all", "--workers", "1"]
    assert main([str(a) for a in argv]) == 0
    manifest = out / "manifest.json"
    data = json.loads(manifest.read_text())
    data["frames"][0]["index"] = json.loads(index)
    manifest.write_text(json.dumps(data))
    got = data["frames"][0]["index"]
    refused(capsys, argv, f"frames[0].index: expected a whole number >= 0, got {got!r}")
