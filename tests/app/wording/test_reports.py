"""Reports' wording: a long refusal, a calibration's headline and a mirror's line lead with a short
headline and keep their figures in the details."""
from dataclasses import replace

from mirrorscan.markup import fold_under
from mirrorscan.results import CalibrationReport, FramesUsed, NotFound
from mirrorscan.wording import HEADLINE_WORDS, refusal, words
from mirrorscan.wording import refinement as calibration_words
from mirrorscan.wording.mirrors import mirror_status

from mirrorcore.geometry.plane import Plane
from mirrorcore.io.session import SessionMirror
from tests.app.support import refined


def test_a_long_refusal_leads_with_a_short_headline_and_keeps_all_in_its_details():
    long = (
        "not done: mirror 1: the camera and the mirror see too little of the same surface to "
        "determine its "
        "plane (18 readings agree over 10 frame(s), 200 are needed; the 72,126 it shares with "
        "the other "
        "mirrors fix nothing, as the camera fixes none of them); refine on an object that both "
        "see from the "
        "side"
    )
    said = refusal(long, "why is in the details")
    assert said.headline == (
        "not done: mirror 1: the camera and the mirror see too little of the "
        "same surface "
        "to determine its plane; why is in the details."
    )
    assert said.details == (long,) and words(said.headline) <= HEADLINE_WORDS
    assert refusal("not done: a short one (here)").headline == "not done: a short one (here)"
    search = calibration_words.calibration_refused(long, ("mirror 1",), search=True)
    assert search.headline.startswith(
        "mirror 1 not found from the object: the planes are as they were"
    )
    assert search.details == (long,) and words(search.headline) <= HEADLINE_WORDS


def test_a_calibrations_headline_is_short_and_its_figures_are_in_the_details():
    used = FramesUsed((0, 1, 2, 3, 4))
    report = CalibrationReport((refined(),), False, "surfaces", True, used)
    head = calibration_words.headline(report)
    assert head.headline == (
        "Planes refined. Undo restores the previous planes. Glass measured: "
        "type it in if "
        "you know it (how: in the details)."
    )
    assert head.details[-1].startswith("Type it in under Mirrors › Rename, glass, remove, clear.")
    assert (
        "Over the last 5 live frames." in head.details
        and "A move > 0 is away from the camera." in head.details
    )
    line = calibration_words.mirror_line(report.mirrors[0], search=False)
    assert line.headline == (
        "**left** refined: moved -2.7 mm and 0.18°; its view agrees with the "
        "others as the "
        # the sign kept
        "depth noise allows."
    )
    assert (
        "RMS 1.42 mm before, 0.91 mm after; mean +0.61 mm before, +0.05 mm after; the depth "
        "noise alone "
        "gives 1.00 mm RMS."
    ) in line.details
    assert (
        "Glass: markers 0.5 ± 1.2 mm in front of the silver (saved as its glass)." in line.details
    )
    worse = calibration_words.mirror_line(refined(agreement_after_mm=1.2), search=False)
    assert (
        "⚠ its view agrees less well than the depth noise explains: check its boundary"
        in worse.headline
    )
    found = CalibrationReport(
        (refined(),),
        True,
        "surfaces",
        True,
        used,
        (NotFound("middle", "its image spills over the outline"),),
    )
    said = calibration_words.report(found)
    assert said[0].headline.startswith("Planes found; ⚠ middle not found (why below). Undo takes")
    assert said[-1].headline.startswith("**middle** ⚠ not found") and said[-1].details == (
        "its image spills over the outline",
    )
    assert calibration_words.note(found).plain.endswith("The report is under Mirrors.")
    for message in [*said, *calibration_words.report(report), calibration_words.note(report)]:
        assert words(message.headline) <= HEADLINE_WORDS, message.headline
    assert "<details><summary>Details</summary>" in said[0].markdown()


def test_a_mirrors_line_says_where_its_plane_comes_from_its_glass_and_its_markers():
    mirror = SessionMirror("left", ((10.0, 10.0),), id=3)
    assert mirror_status(None, False) == ""
    assert mirror_status(mirror, False) == "no plane yet · no glass set · 1 marker"
    placed = replace(mirror, plane=Plane.from_abcd([0.0, 0.0, -1.0, 2.0]), marker_offset=0.0042)
    assert mirror_status(placed, False) == "plane calibrated · glass 4.2 mm typed in · 1 marker"
    assert mirror_status(placed, True).startswith("plane from the object · ")
    assert mirror_status(placed, False, glass_unused=True) == (
        "plane calibrated · glass 4.2 mm typed in, not in the plane yet: **Fit plane** moves it "
        "behind the "
        "glass · 1 marker"
    )
    # measured by a refinement: with its 1 sigma
    read = replace(placed, marker_offset_std=0.0008)
    assert mirror_status(read, True) == (
        "plane from the object · glass 4.2 ± 0.8 mm measured (type it in if you know it) · 1 marker"
    )
    assert mirror_status(placed, True, glass_unused=True) == (
        "plane from the object · glass 4.2 mm typed in: the next markers fit uses it, this plane "
        "does not depend on "
        "it · 1 marker"
    )
    measured = replace(placed, marker_offset=0.0)  # no glass read (one marker): not "0.0 mm"
    assert mirror_status(measured, True) == "plane from the object · glass not measured · 1 marker"
    assert mirror_status(measured, False).startswith("plane calibrated · no glass set")
    assert mirror_status(replace(measured, markers=()), True) == "plane from the object · 0 markers"
    # a colour gain: the line itself opens the fold that holds it (no line of its own), its bold
    # kept and any HTML of a name shown as text
    gained = replace(placed, colour_gain=(0.84, 0.88, 0.86))
    status = mirror_status(gained, False, glass_unused=True)
    assert status.startswith("<details><summary>plane calibrated · glass 4.2 mm typed in, not in "
                             "the plane yet: <b>Fit plane</b> moves it")
    assert "1 marker</summary>" in status and "colour 84 / 88 / 86 %" in status
    assert fold_under("a <img onerror=x> name", ["x"]).startswith(
        "<details><summary>a &lt;img onerror=x&gt; name</summary>")
