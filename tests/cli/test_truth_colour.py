"""`mirrorscan truth --cloud`: the cloud's colours against the scene's albedo per source (a mirror's
gain left out reads as its points too dark), and no colour figures for a cloud in the source
palette or without colours."""

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mirrorcore.depth.files import read_colour
from mirrorcore.io.ply import read_ply, write_ply
from mirrorcore.io.sessionfile import load_session
from mirrorcore.rig.model import Rig
from mirrorcore.rig.pipeline import object_cloud
from mirrorcore.sim.colourtruth import WITHIN_LEVELS
from mirrorcore.sources import session_truth
from mirrorscan.cli import main
from tests.cli.output import details, headlines


def run(capsys, *argv) -> tuple[int, str]:
    capsys.readouterr()
    status = main([str(a) for a in argv])
    return status, capsys.readouterr().out


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """A noiseless sphere session (two tinted mirrors), calibrated."""
    folder = tmp_path_factory.mktemp("colour") / "s"
    assert main(["simulate", str(folder), "--frames", "1", "--noise", "none", "--quiet"]) == 0
    assert main(["calibrate", str(folder), "--quiet"]) == 0
    return folder


def coloured_cloud(folder: Path, out: Path, gains: bool) -> Path:
    """Frame 0's object cloud in the scene's colour, each mirror's gain the simulator's tint (or
    none), as a PLY."""
    session = load_session(folder)
    scene, _ = session_truth(session)
    mirrors = tuple(replace(m, colour_gain=tuple(t.tint) if gains else None)
                    for m, t in zip(session.mirrors, scene.mirrors))
    colour = read_colour(Path(session.root) / session.colour_frames[0], session.camera)
    cloud, _ = object_cloud(Rig.from_session(replace(session, mirrors=mirrors)),
                            session.read_frame(0), session.read_background(), colour=colour)
    write_ply(out, cloud.points, cloud.sources, colours=cloud.rgb)
    return out


def test_the_mirrors_points_carry_the_albedo_with_their_gains_and_not_without(
        session, tmp_path, capsys):
    cloud = coloured_cloud(session, tmp_path / "gains.ply", gains=True)
    status, out = run(capsys, "truth", session, "--cloud", cloud, "--json")
    colour = json.loads(out)["colour"]
    assert status == 0 and [(c["source"], c["name"]) for c in colour] == [
        (0, "direct"), (1, "mirror 1"), (2, "mirror 2")]
    for c in colour:
        assert all(abs(b) < 3 for b in c["bias"]) and c["within"] > 0.9, c
    bare = coloured_cloud(session, tmp_path / "bare.ply", gains=False)
    _, out = run(capsys, "truth", session, "--cloud", bare, "--json")
    left_out = json.loads(out)["colour"]
    assert left_out[0] == colour[0]
    for c in left_out[1:]:
        # the tints (0.82 to 0.89) dim every channel
        assert all(b < -5 for b in c["bias"]) and c["bias"][0] < -20 and c["within"] < 0.1, c


def test_the_colour_figures_are_a_headline_and_one_line_per_source(session, tmp_path, capsys):
    cloud = coloured_cloud(session, tmp_path / "c.ply", gains=True)
    _, out = run(capsys, "truth", session, "--cloud", cloud, "--json")
    colour = json.loads(out)["colour"]
    _, out = run(capsys, "truth", session, "--cloud", cloud, "-v")
    points = sum(c["points"] for c in colour)
    rmse = np.sqrt(sum(c["points"] * c["rmse"] ** 2 for c in colour) / points)
    worst = max(colour, key=lambda c: max(map(abs, c["bias"])))
    k = int(np.argmax(np.abs(worst["bias"])))
    assert headlines(out)[-1] == (
        f"{cloud}: colour RMSE {rmse:.1f} levels (of 255) to the albedo each point's pixel sees; "
        f"largest mean bias {worst['bias'][k]:+.1f}, {('red', 'green', 'blue')[k]} of "
        f"{worst['name']}.")
    r, g, b = colour[1]["bias"]
    unseen = colour[1]["unseen"]
    # noiseless: the direct view's colours are exact, so no ratio to them
    assert colour[0]["rmse"] == 0 and colour[1]["ratio"] is None
    assert details(out)[-3:][1] == (
        f"mirror 1: {colour[1]['points']:,} points, mean bias red {r:+.1f} green {g:+.1f} blue "
        f"{b:+.1f} levels, RMSE {colour[1]['rmse']:.1f} levels, "
        f"{100 * colour[1]['within']:.1f} % within {WITHIN_LEVELS} levels "
        f"({100 * colour[1]['within_at_point']:.1f} % at the point's own position)"
        + (f", {unseen:,} left out (their pixel sees nothing)" if unseen else ""))
    _, quiet = run(capsys, "truth", session, "--cloud", cloud)
    assert headlines(quiet) == headlines(out) and not details(quiet)


def test_a_cloud_in_the_source_palette_or_without_colours_has_no_colour_figures(
        session, tmp_path, capsys):
    xyz, sources = read_ply(coloured_cloud(session, tmp_path / "c.ply", gains=True))
    palette = tmp_path / "palette.ply"
    write_ply(palette, xyz, sources)
    status, out = run(capsys, "truth", session, "--cloud", palette, "--json")
    assert status == 0 and json.loads(out)["colour"] is None
    _, out = run(capsys, "truth", session, "--cloud", palette)
    assert headlines(out)[-1] == (
        f"{palette}: no colour figures, its colours are the source palette, not the scene's; "
        "reconstruct it from a session with colour frames to compare colours.")
    plain = tmp_path / "plain.ply"
    plain.write_text("ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                     "property float z\nend_header\n"
                     + "".join(" ".join(map(str, p)) + "\n" for p in xyz[:2]))
    _, out = run(capsys, "truth", session, "--cloud", plain)
    assert headlines(out)[-1].startswith(f"{plain}: no colour figures, it has no colours, not")


def test_a_cloud_of_another_rig_says_so(session, tmp_path, capsys):
    xyz, sources = read_ply(coloured_cloud(session, tmp_path / "c.ply", gains=True))
    colours = np.full((len(xyz), 3), 90, np.uint8)
    colours[::2] = 160
    # behind the camera: no point's pixel sees the scene
    away = tmp_path / "away.ply"
    write_ply(away, xyz * (1, 1, -1), sources, colours=colours)
    _, out = run(capsys, "truth", session, "--cloud", away, "--json")
    assert all(c["points"] == 0 and c["bias"] is None and c["unseen"] > 0
               for c in json.loads(out)["colour"])
    _, out = run(capsys, "truth", session, "--cloud", away, "-v")
    assert headlines(out)[-1] == (f"{away}: no colour figures, no point's pixel sees the scene; "
                                  "is the cloud of this session and --frame?")
    # a label through a third mirror the session does not have
    third = tmp_path / "third.ply"
    write_ply(third, xyz, np.where(sources == 2, 3, sources), colours=colours)
    status = main(["truth", str(session), "--cloud", str(third)])
    assert status != 0 and ("the cloud's source label 3 names a mirror the session does not "
                            "have (2 mirrors)") in capsys.readouterr().err
