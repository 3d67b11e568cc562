"""`mirrorscan fit` on PLY files (ours and Open3D's), its errors, and the sphere fit of a real TUM
RGB-D globe."""

from __future__ import annotations

import json

import numpy as np
import open3d as o3d
import pytest
from tests.helpers import GLOBE_DEPTH, globe_points

from mirrorscan.cli import main
from tests.cli.output import details, headlines
from mirrorcore.geometry.fitting import fit_sphere
from mirrorcore.io.ply import write_ply


def _sphere_cloud(n: int = 3000, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A 115 mm sphere at 2 m (the paper's ball) with 2 mm noise, labelled 0 on the camera's side, 1
    and 2 behind."""
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(n, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    points = np.array([0.1, -0.1, 2.0]) + 0.115 * directions + rng.normal(scale=0.002, size=(n, 3))
    sources = np.where(directions[:, 2] < 0, 0, np.where(directions[:, 0] < 0, 1, 2)).astype(
        np.uint8
    )
    return points, sources


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    status = main(["fit", *argv])
    out, err = capsys.readouterr()
    return status, out, err


def test_fit_sphere_json_with_sources(tmp_path, capsys):
    points, sources = _sphere_cloud()
    write_ply(tmp_path / "ball.ply", points, sources)
    status, out, err = _run(
        capsys, "sphere", str(tmp_path / "ball.ply"), "--json", "--threshold", "8"
    )
    assert status == 0 and err == ""
    result = json.loads(out)  # exactly one JSON object: json.loads refuses anything after it
    assert result["shape"] == "sphere" and result["file"] == str(tmp_path / "ball.ply")
    assert result["radius_mm"] == pytest.approx(115.0, abs=0.5)
    np.testing.assert_allclose(result["center"], [0.1, -0.1, 2.0], atol=5e-4)
    assert result["points"] == 3000 and result["inliers"] > 2950 and result["threshold_mm"] == 8.0
    assert result["rmse_mm"] == pytest.approx(2.0, abs=0.2)  # 2 mm noise along the normal
    assert abs(result["mean_error_mm"]) < 0.2 and result["mean_abs_error_mm"] == pytest.approx(
        1.6, abs=0.2
    )
    assert list(result["per_source"]) == ["direct", "mirror 1", "mirror 2"]
    assert sum(s["points"] for s in result["per_source"].values()) == 3000
    assert result["per_source"]["direct"]["points"] == np.count_nonzero(sources == 0)
    assert set(result["inlier_errors"]) == {
        "points",
        "rmse_mm",
        "mean_error_mm",
        "mean_abs_error_mm",
    }


def test_fit_summary_and_seed(tmp_path, capsys):
    points, sources = _sphere_cloud()
    write_ply(tmp_path / "ball.ply", points, sources)
    status, out, _ = _run(capsys, "sphere", str(tmp_path / "ball.ply"), "--seed", "3")
    result = json.loads(
        _run(capsys, "sphere", str(tmp_path / "ball.ply"), "--seed", "3", "--json")[1]
    )
    assert status == 0
    assert (
        headlines(out)
        == [
            f"{tmp_path / 'ball.ply'}: sphere of radius {result['radius_mm']:.2f} mm, RMSE "
            f"{result['rmse_mm']:.2f} mm over its 3000 points."
        ]
        and details(out) == []
    )
    status, out, _ = _run(capsys, "sphere", str(tmp_path / "ball.ply"), "--seed", "3", "--verbose")
    lines = details(out)
    assert (
        status == 0
        and lines[0].startswith("centre (0.1")
        and lines[1].endswith(" points within 20 mm")
    )
    assert [line.split()[0] for line in lines[2:]] == [
        "all",
        "inliers",
        "direct",
        "mirror",
        "mirror",
    ]
    for line, figures in zip(
        lines[2:], [result, result["inlier_errors"], *result["per_source"].values()]
    ):
        assert line.split()[-13:] == [
            str(figures["points"]),
            "points",
            "RMSE",
            f"{figures['rmse_mm']:.2f}",
            "mm",
            "mean",
            "error",
            f"{figures['mean_error_mm']:+.2f}",
            "mm",
            "mean",
            "|error|",
            f"{figures['mean_abs_error_mm']:.2f}",
            "mm",
        ]
    assert _run(capsys, "sphere", str(tmp_path / "ball.ply"), "--seed", "3", "-v")[1] == out


def test_fit_cylinder_from_an_open3d_ply_without_sources(tmp_path, capsys):
    rng = np.random.default_rng(1)
    theta, height = rng.uniform(0.3 * np.pi, 0.7 * np.pi, 3000), rng.uniform(-0.3, 0.3, 3000)
    # axis along y through (0, 0, 2.2), radius 150 mm (the paper's cylinder), the camera's side only
    points = np.column_stack([0.15 * np.cos(theta), height, 2.2 - 0.15 * np.sin(theta)])
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    o3d.io.write_point_cloud(str(tmp_path / "can.ply"), cloud)
    status, out, _ = _run(capsys, "cylinder", str(tmp_path / "can.ply"), "--json")
    result = json.loads(out)
    assert status == 0 and result["shape"] == "cylinder"
    assert result["radius_mm"] == pytest.approx(150.0, abs=0.01)
    np.testing.assert_allclose(result["axis_direction"], [0.0, 1.0, 0.0], atol=1e-5)
    assert result["axis_point"][0] == pytest.approx(0.0, abs=1e-5) and result["axis_point"][
        2
    ] == pytest.approx(2.2)
    assert result["rmse_mm"] < 0.01 and result["per_source"] == {}


@pytest.mark.parametrize(
    "points, message",
    [
        (None, "no such file"),
        ("hello, not a mesh", "not a PLY file"),
        (np.empty((0, 3)), "the PLY has no points"),
        (np.eye(3) + [0.0, 0.0, 1.0], "a sphere fit needs at least 4 points, got 3"),
    ],
)
def test_bad_input_is_one_line_naming_the_file(tmp_path, capsys, points, message):
    path = tmp_path / "scan.ply"
    if isinstance(points, str):
        path.write_text(points)
    elif points is not None:
        write_ply(path, points, np.zeros(len(points), np.uint8))
    status, out, err = _run(capsys, "sphere", str(path))
    assert status == 2 and out == ""
    assert (
        err.count("\n") == 1
        and err.startswith(f"mirrorscan fit: error: {path}: ")
        and message in err
    )


def test_no_model_found(tmp_path, capsys):
    rng = np.random.default_rng(0)
    plane = np.column_stack([rng.uniform(-0.5, 0.5, size=(1000, 2)), np.full(1000, 2.0)])
    write_ply(tmp_path / "wall.ply", plane, np.zeros(1000, np.uint8))
    status, _, err = _run(capsys, "sphere", str(tmp_path / "wall.ply"), "--max-radius", "500")
    assert status == 2 and f"{tmp_path / 'wall.ply'}: no sphere found" in err


# ------------------------------------------------------------------------------------- real data
@pytest.mark.skipif(not GLOBE_DEPTH.is_file(), reason="real data not available")
def test_real_globe_sphere_fit_and_cli(tmp_path, capsys):
    points = globe_points()
    assert 5000 < len(points) < 8000
    fit = fit_sphere(points, np.random.default_rng(0))
    # `mirrorscan fit sphere` gives radius 220.6 mm, centre (-0.925, -0.784, 2.314) m, RMSE 8.1 mm
    # (all points), 7.8 mm (98.8 % inliers)
    assert 0.21 < fit.shape.radius < 0.23
    # the nearest point is on the front of the globe
    assert 2.25 < fit.shape.centre[2] < 2.4 and fit.shape.centre[
        2
    ] - fit.shape.radius == pytest.approx(points[:, 2].min(), abs=0.03)
    assert 0.004 < fit.errors.rmse < 0.012  # Kinect-class noise at 2.1-2.3 m
    assert fit.inliers.mean() > 0.95 and abs(fit.errors.mean_error) < 0.002

    write_ply(tmp_path / "globe.ply", points, np.zeros(len(points), np.uint8))
    status, out, err = _run(capsys, "sphere", str(tmp_path / "globe.ply"), "--json", "--seed", "0")
    assert status == 0 and err == ""
    result = json.loads(out)
    assert {
        "radius_mm",
        "center",
        "rmse_mm",
        "mean_error_mm",
        "mean_abs_error_mm",
        "inliers",
        "points",
        "per_source",
    } <= set(result)
    # same points, same seed
    assert result["radius_mm"] == pytest.approx(1e3 * fit.shape.radius, rel=1e-9)
    assert result["rmse_mm"] == pytest.approx(1e3 * fit.errors.rmse, rel=1e-9)
    assert 210 < result["radius_mm"] < 230 and result["points"] == len(points)
    assert result["per_source"]["direct"]["rmse_mm"] == pytest.approx(result["rmse_mm"])
