"""mirrorscan.commands.wording: every message a headline of at most 25 words; every figure of the
typed result printed under -v/--verbose (a figure dropped fails here)."""

from __future__ import annotations

from pathlib import Path

import pytest

from mirrorcore.batch import BatchReport
from mirrorcore.calibration.fit import Calibration
from mirrorcore.calibration.markers import MarkerResiduals
from mirrorcore.calibration.refine import MirrorRefinement
from mirrorcore.geometry.plane import Plane
from mirrorcore.sim.truth import PlaneError, SurfaceError
from mirrorscan.commands import wording
from tests.cli.output import details, headlines

BEFORE = Plane.from_abcd([0.5, 0.0, -0.866, 2.1])
AFTER = Plane.from_abcd([0.49954, 0.00027, -0.86629, 2.0978])


def refinement(**changes) -> MirrorRefinement:
    """A refined mirror whose figures are all different, so that each can be found in the output."""
    figures = dict(
        index=0,
        name="left",
        before=BEFORE,
        after=AFTER,
        agreement_before_mm=5.62,
        agreement_after_mm=5.41,
        offset_before_mm=1.15,
        offset_after_mm=-0.18,
        shift_mm=0.36,
        tilt_deg=0.031,
        shift_std_mm=0.24,
        tilt_std_deg=0.014,
        agreements=12345,
        camera_agreements=6789,
        noise_mm=7.98,
        marker_offset=0.0031,
        marker_offset_std=0.0005,
    )
    return MirrorRefinement(**{**figures, **changes})


def printed(message: wording.Message, capsys, verbose: bool = True) -> str:
    wording.show(message, verbose)
    return capsys.readouterr().out


def test_a_message_is_its_headline_and_its_details_only_when_verbose(capsys):
    message = wording.Message("it happened.", ("figure 1", "figure 2"))
    assert printed(message, capsys, verbose=False) == "it happened.\n"
    assert printed(message, capsys) == "it happened.\n  figure 1\n  figure 2\n"


def test_a_refined_plane_says_every_figure_under_verbose(capsys):
    out = printed(wording.refined(refinement(), searched=False, saved=True), capsys)
    assert headlines(out) == [
        "left: plane refined; it agrees with the other views as well as the depth noise allows."
    ]
    text = "\n".join(details(out))
    for figure in (
        "[0.49954, 0.00027, -0.86629, 2.0978]",
        "+0.36 mm",
        "0.031°",
        "5.62 mm before",
        "5.41 mm after",
        "+1.15 mm before",
        "-0.18 mm after",
        "7.98 mm RMS",
        "±0.24 mm",
        "±0.014°",
        "12,345 points",
        "6,789 with the camera",
        "3.1 ± 0.5 mm",
        "saved as its glass",
        "2.0 mm and 0.05°",
        "a ball in every view 0.3 mm",
    ):
        assert figure in text, figure


def test_a_found_plane_has_no_before_and_a_sphere_says_its_radius(capsys):
    out = printed(
        wording.refined(
            refinement(
                sphere_radius_mm=115.04,
                camera_agreements=12345,
                marker_offset=None,
                marker_offset_std=None,
            ),
            searched=True,
            saved=True,
        ),
        capsys,
    )
    assert headlines(out)[0].startswith("left: plane found;")
    text = "\n".join(details(out))
    assert "before" not in text and "moved" not in text and "glass" not in text
    assert "RMS 5.41 mm, mean -0.18 mm" in text and "(radius 115.0 mm)" in text
    assert "may add 0.3 mm and 0.04°" in text


def test_a_plane_beyond_the_noise_says_what_to_check(capsys):
    out = printed(
        wording.refined(
            refinement(agreement_after_mm=9.0, glass_typed=0.004), searched=False, saved=False
        ),
        capsys,
    )
    assert headlines(out) == [
        "left: plane refined; its view disagrees with the others beyond the depth noise: "
        "check its outline."
    ]
    assert details(out)[-1] == (
        "glass: markers 3.1 ± 0.5 mm in front of the refined plane; its glass stays "
        "4.0 mm, as typed in"
    )


def test_a_markers_fit_names_its_poor_markers_and_gives_its_figures(capsys):
    residuals = MarkerResiduals((0.4, -9.5, 1.1), (2.0, 2.0, 2.2))
    fit = Calibration(AFTER, 3.41, 150, 148, residuals, marker_offset=0.003)
    out = printed(wording.fitted("left", fit, ["a", "b", "c"]), capsys)
    assert headlines(out) == [
        "left: plane fitted to its 3 markers; marker b lies off it: check the click "
        "or move the marker."
    ]
    assert details(out) == [
        "plane [0.49954, 0.00027, -0.86629, 2.0978]",
        "RMS 3.41 mm over 148 of 150 points",
        "markers: 2 good, 1 poor",
        "farthest: marker b, 9.5 mm from the plane (4.8σ)",
        "glass: plane 3.0 mm behind the markers",
    ]
    region = Calibration(AFTER, 1.25, 900, 880)
    assert printed(wording.fitted("left", region), capsys) == (
        "left: plane fitted to its region.\n  plane [0.49954, 0.00027, -0.86629, 2.0978]\n"
        "  RMS 1.25 mm over 880 of 900 points\n"
    )


def test_clouds_meshes_and_batches_keep_their_counts_under_verbose(capsys):
    out = printed(wording.cloud_written(Path("c.ply"), 7909, {0: 3658, 1: 2122, 2: 2129}), capsys)
    assert out == (
        "wrote c.ply: 7909 points seen directly and in 2 mirror views.\n"
        "  points per view: direct 3658, mirror 1 2122, mirror 2 2129\n"
    )
    out = printed(wording.cloud_written(Path("c.ply"), 5780, {0: 3658, 1: 2122, 2: 0}), capsys)
    assert headlines(out) == ["wrote c.ply: 5780 points seen directly and in 1 mirror view."]
    out = printed(
        wording.mesh_written(Path("m.ply"), 5000, 9996, 2, (200, 180, 190), 0.002), capsys
    )
    assert headlines(out) == ["wrote m.ply: a mesh of 5000 vertices fused from 2 frame(s)."]
    assert details(out) == ["9996 faces", "volume 200x180x190 voxels of 2 mm"]
    out = printed(wording.carved_written(Path("v.ply"), 4321, (300, 300, 300), 0.00133), capsys)
    assert details(out) == ["volume 300x300x300 voxels of 1.33 mm"] and "4321 voxels" in out
    done = BatchReport(Path("out"), 3, kept=0, written=3, seconds=0.05)
    assert printed(wording.batch_done(done), capsys) == (
        "wrote 3 PLY files into out; every frame is done.\n  60.0 frames/s over 0.05 s\n"
        "  manifest out/manifest.json\n"
    )
    nothing = BatchReport(Path("out"), 3, kept=3, written=0)
    assert headlines(printed(wording.batch_done(nothing), capsys)) == [
        "nothing to do: the 3 frames are in out already."
    ]


def test_fit_and_truth_lines(capsys):
    plane = PlaneError("left", 0.22, 0.034, 0.3, 0.0)
    assert printed(wording.plane_error(plane), capsys) == (
        "left: plane +0.22 mm at the object, tilted 0.034°; glass 0.3 mm (true 0.0 mm).\n"
        "  offset along the normal at the object's middle; > 0: too far from the camera\n"
    )
    surface = SurfaceError(7909, 1.95, 1.5, 3.98)
    assert printed(wording.surface_error(surface, "c.ply"), capsys) == (
        "c.ply: RMSE 1.95 mm to the true surface over 7,909 points.\n  mean 1.50 mm, 95 % within "
        "3.98 mm\n"
    )


@pytest.mark.parametrize(
    "message",
    [
        wording.unchanged(Path("/a/rather/long/path/to/the/session.json")),
        wording.markers_unused(["mirror 1", "mirror 2", "mirror 3"]),
        wording.retried("tcp://10.0.0.2:4000", list(range(40))),
        wording.batch_done(BatchReport(Path("out"), 40, kept=10, written=27, seconds=2.7)),
    ],
    ids=["unchanged", "markers unused", "retried", "batch not complete"],
)
def test_every_headline_is_short(message, capsys):
    headlines(printed(message, capsys, verbose=False))
