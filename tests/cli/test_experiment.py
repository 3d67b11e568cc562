"""`mirrorscan experiment angle|distance|kaleidoscope` run in-process with one seed: one CSV row per
parameter value, errors positive and a few millimetres, radii near the truth, a readable PNG; bad
input exits 2 with one line and writes nothing."""

import contextlib
import csv
import io

import cv2
import numpy as np
import pytest

from mirrorscan.cli import main
from mirrorscan.experiments import kaleidoscope as experiment_kaleidoscope
from mirrorscan.experiments.paper import ANGLES, COLUMNS, MIRROR_DISTANCES
from mirrorcore.sim.presets import CYLINDER_RADIUS, SPHERE_RADIUS

EXPERIMENTS = {"angle": (ANGLES, SPHERE_RADIUS), "distance": (MIRROR_DISTANCES, CYLINDER_RADIUS)}


@pytest.fixture(scope="module", params=sorted(EXPERIMENTS))
def experiment(request, tmp_path_factory):
    """(name, output prefix, CSV header, CSV rows as dicts of floats, stdout) of one run with one
    seed."""
    name = request.param
    prefix = tmp_path_factory.mktemp(name) / f"exp-{name}"
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["experiment", name, "-o", str(prefix), "--seeds", "1", "--quiet"]) == 0
    with open(prefix.with_suffix(".csv"), newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        header, rows = reader.fieldnames, [{k: float(v) for k, v in row.items()} for row in reader]
    return name, prefix, header, rows, out.getvalue()


def test_csv_has_one_row_per_parameter_and_seed(experiment):
    name, prefix, header, rows, out = experiment
    assert header == list(COLUMNS)
    assert [r["parameter"] for r in rows] == pytest.approx([float(p) for p in EXPERIMENTS[name][0]])
    assert all(r["seed"] == 0 for r in rows)
    assert str(prefix.with_suffix(".csv")) in out and str(prefix.with_suffix(".png")) in out


def test_errors_are_positive_and_millimetres_and_radii_near_the_truth(experiment):
    name, _, _, rows, _ = experiment
    true_radius_mm = 1e3 * EXPERIMENTS[name][1]
    for r in rows:
        # Kinect v1 at 2 m: depth noise std about 5.7 mm per point; the fits see 1.5 to 3 mm
        for key in ("rmse_mm", "mean_abs_error_mm", "true_rmse_mm"):
            assert 0.5 < r[key] < 5.0, (r["parameter"], key, r[key])
        assert abs(r["mean_error_mm"]) < 1e-3  # signed mean about a least-squares fit
        assert r["radius_mm"] == pytest.approx(true_radius_mm, abs=2.0)
        assert r["radius_error_mm"] == pytest.approx(r["radius_mm"] - true_radius_mm, abs=1e-9)
        assert 1000 < r["points"] and 0.2 * r["points"] < r["mirror_points"] < 0.8 * r["points"]
        # markers 3 mm in front of the silver: worse from them alone, as good as exact markers once
        # refined (the sphere from its centres at every angle; from the surfaces it is refused at
        # 140 and 160 degrees, where the sphere hides what the mirrors and the camera both see)
        assert r["glass_true_rmse_mm"] > r["true_rmse_mm"] + 0.5
        assert r["glass_refined_true_rmse_mm"] < 1.1 * r["true_rmse_mm"]


def test_png_is_a_plot(experiment):
    _, prefix, _, _, _ = experiment
    image = cv2.imread(str(prefix.with_suffix(".png")))
    assert image is not None and image.shape == (480, 720, 3)  # 6 x 4 inches at 120 dpi
    assert image.std() > 10  # not a blank canvas


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--seeds", "0"], "--seeds: expected a whole number >= 1, got 0"),
        (["-o", "{tmp}/missing/exp"], "missing: no such folder"),
    ],
)
def test_bad_input_exits_2_with_one_line_and_writes_nothing(
    tmp_path, monkeypatch, capsys, argv, message
):
    monkeypatch.chdir(tmp_path)  # where the default prefix would write
    argv = [a.format(tmp=tmp_path) for a in argv]
    assert main(["experiment", "angle", "--quiet", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err
    assert list(tmp_path.iterdir()) == []


@pytest.fixture(scope="module")
def kaleidoscope(tmp_path_factory):
    """(CSV rows as dicts of floats, PNG path) of `experiment kaleidoscope` with one seed."""
    prefix = tmp_path_factory.mktemp("kaleidoscope") / "exp"
    with contextlib.redirect_stdout(io.StringIO()):
        assert (
            main(["experiment", "kaleidoscope", "-o", str(prefix), "--seeds", "1", "--quiet"]) == 0
        )
    with open(prefix.with_suffix(".csv"), newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        assert reader.fieldnames == list(experiment_kaleidoscope.COLUMNS)
        rows = [{k: float(v) for k, v in row.items()} for row in reader]
    return rows, prefix.with_suffix(".png")


def test_kaleidoscope_experiment_rows(kaleidoscope):
    """One row per angle from 45 degrees; below 120 the views through several mirrors add points and
    their errors are reported; at 120 there are none and following 3 mirrors changes nothing."""
    rows, png = kaleidoscope
    assert [r["parameter"] for r in rows] == [float(a) for a in experiment_kaleidoscope.ANGLES]
    assert min(experiment_kaleidoscope.ANGLES) == 45
    for r in rows:
        assert r["radius_mm"] == pytest.approx(1e3 * SPHERE_RADIUS, abs=1.5)
        assert r["far_share"] < 0.005 and 0.5 < r["direct_rmse_mm"] and r["first_rmse_mm"] < 5.0
        if r["parameter"] < 120:
            assert r["multi_share"] > 0.1 and r["growth"] > 1.1
            assert 0.5 < (r["second_rmse_mm"] if r["parameter"] != 45 else r["third_rmse_mm"]) < 6.0
        else:
            assert r["multi_share"] == 0 and r["growth"] == 1.0 and np.isnan(r["second_rmse_mm"])
    image = cv2.imread(str(png))
    assert image is not None and image.shape == (480, 1200, 3) and image.std() > 10
