"""`mirrorscan truth`: a simulated session's planes and clouds against the simulator's truth, with
signs and frames that mean something (a plane moved away from the camera reads > 0; a walking
figure's cloud is compared at its own frame), and one-line refusals."""

import json
from dataclasses import replace

import numpy as np
import pytest

from mirrorscan.cli import main
from tests.cli.output import details, headlines
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.ply import read_ply
from mirrorcore.io.sessionfile import load_session, save_session
from mirrorcore.sim.presets import object_extent
from mirrorcore.sim.truth import surface_error
from mirrorcore.sources import session_truth


def run(capsys, *argv) -> tuple[int, str, str]:
    capsys.readouterr()
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


@pytest.fixture(scope="module")
def glass(tmp_path_factory):
    """A sphere session, markers 3 mm in front of the silver, calibrated from them alone."""
    folder = tmp_path_factory.mktemp("truth") / "glass"
    assert main(["simulate", str(folder), "--marker-offset", "3", "--frames", "2", "--quiet"]) == 0
    assert main(["calibrate", str(folder), "--quiet"]) == 0
    return folder


def with_planes(folder, planes) -> None:
    session = load_session(folder)
    save_session(
        replace(
            session, mirrors=tuple(replace(m, plane=p) for m, p in zip(session.mirrors, planes))
        )
    )


def test_markers_on_glass_read_as_planes_too_near_and_the_glass_beside_the_truth(glass, capsys):
    status, out, err = run(capsys, "truth", glass, "--json")
    assert status == 0 and err == ""
    planes = json.loads(out)["planes"]
    assert [p["name"] for p in planes] == ["mirror 1", "mirror 2"]
    for plane in planes:  # the fit puts the planes on the markers' faces: 3 mm too near
        assert -4.0 < plane["offset_mm"] < -2.0 and plane["tilt_deg"] < 0.2
        assert plane["glass_mm"] == 0.0 and plane["true_glass_mm"] == pytest.approx(3.0)
    status, out, _ = run(capsys, "truth", glass)
    lines = headlines(out)
    assert len(lines) == 2 and out == "\n".join(lines) + "\n"
    for line, plane in zip(lines, planes):
        assert line == (
            f"{plane['name']}: plane {plane['offset_mm']:+.2f} mm at the object, tilted "
            f"{plane['tilt_deg']:.3f}°; glass 0.0 mm (true 3.0 mm)."
        )
    _, out, _ = run(capsys, "truth", glass, "--verbose")
    assert (
        details(out)
        == ["offset along the normal at the object's middle; > 0: too far from the camera"] * 2
    )


def test_the_true_planes_read_zero_and_a_plane_moved_away_reads_its_move(glass, capsys):
    scene, _ = session_truth(load_session(glass))
    true = [m.plane for m in scene.mirrors]
    at = object_extent(scene.objects[0])[0]
    farther = Plane(true[1].normal, true[1].d + 0.005)  # 5 mm farther from the camera (d > 0 at it)
    assert farther.signed_distance(np.zeros(3)) > true[1].signed_distance(np.zeros(3))
    assert abs(farther.signed_distance(at) - true[1].signed_distance(at)) == pytest.approx(0.005)
    with_planes(glass, true)
    try:
        _, out, _ = run(capsys, "truth", glass, "--json")
        assert [(p["offset_mm"], p["tilt_deg"]) for p in json.loads(out)["planes"]] == [
            (0.0, 0.0),
            (0.0, 0.0),
        ]
        with_planes(glass, [true[0], farther])
        _, out, _ = run(capsys, "truth", glass, "--json")
        second = json.loads(out)["planes"][1]
        assert second["offset_mm"] == pytest.approx(5.0, abs=1e-6) and second["tilt_deg"] < 1e-6
        with_planes(glass, [true[0], None])
        _, out, _ = run(capsys, "truth", glass)
        assert out.splitlines()[1] == "mirror 2: no plane yet; glass 0.0 mm (true 3.0 mm)."
    finally:
        assert main(["calibrate", str(glass), "--quiet"]) == 0


def test_a_cloud_of_the_true_rig_lies_on_the_sphere_and_a_sphere_moved_does_not(
    glass, tmp_path, capsys
):
    scene, _ = session_truth(load_session(glass))
    directions = np.random.default_rng(0).normal(size=(2000, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    sphere = scene.objects[0]
    on, beyond = (
        np.asarray(sphere.centre) + r * directions for r in (sphere.radius, sphere.radius + 0.004)
    )
    assert surface_error(on, scene).rmse_mm < 0.1  # the icosphere's facets: under 0.1 mm
    assert surface_error(beyond, scene).mean_mm == pytest.approx(4.0, abs=0.1)
    cloud = tmp_path / "frame0.ply"
    assert main(["reconstruct", str(glass), "-o", str(cloud), "--frame", "0"]) == 0
    status, out, _ = run(capsys, "truth", glass, "--cloud", cloud, "--json")
    figures = json.loads(out)
    assert status == 0 and figures["points"] == len(read_ply(cloud)[0]) and figures["frame"] == 0
    # the markers' planes 3 mm too near: the mirrors' points off
    assert 2.0 < figures["rmse_mm"] < 6.0
    _, out, _ = run(capsys, "truth", glass, "--cloud", cloud, "-v")
    # the distances, then the colours (tests/cli/test_truth_colour.py)
    assert headlines(out)[-2] == (
        f"{cloud}: RMSE {figures['rmse_mm']:.2f} mm to the true surface over "
        f"{figures['points']:,} points."
    )
    assert (
        details(out)[2]
        == f"mean {figures['mean_mm']:.2f} mm, 95 % within {figures['p95_mm']:.2f} mm"
    )


def test_a_walking_figures_cloud_is_compared_at_its_own_frame(tmp_path, capsys):
    folder = tmp_path / "walk"
    assert (
        main(
            [
                "simulate",
                str(folder),
                "--object",
                "figure",
                "--frames",
                "9",
                "--noise",
                "none",
                "--quiet",
            ]
        )
        == 0
    )
    scene, fps = session_truth(load_session(folder))
    with_planes(folder, [m.plane for m in scene.mirrors])
    cloud = tmp_path / "frame8.ply"
    assert main(["reconstruct", str(folder), "-o", str(cloud), "--frame", "8"]) == 0
    _, own, _ = run(capsys, "truth", folder, "--cloud", cloud, "--frame", 8, "--json")
    _, first, _ = run(capsys, "truth", folder, "--cloud", cloud, "--json")
    assert fps == 30.0
    assert (
        json.loads(own)["rmse_mm"]
        < 2.0
        < 2 * json.loads(own)["rmse_mm"]
        < json.loads(first)["rmse_mm"]
    )


def test_refusals_are_one_line(glass, tmp_path, capsys):
    plain = tmp_path / "plain"
    plain.mkdir()
    (plain / "session.json").write_bytes((glass / "session.json").read_bytes())
    for name in ("background.png", "frames"):
        (plain / name).symlink_to(glass / name)
    status, _, err = run(capsys, "truth", plain)
    assert status == 2 and err == (
        f"mirrorscan truth: error: {plain}: no truth.json: only a session `mirrorscan "
        "simulate` wrote, or one recorded from the simulated source, has a truth to compare with\n"
    )
    (plain / "truth.json").write_bytes((glass / "truth.json").read_bytes())
    session = load_session(plain)
    extra = replace(session.mirrors[0], id=99, name="mirror 3")
    save_session(replace(session, mirrors=session.mirrors + (extra,)))
    status, _, err = run(capsys, "truth", plain)
    assert status == 2 and err == (
        "mirrorscan truth: error: the session has 3 mirrors, its truth 2: a mirror was "
        "added or removed since it was simulated\n"
    )
    for frame in (-1, 2):
        status, _, err = run(capsys, "truth", glass, "--frame", frame, "--cloud", "c.ply")
        assert status == 2
        assert err == (
            f"mirrorscan truth: error: {glass / 'session.json'}: no frame {frame}; the session has "
            "2 "
            "(0 to 1)\n"
        )


def test_a_recording_of_the_simulated_source_has_the_truth_and_its_own_times(tmp_path, capsys):
    """`mirrorscan record sim` (and the browser's recording, through its tap) writes the truth the
    simulator knows; its frames are compared at their own times; planes need no frame, and the
    mirrors may be added in any order."""
    from mirrorcore.sim.export import session_mirrors
    from mirrorcore.sim.simulator import Simulator
    from mirrorcore.sim.truth import frame_time
    from mirrorcore.sources import open_source
    from mirrorscan.recording import LiveTap

    folder = tmp_path / "rec"
    assert main(["record", "sim", str(folder), "--frames", "3", "--quiet"]) == 0
    session = load_session(folder)
    scene, fps = session_truth(session)
    assert [frame_time(session, k, fps) for k in range(3)] == pytest.approx([0, 1 / fps, 2 / fps])
    status, out, _ = run(capsys, "truth", folder)
    assert status == 0 and headlines(out) == [
        f"{folder}: no mirror yet, so no plane to compare: add the mirrors and calibrate them "
        "(mirrorscan serve), then compare again."
    ]
    # the mirrors added the other way round, with their true planes; no frame at all
    sim = Simulator(scene)
    mirrors = session_mirrors(sim, sim.background().truth)[::-1]
    planes = [m.plane for m in scene.mirrors][::-1]
    save_session(
        replace(
            session,
            mirrors=tuple(replace(m, plane=p) for m, p in zip(mirrors, planes)),
            frames=(),
            timestamps=(),
            colour_frames=None,
        )
    )
    status, out, _ = run(capsys, "truth", folder, "--json")
    errors = json.loads(out)["planes"]
    assert status == 0 and [p["name"] for p in errors] == ["mirror 2", "mirror 1"]
    assert all(p["offset_mm"] == pytest.approx(0, abs=1e-9) for p in errors)
    status, _, err = run(capsys, "truth", folder, "--cloud", tmp_path / "none.ply")
    assert status == 2 and "no frame 0; the session has 0" in err
    with open_source("sim") as source:
        tap = LiveTap(source, lambda take: lambda: None)
        try:
            assert tap.truth() == source.truth() and tap.truth()["scene"] == scene.to_json()
        finally:
            tap.close()
