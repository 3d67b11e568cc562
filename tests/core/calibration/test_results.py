"""What a refinement reports (results.py): the verdict first, and no change when nothing
moved."""
from dataclasses import replace
from types import SimpleNamespace

from mirrorcore.calibration.results import MirrorRefinement, Refinement
from mirrorcore.geometry.plane import Plane


def test_the_report_leads_with_whether_the_views_agree_as_the_noise_allows():
    """The RMS is mostly the depth noise's, so the report says first whether it is within what the
    noise explains (NOISE_EXPLAINS), then the figures before and after."""
    plane = Plane.from_abcd([0.0, 0.0, 1.0, -2.0])
    report = MirrorRefinement(0, "left", plane, plane, 5.43, 5.44, -0.73, 0.04, 3.41, 0.02, 0.5,
                              0.01, 900, 900, 7.94)
    assert report.summary() == (
        "plane moved +3.41 mm (> 0: away from the camera) and 0.020°; its points agree with the "
        "other views as well "
        "as the depth noise allows (RMS 5.43 mm before, 5.44 mm after, mean -0.73 mm before, +0.04 "
        "mm after over the "
        "frames used, where the depth noise alone would give 7.94 mm RMS); the data fix it to "
        "±0.50 mm and ±0.010° "
        "(1σ; the method may add 1 to 2 mm, a ball in every view only 0.3 mm; 900 points seen both "
        "ways with the "
        "camera)")
    # an arc's middle mirror
    middle = replace(report, agreements=7565, camera_agreements=42)
    assert middle.summary().endswith(
        "(1σ; the method may add 1 to 2 mm, a ball in every view only 0.3 mm; 7,565 "
                                     "points seen both ways with the camera and the mirrors that "
                                     "fix it, 42 with the "
                                     "camera)")
    assert report.summary(searched=True).startswith(
        "its points agree with the other views as well as the depth noise allows (RMS 5.44 mm, "
        "mean +0.04 mm over")
    glass = replace(report, marker_offset=0.0032, marker_offset_std=0.0002)
    assert glass.summary().endswith(
        ", markers 3.2 ± 0.2 mm in front of the silver (saved as its glass)")
    # a refinement that changed nothing
    assert glass.summary(saved=False).endswith("the silver (its glass already)")
    worse = replace(report, noise_mm=4.0)
    assert ("⚠ its points agree with the other views less well than the depth noise explains (RMS"
            in worse.summary())
    assert worse.summary().split("; the data fix")[0].endswith("4.00 mm RMS): check its boundary")


def test_a_refinement_that_moves_nothing_changes_nothing():
    """A refinement right after the search's own, on the same frames, is no change (no undo step,
    no save): below 0.05 mm, 0.005° and 0.05 mm of glass."""
    def glass(*mm):
        return SimpleNamespace(mirrors=[SimpleNamespace(marker_offset=x / 1e3) for x in mm])

    still = [SimpleNamespace(index=0, shift_mm=-0.04, tilt_deg=0.004),
             SimpleNamespace(index=1, shift_mm=0.0, tilt_deg=0.0)]
    assert not Refinement.changed(SimpleNamespace(mirrors=still), glass(3.0, 0.0), glass(3.04, 0.0))
    # a glass moved
    assert Refinement.changed(SimpleNamespace(mirrors=still), glass(3.0, 0.0), glass(3.0, 0.06))
    moved = SimpleNamespace(index=1, shift_mm=-0.06, tilt_deg=0.0)
    assert Refinement.changed(SimpleNamespace(mirrors=[still[0], moved]), glass(0, 0), glass(0, 0))
    turned = SimpleNamespace(index=0, shift_mm=0.0, tilt_deg=0.006)
    assert Refinement.changed(SimpleNamespace(mirrors=[turned]), glass(0, 0), glass(0, 0))
