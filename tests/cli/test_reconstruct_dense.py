"""`mirrorscan reconstruct --method paper|carve|tsdf` on the shipped demo session (sphere, two
mirrors, Kinect noise): PLY files of the docs/DESIGN.md layout, a cancelled run writes nothing, bad
requests exit 2 with one line."""

import threading
from contextlib import contextmanager

import numpy as np
import pytest
import trimesh

from mirrorscan.cli import main
from mirrorscan.commands import reconstruct as command
from mirrorcore.io.ply import read_ply

DEMO = "sessions/demo"
SPHERE_CENTRE = np.array([0.0, 0.0, 2.0])


@pytest.mark.parametrize("method", ["paper", "carve", "tsdf"])
def test_dense_methods_write_ply(method, tmp_path):
    out = tmp_path / f"{method}.ply"
    assert (
        main(
            [
                "reconstruct",
                DEMO,
                "-o",
                str(out),
                "--method",
                method,
                "--voxel",
                "0.004",
                "--frames",
                "2",
                "--threshold",
                "0.008",
            ]
        )
        == 0
    )
    points, sources = read_ply(out)
    assert len(points) > 1000 and set(np.unique(sources)) == {0, 1, 2}
    loaded = trimesh.load(out, process=False)
    assert isinstance(loaded, trimesh.Trimesh) == (method == "tsdf")  # faces for the mesh only
    # the mesh wraps the sphere (r = 115 mm at 2 m): its vertices' mean is near the centre
    if method == "tsdf":
        assert np.linalg.norm(points.mean(axis=0) - SPHERE_CENTRE) < 0.02


def test_cancelled_run_writes_nothing(tmp_path, monkeypatch, capsys):
    def cancelled_at_once():
        event = threading.Event()
        event.set()
        yield event

    monkeypatch.setattr(command, "ctrl_c_cancels", contextmanager(cancelled_at_once))
    out = tmp_path / "mesh.ply"
    assert main(["reconstruct", DEMO, "-o", str(out), "--method", "tsdf"]) == 130
    assert not out.exists() and list(tmp_path.iterdir()) == []
    assert "cancelled" in capsys.readouterr().err


@pytest.mark.parametrize(
    "argv, message",
    [
        (
            ["--frame", "all", "--method", "tsdf", "--frames", "2"],
            "each frame is reconstructed alone",
        ),
        (["--method", "tsdf", "--frames", "99"], "past the end"),
        (["--method", "tsdf", "--frames", "0"], "--frames: expected a whole number >= 1, got 0"),
        (["--method", "carve", "--voxel", "-1"], "--voxel: expected a number of metres from"),
        (["--method", "carve", "--bounds", "0", "0", "5", "0.1", "0.1", "4"], "upper corner"),
    ],
)
def test_bad_requests_exit_2(argv, message, tmp_path, capsys):
    assert main(["reconstruct", DEMO, "-o", str(tmp_path / "x.ply"), *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []
