"""The scene's colour through every mirror, end to end on the command line: `simulate` (Kinect
noise, tinted mirrors), `calibrate` with no options (the markers; it measures the colour gains),
`reconstruct` with no colour option, `truth --cloud --json`. Each mirror's view and each view
through two mirrors in turn carries the albedo its pixels see within 3 levels of mean bias per
channel, at most 1.5 times the direct view's colour RMSE; the gains lie within 2 % of the tints;
a gain left out fails its mirror's views."""
import json
from dataclasses import replace

import numpy as np
import pytest

from mirrorcore.io.sessionfile import load_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.scenefile import save_scene
from mirrorscan.cli import main
from tests.cli.output import details
from tests.cli.test_calibrate_colour import tints
from tests.cli.test_reconstruct_colour import MIN_POINTS, _edit_session

# mirror 1 dims blue most, mirror 2 red: tints unlike the defaults, set in a scene file
SCENE_TINTS = ((0.90, 0.84, 0.78), (0.78, 0.86, 0.92))
LAYOUTS = {"paper": ["--frames", "3"],
           "kaleidoscope 72": ["--kaleidoscope", "--angle", "72", "--frames", "3"],
           "paper, scene file's tints": None}
# levels, per channel: the most a view's mean colour may lie from the albedo
MAX_BIAS = 3.0
# the most a view's colour RMSE may be, as a multiple of the direct view's
MAX_RATIO = 1.5


def run_ok(*argv) -> None:
    assert main([str(a) for a in argv]) == 0, argv


def simulate(tmp_path, layout: str):
    """The session folder `simulate` writes for a layout (a scene file for the tints' one)."""
    folder = tmp_path / "scan"
    options = LAYOUTS[layout]
    if options is None:
        scene = paper_scene()
        scene = replace(scene, mirrors=tuple(replace(m, tint=t)
                                             for m, t in zip(scene.mirrors, SCENE_TINTS)))
        save_scene(scene, tmp_path / "scene.json")
        options = ["--scene", tmp_path / "scene.json", "--frames", "3"]
    run_ok("simulate", folder, *options, "--quiet")
    return folder


def colour_figures(folder, capsys) -> dict[int, dict]:
    """reconstruct frame 0 with no colour option, then `truth --cloud --json`: the colour
    figures of each view with at least MIN_POINTS points measured, by source label."""
    cloud = folder.parent / f"{folder.name}.ply"
    run_ok("reconstruct", folder, "-o", cloud)
    capsys.readouterr()
    run_ok("truth", folder, "--cloud", cloud, "--json")
    colour = json.loads(capsys.readouterr().out)["colour"]
    return {c["source"]: c for c in colour if c["points"] >= MIN_POINTS}


def carries_the_albedo(view: dict) -> bool:
    """Whether a view's points carry the true colour: every channel's mean bias within MAX_BIAS
    levels, the RMSE at most MAX_RATIO times the direct view's."""
    return all(abs(b) <= MAX_BIAS for b in view["bias"]) and view["ratio"] <= MAX_RATIO


@pytest.mark.parametrize("layout", LAYOUTS)
def test_every_view_carries_the_albedo_and_a_gain_left_out_fails_its_views(layout, tmp_path,
                                                                           capsys):
    folder = simulate(tmp_path, layout)
    run_ok("calibrate", folder, "--quiet")
    mirrors = load_session(folder).mirrors
    true_tints = tints(folder)
    if LAYOUTS[layout] is None:
        assert true_tints == [list(t) for t in SCENE_TINTS]
    for mirror, tint in zip(mirrors, true_tints):
        np.testing.assert_allclose(mirror.colour_gain, tint, rtol=0.02)

    views = colour_figures(folder, capsys)
    assert set(range(len(mirrors) + 1)) <= set(views), views.keys()
    multi = [label for label in views if label > len(mirrors)]
    assert bool(multi) == layout.startswith("kaleidoscope"), "views through both mirrors in turn"
    assert views[0]["ratio"] == 1.0
    for label, view in views.items():
        assert carries_the_albedo(view), view
    run_ok("truth", folder, "--cloud", folder.parent / "scan.ply", "-v")
    lines = details(capsys.readouterr().out)
    assert any(line.startswith("mirror 1: ") and f"({views[1]['ratio']:.2f}x the direct view's)"
               in line for line in lines)
    assert not any("x the direct view's" in line for line in lines if line.startswith("direct"))

    # mirror 1's gain left out (a copy of the session): its view and the views through it are
    # too dark; the other mirror's view still carries the albedo
    dim = _edit_session(folder, tmp_path / "dim", lambda s: s["mirrors"][0].pop("colour_gain"))
    left_out = colour_figures(dim, capsys)
    assert left_out[0]["bias"] == views[0]["bias"]
    for label, view in left_out.items():
        through_1 = label == 1 or label in multi
        assert carries_the_albedo(view) != through_1, view
        assert not through_1 or min(view["bias"]) < -MAX_BIAS, view
