"""`mirrorscan calibrate --refine` and `--method scene` on the simulator as a user meets a real rig:
Kinect v1 noise, markers 3 mm in front of the silver, clicks off by 2 px (issue 11). The figures in
README.md come from these runs (and seeds 0 to 3 of the same, measured beside them)."""

import json
import shutil

import numpy as np
import pytest

from mirrorscan.cli import main
from tests.cli.output import headlines
from mirrorcore.io.ply import read_ply
from mirrorcore.io.sessionfile import load_session
from mirrorcore.sim.truth import plane_errors as truth_plane_errors, surface_error
from mirrorcore.sources import session_truth

FRAMES = 10
SEED = 3


def run_ok(*argv) -> None:
    assert main([str(a) for a in argv]) == 0, argv


def plane_errors(session) -> list[tuple[float, float]]:
    """Per mirror: (mm at the object's middle, along the normal; degrees) from the true plane
    (`mirrorscan truth`)."""
    loaded = load_session(session)
    return [(e.offset_mm, e.tilt_deg) for e in truth_plane_errors(loaded, session_truth(loaded)[0])]


def sphere_figures(session, folder, capsys) -> tuple[float, float]:
    """(fitted radius, RMSE to the true sphere) mm of frame 0's cloud."""
    run_ok("reconstruct", session, "-o", folder / "cloud.ply", "--frame", 0)
    points, _ = read_ply(folder / "cloud.ply")
    rmse = surface_error(points, session_truth(load_session(session))[0]).rmse_mm
    capsys.readouterr()
    run_ok("fit", "sphere", folder / "cloud.ply", "--json")
    return json.loads(capsys.readouterr().out)["radius_mm"], rmse


@pytest.fixture(scope="module")
def rigs(tmp_path_factory):
    """Sessions of the sphere: 'glass' (markers 3 mm in front, 2 px clicks) and 'perfect' (markers
    on the silver, exact clicks), the same noise, under one folder."""
    root = tmp_path_factory.mktemp("refine")
    run_ok(
        "simulate",
        root / "glass",
        "--marker-offset",
        3,
        "--click-jitter",
        2,
        "--frames",
        FRAMES,
        "--seed",
        SEED,
        "--quiet",
    )
    run_ok("simulate", root / "perfect", "--frames", FRAMES, "--seed", SEED, "--quiet")
    return root


def test_markers_on_glass_are_off_and_the_refinement_brings_them_back(rigs, capsys, tmp_path):
    root = rigs
    session = tmp_path / "s"
    shutil.copytree(root / "glass", session)
    run_ok("calibrate", session)
    before = plane_errors(session)
    assert all(offset < -2.0 for offset, _ in before)  # markers nearer than the silver: planes too
    radius_before, _ = sphere_figures(session, tmp_path, capsys)
    assert radius_before < 113.5  # the sphere comes out millimetres too small
    capsys.readouterr()
    run_ok("calibrate", session, "--refine", "--quiet", "--verbose")
    out = capsys.readouterr().out
    assert headlines(out) == [
        *(
            f"mirror {k}: plane refined; it agrees with the other views as well as the depth "
            "noise allows."
            for k in (1, 2)
        ),
        # the session has colour frames
        *(f"mirror {k}: colour gain measured; its points show the scene's own colour."
          for k in (1, 2)),
        f"wrote {session / 'session.json'}",
    ]
    # the markers were too near
    assert out.count("  known to ±") == 2 and out.count("  moved +") == 2
    # the object is a sphere
    assert out.count("  compared: the centres of the sphere (radius 115.") == 2
    # issue 11 asks 0.5 mm and 0.1 deg; seeds 0 to 3 give +0.12 to +0.32 mm and at most 0.037 deg
    # (README)
    for offset, angle in plane_errors(session):
        assert abs(offset) < 0.5 and angle < 0.1
    for mirror in load_session(session).mirrors:  # the glass, estimated: 3 mm (2.8 to 3.7)
        assert mirror.marker_offset == pytest.approx(0.003, abs=1e-3)
    radius, rmse = sphere_figures(session, tmp_path, capsys)
    perfect = tmp_path / "perfect"
    shutil.copytree(root / "perfect", perfect)
    run_ok("calibrate", perfect)
    _, perfect_rmse = sphere_figures(perfect, tmp_path, capsys)
    assert abs(radius - 115.0) < 0.5
    assert rmse <= 1.05 * perfect_rmse  # no worse than perfect markers
    # the estimated glass goes into the next markers fit: the planes come back near the refined ones
    capsys.readouterr()
    run_ok("calibrate", session)
    assert all(abs(offset) < 1.5 for offset, _ in plane_errors(session))
    # and the surfaces, asked for, are still there
    capsys.readouterr()
    run_ok("calibrate", session, "--refine", "--refine-with", "surfaces", "--quiet", "-v")
    assert capsys.readouterr().out.count(" points seen both ways with the camera") == 2


def test_refining_a_good_calibration_keeps_it_good(rigs, tmp_path, capsys):
    root = rigs
    session = tmp_path / "s"
    shutil.copytree(root / "perfect", session)
    # markers, then the refinement
    run_ok("calibrate", session, "--method", "markers", "--refine", "--quiet")
    refined = plane_errors(session)
    # exact markers are themselves up to 0.6 mm off (their readings' noise; seeds 0 to 3): the
    # refinement moves them by that, towards the truth (README)
    assert all(abs(offset) < 0.5 and angle < 0.1 for offset, angle in refined)
    written = (session / "session.json").read_bytes()
    capsys.readouterr()
    # alone, on the planes that are set: they stay, and so does the file
    run_ok("calibrate", session, "--refine", "--quiet", "--verbose")
    out = capsys.readouterr().out
    assert (session / "session.json").read_bytes() == written
    assert out.splitlines()[-2:] == [
        "nothing changed: the planes and the glass are already where this object puts "
        f"them; {session / 'session.json'} not written.",
        "  within 0.05 mm, 0.005° and 0.05 mm of glass",
    ]
    assert "(saved as its glass)" not in out and out.count("(its glass already)") == 2


def test_with_an_ideal_sensor_exact_markers_move_by_their_own_error_alone(tmp_path):
    """No noise (the readings exact, saved in millimetre steps): exact markers are 0.19 and 0.23 mm
    off (the steps), and the refinement takes both planes to 0.01 mm: it moves them by the markers'
    own error and no more (README)."""
    session = tmp_path / "ideal"
    run_ok("simulate", session, "--noise", "none", "--frames", 3, "--quiet")
    run_ok("calibrate", session, "--quiet")
    markers = plane_errors(session)
    assert all(0.1 < abs(offset) < 0.3 and angle < 0.02 for offset, angle in markers), markers
    run_ok("calibrate", session, "--refine", "--quiet")
    refined = plane_errors(session)
    assert all(abs(offset) < 0.05 and angle < 0.005 for offset, angle in refined), refined
    assert all(abs(a - b) < 0.25 for (a, _), (b, _) in zip(markers, refined))


def without_markers(source, target) -> None:
    shutil.copytree(source, target)
    data = json.loads((target / "session.json").read_text())
    for mirror in data["mirrors"]:
        mirror["markers"], mirror["plane"] = [], None
    (target / "session.json").write_text(json.dumps(data))


def test_scene_method_without_markers_on_the_sphere(rigs, capsys, tmp_path):
    root = rigs
    session = tmp_path / "s"
    without_markers(root / "glass", session)
    capsys.readouterr()
    run_ok("calibrate", session, "--method", "scene", "--frame", 0, "--quiet", "-v")  # one frame
    out = capsys.readouterr().out
    # a found plane has no start worth a "moved" (the search's guess)
    assert "mirror 1: plane found; it agrees with the other views" in out and "moved" not in out, (
        out
    )
    assert "  agreement with the other views: RMS " in out and "before" not in out
    assert "markers only read the glass" not in out  # it has none
    for offset, angle in plane_errors(session):
        assert abs(offset) < 1.0 and angle < 0.2


def test_scene_method_says_that_it_leaves_the_markers_out_of_the_planes(rigs, capsys, tmp_path):
    session = tmp_path / "s"
    shutil.copytree(rigs / "glass", session)
    capsys.readouterr()
    run_ok("calibrate", session, "--method", "scene", "--frame", 0, "--quiet")
    out = capsys.readouterr().out.splitlines()
    # before the colour gains' lines (the session has colour frames)
    assert out[-4] == (
        "mirror 1 and mirror 2: their planes were found from the object alone; the markers only "
        "read "
        "the glass."
    )
    for offset, angle in plane_errors(session):  # the markers' 3 mm of glass did not pull them
        assert abs(offset) < 1.0 and angle < 0.2


def test_scene_method_writes_the_mirrors_it_finds_and_names_the_others(rigs, capsys, tmp_path):
    """Mirror 1's outline drawn 80 px too narrow: its image spills over it, and its search is
    refused; mirror 2 is still found (over every frame) and written (before, one refusal dropped
    every mirror), and the command says which was not, why, and exits with status 2."""
    root = rigs
    session = tmp_path / "s"
    without_markers(root / "glass", session)
    data = json.loads((session / "session.json").read_text())
    boundary = np.asarray(data["mirrors"][0]["boundary"], float)
    boundary[boundary[:, 0] < boundary[:, 0].mean(), 0] += 80.0
    data["mirrors"][0]["boundary"] = boundary.tolist()
    (session / "session.json").write_text(json.dumps(data))
    capsys.readouterr()
    assert main(["calibrate", str(session), "--method", "scene", "--quiet", "-v"]) == 2
    out, err = capsys.readouterr()
    assert (
        "mirror 2: plane found" in out
        and "mirror 1: plane found" not in out
        and f"wrote {session}" in out
    )
    # its spilled image is not the camera's view in mirror 2's refinement, which compares the
    # sphere's centres
    assert "  compared: the centres of the sphere" in out
    assert len(err.strip().splitlines()) == 1
    assert "mirror 1 not calibrated (the planes found are written): mirror 1: " in err
    assert err.strip().endswith(
        "its image spills over the outline; draw the outline along the glass's edge."
    )
    written = load_session(session)
    assert written.mirrors[0].plane is None
    true = session_truth(written)[0].mirrors[1].plane
    assert written.mirrors[1].plane.angle_to(true) < 0.2


def test_scene_method_on_the_walking_person(tmp_path):
    session = tmp_path / "walk"
    run_ok(
        "simulate",
        session,
        "--object",
        "figure",
        "--distance",
        3.0,
        "--frames",
        3,
        "--seed",
        1,
        "--quiet",
    )
    data = json.loads((session / "session.json").read_text())
    for mirror in data["mirrors"]:
        mirror["markers"] = []
    (session / "session.json").write_text(json.dumps(data))
    run_ok("calibrate", session, "--method", "scene", "--quiet")
    # issue 11 asks 1 mm and 0.2 deg; the person's planes come out 1.6 to 2.5 mm too near the
    # camera (README; this seed -1.8 and -1.9 mm, 0.015 and 0.008 deg)
    for offset, angle in plane_errors(session):
        assert abs(offset) < 2.5 and angle < 0.1


def test_refine_alone_fits_the_mirrors_without_a_plane_from_their_markers_first(
    rigs, capsys, tmp_path
):
    """Markers are the default method: `--refine` on a session without planes fits them from the
    markers, then refines; a mirror with a plane starts from it, not from its markers."""
    session = tmp_path / "s"
    shutil.copytree(rigs / "glass", session)
    data = json.loads((session / "session.json").read_text())
    for mirror in data["mirrors"]:
        mirror["plane"] = None
    (session / "session.json").write_text(json.dumps(data))
    capsys.readouterr()
    run_ok("calibrate", session, "--refine", "--frame", 0, "--quiet")
    out = headlines(capsys.readouterr().out)
    assert [line.split(":")[0] for line in out[:2]] == ["mirror 1", "mirror 2"]
    assert all("plane refined" in line for line in out[2:4]) and out[-1].startswith("wrote ")
    assert all(abs(offset) < 1.0 and angle < 0.1 for offset, angle in plane_errors(session))
    # mirror 2's plane kept where it is: only mirror 1 is fitted from its markers
    data = json.loads((session / "session.json").read_text())
    data["mirrors"][0]["plane"] = None
    (session / "session.json").write_text(json.dumps(data))
    capsys.readouterr()
    run_ok("calibrate", session, "--refine", "--frame", 0, "--quiet")
    out = headlines(capsys.readouterr().out)
    assert out[0].startswith("mirror 1: ")
    assert "plane refined" in out[1] and "plane refined" in out[2]


def test_refusals_are_one_line_and_change_nothing(rigs, capsys, tmp_path):
    root = rigs
    session = tmp_path / "s"
    without_markers(root / "glass", session)
    capsys.readouterr()
    # no plane and no markers: the markers fit that --refine starts with refuses
    assert main(["calibrate", str(session), "--refine"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.endswith("mirror 1: 0 usable marker(s) of 0, 3 are needed"), err
    box = tmp_path / "box"
    run_ok("simulate", box, "--object", "box", "--quiet")
    run_ok("calibrate", box)
    before = (box / "session.json").read_bytes()
    capsys.readouterr()
    assert main(["calibrate", str(box), "--refine", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "see too little of the same surface" in err
    assert (box / "session.json").read_bytes() == before
    assert main(["calibrate", str(box), "--method", "markers", "--refine", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()  # the markers fit printed, then refused: said so
    assert err.endswith("(nothing written: without --refine, the markers fit alone is written)")
    assert (box / "session.json").read_bytes() == before
    assert main(["calibrate", str(box), "--refine", "--refine-with", "sphere", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert (
        len(err.splitlines()) == 1 and "frame 0: the object is not a sphere in the view of" in err
    ), err
    assert main(["calibrate", str(box), "--refine-with", "sphere"]) == 2
    assert "--refine-with sphere applies to --refine or --method scene" in capsys.readouterr().err
    assert (box / "session.json").read_bytes() == before


def test_a_plane_the_search_got_wrong_is_refused_not_written(tmp_path, capsys):
    """Two mirrors hinged at 72 degrees, the figure 2 m away, calibrated from the object alone: the
    search locked on planes about 50 degrees off the truth, which the refinement can move only a few
    centimetres. Their views still disagree with the camera's twice as much as the depth noise
    explains (the true planes: 0.7 to 0.9 times): the calibration is refused by name, writing
    nothing."""
    session = tmp_path / "hinged"
    run_ok(
        "simulate",
        session,
        "--kaleidoscope",
        "--angle",
        72,
        "--object",
        "figure",
        "--distance",
        2.0,
        "--frames",
        3,
        "--seed",
        0,
        "--quiet",
    )
    before = (session / "session.json").read_bytes()
    capsys.readouterr()
    assert main(["calibrate", str(session), "--method", "scene", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "its plane was not found" in err and "mirror " in err
    assert (session / "session.json").read_bytes() == before


def test_on_an_arc_of_three_the_middle_mirror_is_fixed_by_the_mirrors_beside_it(tmp_path, capsys):
    """Three mirrors on an arc around the walking figure: the middle one faces the camera and sees
    the person's back, the camera the front, so they share too little to fix it; the mirrors beside
    it see the sides it shares, and fix it once they are fixed. Without markers, a search scored
    against the camera alone puts the middle mirror about 20 deg off: it is searched again against
    the mirrors beside it once they are found."""
    session = tmp_path / "arc"
    run_ok(
        "simulate",
        session,
        "--object",
        "figure",
        "--mirrors",
        3,
        "--frames",
        3,
        "--seed",
        2,
        "--quiet",
    )
    truth = json.loads((session / "truth.json").read_text())
    data = json.loads((session / "session.json").read_text())
    for mirror, plane in zip(data["mirrors"], truth["planes"]):
        mirror["plane"] = plane
    (session / "session.json").write_text(json.dumps(data))
    capsys.readouterr()
    run_ok("calibrate", session, "--refine", "--quiet")
    out = capsys.readouterr().out
    assert out.count(": plane refined;") == 3
    refined = load_session(session)
    for offset, angle in plane_errors(session):  # the figure's planes: 1 to 2 mm too near (README)
        assert abs(offset) < 3.0 and angle < 0.1
    for mirror in data["mirrors"]:
        mirror["plane"] = None
    (session / "session.json").write_text(json.dumps(data))
    run_ok("calibrate", session, "--method", "scene", "--quiet")
    assert capsys.readouterr().out.count(": plane found;") == 3
    for offset, angle in plane_errors(session):  # as the refinement from the true planes
        assert abs(offset) < 3.0 and angle < 0.1
    assert refined.mirrors[1].plane is not None
    # as it says: the middle mirror fitted from its markers (the camera sees them: the simulator
    # puts them where it does), then the others found from the object
    run_ok("calibrate", session, "--method", "markers", "--quiet")
    fitted = load_session(session)
    data = json.loads((session / "session.json").read_text())
    for k in (0, 2):
        data["mirrors"][k]["plane"] = None
    (session / "session.json").write_text(json.dumps(data))
    capsys.readouterr()
    run_ok("calibrate", session, "--method", "scene", "--quiet")
    out = capsys.readouterr().out
    assert out.count(": plane found;") == 2 and "mirror 2: plane found" not in out
    found = load_session(session)
    assert found.mirrors[1].plane == fitted.mirrors[1].plane  # held, as it was
    for k, (offset, angle) in enumerate(plane_errors(session)):
        assert abs(offset) < (3.0 if k != 1 else 5.0) and angle < (0.2 if k != 1 else 0.5), (
            k,
            offset,
            angle,
        )
