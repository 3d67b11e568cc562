"""Scene files (round trip, one-line errors naming file and key), the session mirrors of a simulated
rig and `mirrorscan simulate` writing a session."""

import json
import shutil

import cv2
import numpy as np
import pytest

from mirrorscan.cli import main
from tests.cli.output import details
from mirrorcore.base.errors import FileFormatError
from mirrorcore.geometry.camera import Intrinsics, reproject_pixels
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.sessionfile import load_session
from mirrorcore.sim.export import session_mirrors
from mirrorcore.sim.layouts import (
    HINGE_GAP,
    HINGED_CLEARANCE,
    arc_scene,
    kaleidoscope_scene,
    paper_scene,
)
from mirrorcore.sim.scenefile import load_scene, save_scene
from mirrorcore.sim.simulator import Simulator


@pytest.mark.parametrize(
    "scene",
    [
        paper_scene(),
        arc_scene(4),
        paper_scene(object="figure", distance=3.0),
        kaleidoscope_scene(72),
    ],
)
def test_scene_file_round_trip(tmp_path, scene):
    save_scene(scene, tmp_path / "scene.json")
    loaded = load_scene(tmp_path / "scene.json")
    assert (loaded.camera, loaded.objects, loaded.room) == (scene.camera, scene.objects, scene.room)
    for a, b in zip(loaded.mirrors, scene.mirrors):
        assert a.name == b.name and a.markers == b.markers
        np.testing.assert_allclose(a.corners(), b.corners(), atol=1e-12)


def test_scene_file_keeps_the_glass_and_the_clicks(tmp_path):
    scene = paper_scene().with_markers(0.004, 1.5)
    save_scene(scene, tmp_path / "scene.json")
    loaded = load_scene(tmp_path / "scene.json")
    assert [m.marker_offset for m in loaded.mirrors] == [
        0.004,
        0.004,
    ] and loaded.click_jitter_px == 1.5
    assert (
        load_scene(tmp_path / "scene.json").with_markers(click_jitter_px=0.0).mirrors
        == loaded.mirrors
    )


@pytest.mark.parametrize(
    "edit, key",
    [
        (lambda d: d["mirrors"][0].pop("normal"), "mirrors[0]: missing key(s) normal"),
        (lambda d: d["mirrors"][1].update(width=-1), "mirrors[1].width"),
        (lambda d: d["objects"][0].update(type="teapot"), "objects[0].type"),
        (lambda d: d["objects"][0].update(centre=[0, 1]), "objects[0].centre"),
        (lambda d: d.pop("camera"), "missing key 'camera'"),
        (
            lambda d: d["mirrors"][0].update(marker_offset=-0.001),
            "mirrors[0].marker_offset: must be 0 to 0.05 metres",
        ),
        (lambda d: d["mirrors"][1].update(marker_offset="3"), "mirrors[1].marker_offset"),
        (
            lambda d: d.update(click_jitter_px=float("nan")),
            "click_jitter_px: must be 0 to 50 pixels",
        ),
    ],
)
def test_broken_scene_file_names_file_and_key(tmp_path, edit, key):
    data = paper_scene().to_json()
    edit(data)
    path = tmp_path / "broken.json"
    path.write_text(json.dumps(data))
    with pytest.raises(FileFormatError) as err:
        load_scene(path)
    message = str(err.value)
    assert str(path) in message and key in message and "\n" not in message


def test_invalid_json_is_one_line(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text('{"camera": ')
    with pytest.raises(FileFormatError, match="bad.json: invalid JSON at line 1"):
        load_scene(path)


def test_session_mirrors_hold_visible_markers_inside_outlines():
    rig = Simulator(paper_scene(camera=Intrinsics.kinect_v1().scaled(0.5)))
    specs = session_mirrors(rig, rig.frame(0).truth)
    assert [s.name for s in specs] == [m.name for m in rig.scene.mirrors]
    for spec in specs:
        assert len(spec.markers) == 6 and len(spec.boundary) >= 4 and spec.plane is None
        outline = np.array(spec.boundary, dtype=np.float32)
        assert all(cv2.pointPolygonTest(outline, uv, False) > 0 for uv in spec.markers)


def test_simulate_writes_a_loadable_session_and_truth(tmp_path, capsys):
    out = tmp_path / "session"
    assert main(["simulate", str(out), "--frames", "3", "--seed", "4", "--quiet"]) == 0
    session = load_session(out)
    assert len(session.frames) == 3 and session.read_frame(2).shape == (480, 640)
    assert session.read_background() is not None
    truth = json.loads((out / "truth.json").read_text())
    assert truth["object"]["type"] == "sphere" and truth["object"]["radius"] == 0.115
    assert len(truth["planes"]) == len(session.mirrors) == 2
    for spec, abcd in zip(session.mirrors, truth["planes"]):
        plane = Plane.from_abcd(abcd)
        assert plane.d > 0 and np.allclose(plane.abcd, abcd)
        assert len(spec.markers) == 6 and len(spec.boundary) >= 4 and spec.plane is None
    frame = session.read_frame(0)
    assert (frame > 0).mean() > 0.5


def test_markers_in_front_of_the_glass_and_clicks_off_their_centres(tmp_path):
    """--marker-offset 3 puts every marker face 3 mm in front of the true (reflecting) plane;
    --click-jitter 2 moves the clicks by about 2 px (radial RMS), the same for the same seed;
    truth.json keeps both."""
    plain, glass = tmp_path / "plain", tmp_path / "glass"
    assert main(["simulate", str(plain), "--noise", "none", "--seed", "5", "--quiet"]) == 0
    on_glass = ["--noise", "none", "--seed", "5", "--marker-offset", "3", "--click-jitter", "2"]
    for _ in range(2):
        shutil.rmtree(glass, ignore_errors=True)
        assert main(["simulate", str(glass), *on_glass, "--quiet"]) == 0
        clicks = np.array([load_session(glass).mirrors[j].markers for j in range(2)])
        assert main(["simulate", str(tmp_path / "again"), *on_glass, "--quiet"]) == 0
        np.testing.assert_array_equal(
            clicks, [m.markers for m in load_session(tmp_path / "again").mirrors]
        )
        shutil.rmtree(tmp_path / "again")
    exact = np.array([m.markers for m in load_session(plain).mirrors])
    moved = np.linalg.norm(clicks - exact, axis=-1)
    assert 1.0 < np.sqrt(np.mean(moved**2)) < 3.5 and moved.min() > 0
    truth = json.loads((glass / "truth.json").read_text())
    assert truth["scene"]["click_jitter_px"] == 2.0
    session = load_session(glass)
    depth = session.read_frame(0)
    for mirror, true in zip(truth["mirrors"], truth["planes"]):
        assert mirror["marker_offset"] == 0.003
        plane = Plane.from_abcd(true)
        uv = np.round(exact[truth["mirrors"].index(mirror)]).astype(int)
        faces = reproject_pixels(session.camera, uv[:, 0], uv[:, 1], depth[uv[:, 1], uv[:, 0]])
        # noiseless frames keep 1 mm depth units: each face within 0.6 mm of 3 mm in front of the
        # silver
        np.testing.assert_allclose(
            plane.signed_distance(faces.astype(np.float64)), 0.003, atol=0.6e-3
        )
        np.testing.assert_allclose(
            plane.signed_distance(np.array(mirror["markers"])), 0.003, atol=1e-12
        )


@pytest.mark.parametrize(
    "option, value, message",
    [
        ("--marker-offset", "-1", "--marker-offset: expected a number of mm from 0 to 50, got -1"),
        ("--marker-offset", "nan", "--marker-offset: expected a number of mm from 0 to 50"),
        ("--click-jitter", "99", "--click-jitter: expected a number of pixels from 0 to 50"),
    ],
)
def test_bad_glass_and_jitter_options(tmp_path, capsys, option, value, message):
    assert main(["simulate", str(tmp_path / "s"), option, value, "--quiet"]) == 2
    assert message in capsys.readouterr().err and not (tmp_path / "s").exists()


def test_simulate_cli_errors_leave_nothing(tmp_path, capsys):
    out = tmp_path / "s"
    assert main(["simulate", str(out), "--object", "teapot", "--quiet"]) == 2
    assert "unknown object" in capsys.readouterr().err and not out.exists()
    bad = tmp_path / "scene.json"
    bad.write_text("[]")
    assert main(["simulate", str(out), "--scene", str(bad), "--quiet"]) == 2
    assert not out.exists() and list(tmp_path.iterdir()) == [bad]
    assert main(["simulate", str(out), "--scene", str(bad), "--angle", "90", "--quiet"]) == 2


def test_simulate_from_scene_file_with_figure(tmp_path):
    scene_file = tmp_path / "rig.json"
    save_scene(paper_scene(object="figure", distance=3.0, angle_deg=100), scene_file)
    out = tmp_path / "walk"
    assert (
        main(
            [
                "simulate",
                str(out),
                "--scene",
                str(scene_file),
                "--frames",
                "2",
                "--noise",
                "none",
                "--quiet",
            ]
        )
        == 0
    )
    session = load_session(out)
    assert not np.array_equal(session.read_frame(0), session.read_frame(1))


@pytest.mark.parametrize("angle", [45.0, 60.0, 72.0, 90.0, 120.0])
def test_kaleidoscope_mirrors_meet_at_the_apex(angle):
    """A hinged pair: the planes are `angle` apart, their inner edges HINGE_GAP from one common
    vertical line (the apex), each plane HINGED_CLEARANCE from the sphere's surface when it stands
    on the bisector. Where an image would lie straight behind the sphere (180 / angle whole), the V
    is turned by a quarter of the angle below 90 degrees (the apex leaves the optical axis) and the
    sphere moves 115 mm sideways at 90; otherwise neither."""
    scene = kaleidoscope_scene(angle)
    m1, m2 = scene.mirrors
    # normals face into the V: the surfaces are 180 - that apart
    between = 180.0 - m1.plane.angle_to(m2.plane)
    assert between == pytest.approx(angle, abs=1e-9)
    # the apex: where both (vertical) planes meet at the mirrors' middle height
    y = m1.centre[1]
    n = np.array([[m.plane.n[0], m.plane.n[2]] for m in (m1, m2)])
    x, z = np.linalg.solve(n, [-m.plane.d - m.plane.n[1] * y for m in (m1, m2)])
    apex = np.array([x, y, z])
    for m in (m1, m2):
        corners = m.corners()
        # the middles of the two side edges
        edges = (
            corners[[0, 3]].mean(0),
            corners[[1, 2]].mean(0),
        )
        assert min(np.linalg.norm(e - apex) for e in edges) == pytest.approx(HINGE_GAP, abs=1e-9)
    sphere = scene.objects[0]
    offset = 0.115 if angle == 90.0 else 0.0
    np.testing.assert_allclose(sphere.centre, [offset, 0.0, 2.0], atol=1e-12)
    on_bisector = np.array(sphere.centre) - [offset, 0.0, 0.0]
    for m in (m1, m2):
        assert m.plane.signed_distance(on_bisector) == pytest.approx(
            sphere.radius + HINGED_CLEARANCE
        )
    # the apex seen from the sphere's place on the axis
    turned = np.degrees(np.arctan2(apex[0], apex[2] - 2.0))
    assert turned == pytest.approx({45.0: 11.25, 60.0: 15.0}.get(angle, 0.0), abs=1e-9)


def test_simulate_kaleidoscope_and_bounces(tmp_path, capsys):
    out = tmp_path / "k"
    assert (
        main(
            [
                "simulate",
                str(out),
                "--kaleidoscope",
                "--angle",
                "72",
                "--bounces",
                "2",
                "--noise",
                "none",
                "--quiet",
            ]
        )
        == 0
    )
    truth = json.loads((out / "truth.json").read_text())
    expected = kaleidoscope_scene(72.0)
    assert [m["plane"] for m in truth["mirrors"]] == [m.plane.to_list() for m in expected.mirrors]
    assert "note:" not in capsys.readouterr().out
    assert (
        main(["simulate", str(tmp_path / "k120"), "--kaleidoscope", "--noise", "none", "--quiet"])
        == 0
    )
    # the angle of the V, said
    assert capsys.readouterr().out.splitlines()[-1] == (
        "note: hinged at 120 degrees the mirrors show no view through two of them; --angle 72 "
        "gives such views"
    )
    for argv, message in [
        (["--bounces", "4"], "--bounces: expected a whole number from 1 to 3, got 4"),
        (["--single-bounce", "--bounces", "2"], "--single-bounce means --bounces 1"),
        (["--kaleidoscope", "--mirrors", "3"], "--kaleidoscope: a hinged pair has 2 mirrors"),
        (["--kaleidoscope", "--scene", str(out / "truth.json")], "drop --kaleidoscope"),
    ]:
        capsys.readouterr()
        assert main(["simulate", str(tmp_path / "x"), "--quiet", *argv]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1, err
        assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("layout", [[], ["--kaleidoscope"]], ids=["V", "hinged"])
def test_the_figure_stands_where_the_camera_sees_it_whole_and_the_rig_calibrates(
    tmp_path, capsys, layout
):
    """Without --distance the figure stands 3 m from the camera (at 2 m, the sphere's distance, a
    Kinect cut off its head or feet and with them the mirrors' top or bottom markers: calibration
    refused two or collinear markers)."""
    session = tmp_path / "figure"
    assert (
        main(
            [
                "simulate",
                str(session),
                "--object",
                "figure",
                *layout,
                "--frames",
                "2",
                "--seed",
                "0",
                "--quiet",
            ]
        )
        == 0
    )
    truth = json.loads((session / "truth.json").read_text())
    assert truth["object"]["centre"][2] == pytest.approx(3.0)
    assert main(["calibrate", str(session), "--verbose"]) == 0
    out = capsys.readouterr().out
    assert out.count("markers; they agree with it.") == len(truth["mirrors"]), out
    assert all(" good" in line for line in details(out) if line.startswith("markers: ")), out
    assert all(m.plane is not None for m in load_session(session).mirrors)
