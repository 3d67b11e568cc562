"""What a refinement reports (results.py): each mirror's figures, and no change when nothing
moved."""
from types import SimpleNamespace

from mirrorcore.calibration.results import NOISE_EXPLAINS, MirrorRefinement, Refinement
from mirrorcore.geometry.plane import Plane


def test_a_mirrors_report_holds_its_figures_by_name():
    """The wordings of the browser and the command line read these fields: each lands where its
    name says, in the units it says."""
    plane = Plane.from_abcd([0.0, 0.0, 1.0, -2.0])
    report = MirrorRefinement(0, "left", plane, plane, 5.43, 5.44, -0.73, 0.04, 3.41, 0.02, 0.5,
                              0.01, 900, 42, 7.94)
    assert (report.agreement_before_mm, report.agreement_after_mm) == (5.43, 5.44)
    assert (report.offset_before_mm, report.offset_after_mm) == (-0.73, 0.04)
    assert (report.shift_mm, report.tilt_deg) == (3.41, 0.02)
    assert (report.shift_std_mm, report.tilt_std_deg) == (0.5, 0.01)
    assert (report.agreements, report.camera_agreements, report.noise_mm) == (900, 42, 7.94)
    assert report.marker_offset is None and report.sphere_radius_mm is None
    assert report.agreement_after_mm <= NOISE_EXPLAINS * report.noise_mm


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
