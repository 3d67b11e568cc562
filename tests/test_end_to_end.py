"""The whole command-line pipeline on the simulated two-mirror rig of the paper (sphere r = 115 mm
at 2 m, mirrors at 120 degrees, planes unknown): simulate -> calibrate (markers only) -> reconstruct
-> fit, against the truth."""

import json
import shutil

import numpy as np
import pytest

from mirrorscan.cli import main
from tests.cli.output import details, headlines
from mirrorcore.io.ply import read_ply
from mirrorcore.io.sessionfile import load_session

TRUE_RADIUS = 0.115


def run_ok(*argv) -> None:
    assert main([str(a) for a in argv]) == 0


@pytest.fixture(scope="module", params=["none", "kinect"])
def scanned(request, tmp_path_factory):
    """(noise, session folder, truth, points, sources, fit JSON) after the whole pipeline."""
    root = tmp_path_factory.mktemp(f"e2e-{request.param}")
    session = root / "session"
    run_ok("simulate", session, "--noise", request.param, "--frames", 2, "--seed", 3, "--quiet")
    run_ok("calibrate", session)
    run_ok("reconstruct", session, "-o", root / "cloud.ply", "--frame", 1)
    truth = json.loads((session / "truth.json").read_text())
    points, sources = read_ply(root / "cloud.ply")
    return request.param, session, truth, points, sources, root / "cloud.ply"


def test_calibrated_planes_match_the_truth(scanned):
    noise, session, truth, *_ = scanned
    # noiseless frames still carry the 1 mm depth units of the PNG files: +-0.5 mm
    tol_deg, tol_mm = (0.05, 0.5) if noise == "none" else (1.0, 5.0)
    for mirror, true in zip(load_session(session).mirrors, truth["planes"]):
        true = np.asarray(true)
        angle = np.degrees(np.arccos(np.clip(mirror.plane.n @ true[:3], -1, 1)))
        assert angle < tol_deg and abs(mirror.plane.d - true[3]) * 1e3 < tol_mm


def test_every_source_is_present(scanned):
    sources = scanned[4]
    counts = np.bincount(sources, minlength=3)
    assert len(counts) == 3 and (counts > 500).all(), counts


def test_cloud_lies_on_the_true_sphere(scanned):
    noise, _, truth, points, sources, _ = scanned
    centre = np.asarray(truth["object"]["centre"])
    error = np.linalg.norm(points - centre, axis=1) - TRUE_RADIUS
    if noise == "none":
        assert np.sqrt(np.mean(error**2)) < 1e-3  # RMSE to the true sphere below 1 mm
    else:
        assert np.mean(np.abs(error) > 0.02) < 0.01  # fewer than 1 % farther than 2 cm
        for j in range(3):  # no source is biased
            assert abs(np.mean(error[sources == j])) < 3e-3


def test_fitted_radius(scanned, capsys):
    noise, *_, ply = scanned
    capsys.readouterr()
    run_ok("fit", "sphere", ply, "--json")
    fit = json.loads(capsys.readouterr().out)
    tolerance = 0.5 if noise == "none" else 2.0
    assert abs(fit["radius_mm"] - TRUE_RADIUS * 1e3) < tolerance
    assert set(fit["per_source"]) == {"direct", "mirror 1", "mirror 2"}
    assert fit["rmse_mm"] < (1.0 if noise == "none" else 5.0)


def test_all_frames_into_a_folder(scanned, tmp_path, capsys):
    _, session, *_ = scanned
    run_ok("reconstruct", session, "-o", tmp_path / "clouds", "--frame", "all", "--workers", 1)
    files = sorted(p.name for p in (tmp_path / "clouds").iterdir())
    assert files == [".mirrorscan-batch.lock", "000000.ply", "000001.ply", "manifest.json"]
    run_ok("reconstruct", session, "-o", tmp_path / "clouds", "--frame", "all", "--workers", 1)
    assert "nothing to do: the 2 frames are in" in capsys.readouterr().out


def test_every_line_is_a_headline_and_verbose_adds_the_figures(scanned, tmp_path, capsys):
    """Each command of a scan prints headlines of at most 25 words; -v/--verbose adds the figures
    under each, indented, and keeps the headlines (the same commands on two copies)."""
    _, session, *_ = scanned
    out = {}
    for name, flags in (("plain", []), ("verbose", ["--verbose"])):
        s, cloud = tmp_path / name / "s", tmp_path / name / "cloud.ply"
        shutil.copytree(session, s)
        capsys.readouterr()
        for argv in (
            ["calibrate", s],
            ["calibrate", s, "--refine", "--quiet"],
            ["reconstruct", s, "-o", cloud],
            ["fit", "sphere", cloud],
            ["truth", s, "--cloud", cloud],
        ):
            run_ok(*argv, *flags)
            out[name, argv[0], len(argv)] = capsys.readouterr().out.replace(
                str(tmp_path / name), ""
            )
    for (name, *command), text in out.items():
        if name == "plain":
            verbose = out["verbose", *command]
            assert headlines(text) == headlines(verbose) and details(text) == [], command
            assert len(details(verbose)) >= len(headlines(verbose)) - 1, command
