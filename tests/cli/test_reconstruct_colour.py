"""The scene's colour in `reconstruct`'s files: simulate (colour frames, tinted mirrors), the true
planes and each mirror's colour gain set to its tint, then `reconstruct` with no colour option
gives every view the albedo (the simulator's, at the true hit point of each point's pixel) within
3 levels of mean bias per channel, the mirrors' colour RMSE at most 1.5 times the direct view's;
a gain left out fails that; `--colour source` and a session without colour write the source
palette's file byte for byte; the batch writes colour and records the choice in its manifest."""
import json
import shutil

import numpy as np
import pytest

from mirrorcore.base.palette import source_colours
from mirrorcore.batch import MANIFEST_FILE
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.ply import _VERTEX
from mirrorcore.sim.albedo import object_albedo
from mirrorcore.sim.colourtruth import view_pixels
from mirrorcore.sim.render import OBJECT
from mirrorcore.sim.scenefile import scene_from_json
from mirrorcore.sim.simulator import Simulator
from mirrorscan.cli import main
from tests.cli.output import details

LAYOUTS = {"paper": [], "kaleidoscope 72": ["--kaleidoscope", "--angle", "72"]}
# points a view needs for its figures to count
MIN_POINTS = 200


def _simulate(folder, options, frames=1):
    """simulate, then the true planes and each mirror's colour gain = its tint in session.json."""
    assert main(["simulate", str(folder), "--quiet", "--frames", str(frames), *options]) == 0
    truth = json.loads((folder / "truth.json").read_text())
    session = json.loads((folder / "session.json").read_text())
    for mirror, true in zip(session["mirrors"], truth["mirrors"]):
        mirror["plane"], mirror["colour_gain"] = true["plane"], true["tint"]
    (folder / "session.json").write_text(json.dumps(session))
    return folder


def _edit_session(folder, copy, change):
    """A copy of the session folder with session.json changed by `change(dict)`."""
    shutil.copytree(folder, copy)
    session = json.loads((copy / "session.json").read_text())
    change(session)
    (copy / "session.json").write_text(json.dumps(session))
    return copy


def _vertices(path):
    """The vertices of one of our binary PLY files (docs/DESIGN.md layout)."""
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    count = int(data[:end].split(b"element vertex ")[1].split(b"\n")[0])
    return np.frombuffer(data, _VERTEX, count, end)


def _errors(ply, folder) -> dict[int, np.ndarray]:
    """Per source label, the (k, 3) colour errors (levels) of the object's points against the
    albedo at the true hit point of each point's pixel (the point mirrored back through the true
    planes of its view, last mirror first, and projected)."""
    truth = json.loads((folder / "truth.json").read_text())
    scene = scene_from_json(truth["scene"])
    frame = Simulator(scene).frame(0).truth
    vertex = _vertices(ply)
    points = np.stack([vertex["x"], vertex["y"], vertex["z"]], axis=-1)
    planes = [Plane(np.asarray(p[:3]), p[3]) for p in truth["planes"]]
    pixels = view_pixels(points, vertex["source"], planes, scene.camera)
    on = (pixels >= 0) & (frame.surface.reshape(-1)[pixels] == OBJECT)
    hits = frame.points_at(pixels[on])
    albedo = object_albedo(0, hits - np.asarray(scene.objects[0].centre, np.float32))
    rgb = np.stack([vertex["red"], vertex["green"], vertex["blue"]], axis=-1)[on]
    error = rgb.astype(np.float64) - albedo
    sources = vertex["source"][on]
    return {int(s): error[sources == s] for s in np.unique(sources)
            if np.count_nonzero(sources == s) >= MIN_POINTS}


def _rmse(error: np.ndarray) -> float:
    return float(np.sqrt(np.mean(error ** 2)))


@pytest.mark.parametrize("layout", LAYOUTS)
def test_every_view_carries_the_albedo_and_a_gain_left_out_fails(layout, tmp_path, capsys):
    folder = _simulate(tmp_path / "scan", LAYOUTS[layout])
    assert main(["reconstruct", str(folder), "-o", str(tmp_path / "c.ply"), "-v"]) == 0
    assert "colours: the scene's, each mirror's colour gain undone" in details(
        capsys.readouterr().out)
    errors = _errors(tmp_path / "c.ply", folder)
    mirrors = len(json.loads((folder / "truth.json").read_text())["mirrors"])
    assert set(range(mirrors + 1)) <= set(errors)
    assert layout == "paper" or max(errors) > mirrors, "views through two mirrors in turn"
    for label, error in errors.items():
        assert np.all(np.abs(error.mean(axis=0)) <= 3), (label, error.mean(axis=0))
        assert label == 0 or _rmse(error) <= 1.5 * _rmse(errors[0]), (label, _rmse(error))
    # mirror 1's gain left out: its view's colours are the tinted ones
    dim = _edit_session(folder, tmp_path / "dim",
                        lambda s: s["mirrors"][0].pop("colour_gain"))
    assert main(["reconstruct", str(dim), "-o", str(tmp_path / "dim.ply"), "-v"]) == 0
    assert "(mirror 1: no colour gain, as seen)" in capsys.readouterr().out
    assert np.any(np.abs(_errors(tmp_path / "dim.ply", dim)[1].mean(axis=0)) > 3)


def test_source_colours_and_a_session_without_colour_write_the_palette(tmp_path, capsys):
    folder = _simulate(tmp_path / "scan", [])
    assert main(["reconstruct", str(folder), "-o", str(tmp_path / "s.ply"), "--colour",
                 "source", "-v"]) == 0
    assert "colours: the source colours (--colour source)" in details(capsys.readouterr().out)
    vertex = _vertices(tmp_path / "s.ply")
    np.testing.assert_array_equal(np.stack([vertex["red"], vertex["green"], vertex["blue"]], -1),
                                  source_colours(vertex["source"]))
    plain = _edit_session(folder, tmp_path / "plain", lambda s: s.pop("colour_frames"))
    assert main(["reconstruct", str(plain), "-o", str(tmp_path / "p.ply"), "-v"]) == 0
    assert "colours: the source colours, the session has no colour frames" in details(
        capsys.readouterr().out)
    assert (tmp_path / "p.ply").read_bytes() == (tmp_path / "s.ply").read_bytes()
    # the scene's colours: the same points and labels, other colours
    assert main(["reconstruct", str(folder), "-o", str(tmp_path / "c.ply")]) == 0
    coloured = _vertices(tmp_path / "c.ply")
    for name in ("x", "y", "z", "source"):
        np.testing.assert_array_equal(coloured[name], vertex[name])
    assert np.mean(coloured["red"] != vertex["red"]) > 0.5


def test_glb_output_carries_the_scenes_colours(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    folder = _simulate(tmp_path / "scan", [])
    assert main(["reconstruct", str(folder), "-o", str(tmp_path / "c.ply")]) == 0
    assert main(["reconstruct", str(folder), "-o", str(tmp_path / "c.glb")]) == 0
    vertex = _vertices(tmp_path / "c.ply")
    (cloud,) = trimesh.load(tmp_path / "c.glb", process=False).geometry.values()
    np.testing.assert_array_equal(cloud.vertices,
                                  np.stack([vertex["x"], vertex["y"], vertex["z"]], -1))
    np.testing.assert_array_equal(cloud.colors[:, :3], np.stack(
        [vertex["red"], vertex["green"], vertex["blue"]], -1))


def test_the_batch_writes_each_frames_colour_and_records_the_choice(tmp_path, capsys):
    folder = _simulate(tmp_path / "scan", [], frames=3)
    out = tmp_path / "frames"
    assert main(["reconstruct", str(folder), "-o", str(out), "--frame", "all",
                 "--workers", "1"]) == 0
    manifest = json.loads((out / MANIFEST_FILE).read_text())
    assert manifest["options"]["colour"] == "scene"
    assert manifest["inputs"]["calibration"]["colour_gains"][0] == [0.84, 0.88, 0.86]
    for i in (0, 2):
        assert main(["reconstruct", str(folder), "-o", str(tmp_path / "one.ply"), "--frame",
                     str(i)]) == 0
        assert (out / f"{i:06d}.ply").read_bytes() == (tmp_path / "one.ply").read_bytes()
    # a rerun with the source colours would mix them: refused without --overwrite
    capsys.readouterr()
    assert main(["reconstruct", str(folder), "-o", str(out), "--frame", "all", "--workers", "1",
                 "--colour", "source"]) != 0
    assert "colour (scene -> source)); use --overwrite" in capsys.readouterr().err
    assert main(["reconstruct", str(folder), "-o", str(out), "--frame", "all", "--workers", "1",
                 "--colour", "source", "--overwrite"]) == 0
    assert main(["reconstruct", str(folder), "-o", str(tmp_path / "one.ply"), "--frame", "1",
                 "--colour", "source"]) == 0
    assert (out / "000001.ply").read_bytes() == (tmp_path / "one.ply").read_bytes()
    manifest = json.loads((out / MANIFEST_FILE).read_text())
    assert manifest["options"]["colour"] == "source" and "colour_frames" not in manifest["inputs"]
