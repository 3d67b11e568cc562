"""The Mirrors panel's wording (mirrorscan.wording.mirrors): fit reports and proposals."""
from types import SimpleNamespace

import numpy as np
from mirrorscan.panels.measure import fit_report
from mirrorscan.results import Fit, FitsApplied
from mirrorscan.wording import HEADLINE_WORDS, words
from mirrorscan.wording.mirrors import NO_GLASS_NOTE, fit_note
from mirrorscan.wording.mirrors import fit_report as markers_report

from mirrorcore.calibration.markers import FitReview
from mirrorcore.geometry.fitting import fit_cylinder, fit_sphere
from mirrorcore.io.session import SessionMirror


def test_a_fit_that_most_points_miss_is_flagged():
    """Measure fits a sphere to whatever is selected: on a walking person most points miss it, and
    the report says so above the numbers; on a sphere it does not."""
    rng = np.random.default_rng(3)
    directions = rng.normal(size=(3000, 3))
    sphere = 0.115 * directions / np.linalg.norm(directions, axis=1, keepdims=True) + [0, 0, 2]
    good = fit_sphere(sphere, rng, threshold=0.02)
    assert not fit_report(good, str).startswith("⚠")
    clutter = rng.uniform(-1, 1, (6000, 3)) + [0, 0, 2]
    poor = fit_sphere(np.vstack([sphere, clutter]), rng, threshold=0.02)
    assert fit_report(poor, str).startswith(
        "⚠ only "
    ) and "the object may not be a sphere" in fit_report(poor, str)
    seen = sphere[sphere[:, 2] < 2.0] + rng.normal(
        scale=0.003, size=(int((sphere[:, 2] < 2.0).sum()), 3)
    )
    # Kinect-like noise, a tight band: still no warning
    tight = fit_sphere(seen, rng, threshold=0.005)
    assert not fit_report(tight, str).startswith("⚠"), fit_report(tight, str)
    # a cylinder on a sphere: most points in the band, spread
    wrong = fit_cylinder(seen, rng, threshold=0.02)
    assert fit_report(wrong, str).startswith("⚠ the points scatter"), fit_report(wrong, str)


def test_a_markers_fit_without_glass_says_how_to_measure_it():
    """A markers fit with no glass set ends with the note on how to measure it; one with glass set
    (0 measured included) does not."""

    def fit(name: str, glass: float, std: float | None = None, mirror_id: int = 1) -> Fit:
        mirror = SessionMirror(
            name, ((1.0, 1.0),) * 3, id=mirror_id, marker_offset=glass, marker_offset_std=std
        )
        calibration = SimpleNamespace(
            rms_mm=2.0, n_inliers=90, n_points=100, markers=None, marker_offset=glass
        )
        return Fit(calibration, mirror, FitReview(0.0, 0.0, ()))

    left, right = fit("left", 0.0), fit("right", 0.004, mirror_id=2)
    # right's waited for Apply, left's did not
    bare = markers_report(FitsApplied((left, right), confirmed=(2,)))
    assert [m.headline for m in bare] == [
        "**left**: plane fitted, 2.0 mm RMS",
        "**right**: plane fitted, 2.0 mm RMS (applied on confirmation)",
        NO_GLASS_NOTE.headline,
    ]
    assert bare[0].details == ("RMS 2.00 mm over 90/100 points.",)
    # glass set: nothing to add
    assert len(markers_report(FitsApplied((fit("left", 0.003),)))) == 1
    # 0 measured is set too
    assert len(markers_report(FitsApplied((fit("left", 0.0, 8e-4),)))) == 1


def test_a_proposal_points_at_crossed_markers_only_when_a_marker_is_crossed():
    """A proposal for a plane turned 4 degrees (no poor marker) points at no crossed marker."""

    def fit(poor):
        return Fit(
            SimpleNamespace(marker_offset=0.003),
            SimpleNamespace(name="left"),
            SimpleNamespace(poor=poor),
        )

    assert fit_note([], [fit(())]).headline == (
        "A new plane for left waits, not applied: look at "
        "it under "
        "Mirrors, then Apply or Discard it."
    )
    assert "under Mirrors (the crossed markers), then" in fit_note([], [fit((2,))]).headline


def test_a_fit_of_several_mirrors_applies_those_that_need_no_look_and_proposes_the_others():
    """One mirror's stray marker does not hold back the other mirrors' planes: the note says both
    what was applied and what waits; the RMS in its details."""

    def fit(name, poor=()):
        return Fit(
            SimpleNamespace(rms_mm=2.0),
            SimpleNamespace(name=name, glass_set=True, marker_names=["3.1", "3.2"]),
            SimpleNamespace(poor=poor),
        )

    said = fit_note([fit("mirror 1"), fit("mirror 2")], [fit("mirror 3", (1,))], ("mirror 4",))
    assert said.headline == (
        "Applied: mirror 1 and mirror 2. mirror 3: a new plane waits, Apply or Discard it. mirror "
        "4: no markers, "
        "left as it is."
    )
    assert words(said.headline) <= HEADLINE_WORDS
    assert said.details[0] == "mirror 1 2.0 mm RMS, mirror 2 2.0 mm RMS."
