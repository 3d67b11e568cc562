"""Mirror calibration from markers, from a region and from pairs; degenerate input is refused by
name."""
import numpy as np
import pytest
from tests.helpers import plane_depth

from mirrorcore.base.errors import CalibrationError
from mirrorcore.calibration.fit import (
    calibrate_from_markers,
    calibrate_from_pairs,
    calibrate_from_region,
    calibrate_session,
    calibration_depth,
)
from mirrorcore.calibration.markers import review_fit
from mirrorcore.depth.noise import axial_sigma
from mirrorcore.geometry.camera import Intrinsics, project_points
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.session import SessionMirror
from mirrorcore.io.sessionfile import load_session
from mirrorcore.sim.export import write_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.sensor import SensorModel
from mirrorcore.sim.simulator import Simulator

CAMERA = Intrinsics.kinect_v1()
GLASS = Plane.from_point_normal([0.4, 0.0, 2.6], [-0.5, 0.05, -1.0])
MARKERS = np.array([[420, 100], [560, 120], [430, 380], [580, 360], [500, 240], [460, 300],
                    [540, 180], [610, 250]],
                   float)


def mirror_frame(rng=None, virtual_extra=0.8) -> np.ndarray:
    """Depth of a scene where 9x9 squares around each marker read the glass and the rest of the
    glass shows a virtual scene farther away (as a structured-light camera sees it); optional
    Kinect-like noise."""
    glass = plane_depth(CAMERA, GLASS)
    depth = glass + virtual_extra
    for u, v in MARKERS.astype(int):
        depth[v - 4:v + 5, u - 4:u + 5] = glass[v - 4:v + 5, u - 4:u + 5]
    if rng is not None:
        depth = depth + rng.normal(size=depth.shape).astype(np.float32) * axial_sigma(depth).astype(
            np.float32)
    return depth


def test_noiseless_markers_give_the_exact_plane():
    cal = calibrate_from_markers(CAMERA, mirror_frame(), MARKERS, np.random.default_rng(0),
                                 "mirror 1")
    np.testing.assert_allclose(cal.plane.abcd, GLASS.abcd, atol=1e-5)
    assert cal.rms_mm < 0.01 and cal.n_points == 8 * 25 and cal.n_inliers == cal.n_points
    assert len(cal.markers.distance_mm) == 8 and max(cal.markers.distance_mm) < 0.01
    assert cal.markers.grades == ("good",) * 8


def test_markers_in_front_of_the_silver_are_moved_back_by_their_offset():
    """Stickers on 3 mm of glass: their plane is 3 mm nearer the camera than the reflecting
    surface."""
    stickers = Plane(GLASS.normal, GLASS.d - 0.003)
    depth = mirror_frame()
    for u, v in MARKERS.astype(int):
        depth[v - 4:v + 5, u - 4:u + 5] = plane_depth(CAMERA, stickers)[v - 4:v + 5, u - 4:u + 5]
    plain = calibrate_from_markers(CAMERA, depth, MARKERS, np.random.default_rng(0), "mirror 1")
    moved = calibrate_from_markers(CAMERA, depth, MARKERS, np.random.default_rng(0), "mirror 1",
                                   marker_offset=0.003)
    np.testing.assert_allclose(plain.plane.abcd, stickers.abcd, atol=1e-5)
    np.testing.assert_allclose(moved.plane.abcd, GLASS.abcd, atol=1e-5)
    # graded on the stickers' plane
    assert moved.rms_mm == plain.rms_mm and moved.markers == plain.markers
    assert max(moved.markers.distance_mm) < 0.01
    # what the browser grades against
    glass = SessionMirror("mirror 1", plane=moved.plane, marker_offset=0.003)
    np.testing.assert_allclose(glass.marker_plane.abcd, stickers.abcd, atol=1e-5)
    assert SessionMirror("mirror 2").marker_plane is None


def test_a_refit_over_the_same_glass_is_reviewed_as_not_moving_it():
    """The review measures the old plane's distance to the markers' faces, so that refitting
    markers on 3 mm of glass over the plane a refinement left does not read as a 3 mm move."""
    stickers = Plane(GLASS.normal, GLASS.d - 0.003)
    depth = mirror_frame()
    for u, v in MARKERS.astype(int):
        depth[v - 4:v + 5, u - 4:u + 5] = plane_depth(CAMERA, stickers)[v - 4:v + 5, u - 4:u + 5]
    cal = calibrate_from_markers(CAMERA, depth, MARKERS, np.random.default_rng(0), "mirror 1",
                                 marker_offset=0.003)
    same = review_fit(GLASS, cal.plane, cal.markers, np.asarray(cal.centre))
    assert same.shift_mm < 0.01 and same.tilt_deg < 1e-3 and not same.needs_confirmation
    assert not same.moved
    farther = review_fit(Plane(GLASS.normal, GLASS.d + 0.025), cal.plane, cal.markers,
                         np.asarray(cal.centre))
    assert farther.shift_mm == pytest.approx(25.0, abs=0.01) and farther.needs_confirmation
    assert farther.moved and farther.poor == ()


def test_a_refit_of_markers_applied_before_names_its_poor_marker_but_asks_nothing():
    """A poor marker makes a fit a proposal, once: the same markers fitted again, within a refit's
    noise, are applied with the marker named, not proposed again as a change of nothing; a larger
    change still asks."""
    depth = mirror_frame()
    u, v = MARKERS[2].astype(int)
    depth[v - 4:v + 5, u - 4:u + 5] += 0.3
    cal = calibrate_from_markers(CAMERA, depth, MARKERS, np.random.default_rng(0))
    first = review_fit(GLASS, cal.plane, cal.markers, np.asarray(cal.centre))
    # not fitted on these markers before
    assert first.needs_confirmation and not first.refit and first.poor == (2,)
    again = review_fit(GLASS, cal.plane, cal.markers, np.asarray(cal.centre), same_markers=True)
    assert again.refit and not again.needs_confirmation and again.poor == (2,)
    # 2.5 mm: more than other frames move it
    moved = review_fit(Plane(GLASS.normal, GLASS.d + 0.0025), cal.plane, cal.markers,
                       np.asarray(cal.centre), same_markers=True)
    assert moved.needs_confirmation and not moved.refit


def test_noisy_markers_over_a_median_of_frames():
    rng = np.random.default_rng(1)
    one = calibrate_from_markers(CAMERA, mirror_frame(rng), MARKERS, np.random.default_rng(0))
    many = calibrate_from_markers(CAMERA, np.stack([mirror_frame(rng) for _ in range(9)]), MARKERS,
                                  np.random.default_rng(0))
    for cal, tol_deg, tol_mm in ((one, 1.5, 6.0), (many, 0.6, 2.5)):
        assert cal.plane.angle_to(GLASS) < tol_deg
        assert abs(cal.plane.signed_distance(np.array([0.4, 0.0, 2.6]))) * 1e3 < tol_mm
    assert many.rms_mm < one.rms_mm


def test_a_marker_off_the_glass_is_graded_poor_and_named():
    depth = mirror_frame()
    u, v = MARKERS[2].astype(int)
    # clicked beside its marker: the glass shows a virtual point there
    depth[v - 4:v + 5, u - 4:u + 5] += 0.3
    cal = calibrate_from_markers(CAMERA, depth, MARKERS, np.random.default_rng(0))
    np.testing.assert_allclose(cal.plane.abcd, GLASS.abcd, atol=1e-5)   # RANSAC leaves it out...
    assert cal.n_inliers == 7 * 25
    # ...and the report points at it
    assert cal.markers.poor() == (2,) and cal.markers.distance_mm[2] > 250
    assert cal.markers.grades.count("good") == 7
    ratio = np.asarray(cal.markers.distance_mm) / np.asarray(cal.markers.sigma_mm)
    assert int(np.nanargmax(ratio)) == 2
    assert cal.markers.distance_mm[2] == pytest.approx(285.4, abs=0.05)
    assert ratio[2] == pytest.approx(23.3, abs=0.05) and cal.marker_offset == 0.0
    # which side, and so why: behind the plane (off the glass)
    review = review_fit(GLASS, cal.plane, cal.markers, np.asarray(cal.centre))
    assert review.poor == (2,) and not review.moved and cal.markers.signed_mm[2] < 0
    # something in front of it
    depth[v - 4:v + 5, u - 4:u + 5] -= 0.6
    hidden = calibrate_from_markers(CAMERA, depth, MARKERS, np.random.default_rng(0))
    assert review_fit(GLASS, hidden.plane, hidden.markers, np.asarray(hidden.centre)).poor == (2,)
    assert hidden.markers.signed_mm[2] > 0
    glass = calibrate_from_markers(CAMERA, depth, MARKERS, np.random.default_rng(0),
                                   marker_offset=0.0054)
    assert glass.marker_offset == pytest.approx(0.0054)


def test_markers_on_invalid_depth_are_named():
    depth = mirror_frame()
    for u, v in MARKERS[[1, 3, 4]].astype(int):
        depth[v - 4:v + 5, u - 4:u + 5] = 0
    with pytest.raises(CalibrationError,
                       match=r"mirror 2: 2 usable marker\(s\) of 5, 3 are needed; "
                                               r"marker\(s\) 2, 4, 5 have no depth reading"):
        calibrate_from_markers(CAMERA, depth, MARKERS[:5], np.random.default_rng(0), "mirror 2")


def test_too_few_and_collinear_markers():
    with pytest.raises(CalibrationError, match=r"mirror 1: 2 usable marker\(s\) of 2"):
        calibrate_from_markers(CAMERA, mirror_frame(), MARKERS[:2], np.random.default_rng(0),
                               "mirror 1")
    line = np.array([[420, 100], [470, 150], [520, 200], [570, 250]], float)
    depth = plane_depth(CAMERA, GLASS)
    with pytest.raises(CalibrationError,
                       match="mirror 1: markers 1, 2, 3, 4 are \\(nearly\\) collinear"):
        calibrate_from_markers(CAMERA, depth, line, np.random.default_rng(0), "mirror 1")


def test_plane_through_the_camera_is_refused():
    # bisector x = -0.02
    real, virtual = np.array([[0.01, 0.0, 1.0]]), np.array([[-0.05, 0.0, 1.0]])
    with pytest.raises(CalibrationError,
                       match="mirror 1: the fitted plane passes 20 mm from the camera"):
        calibrate_from_pairs(real, virtual, "mirror 1")


def test_a_region_of_the_frame_gives_the_plane():
    depth = plane_depth(CAMERA, GLASS)
    frame = [[410, 90], [600, 90], [600, 110], [410, 110]]   # a strip of the mirror's frame
    cal = calibrate_from_region(CAMERA, depth, frame, np.random.default_rng(0))
    np.testing.assert_allclose(cal.plane.abcd, GLASS.abcd, atol=1e-5)
    depth[:] = 0
    with pytest.raises(CalibrationError, match="the region has 0 pixels with depth, 50 are needed"):
        calibrate_from_region(CAMERA, depth, frame, np.random.default_rng(0))


def test_pairs_of_real_and_virtual_points_give_the_plane():
    rng = np.random.default_rng(2)
    real = rng.uniform([-0.3, -0.3, 1.8], [0.3, 0.3, 2.2], (6, 3))
    virtual = GLASS.reflect(real)
    cal = calibrate_from_pairs(real, virtual)
    np.testing.assert_allclose(cal.plane.abcd, GLASS.abcd, atol=1e-9)
    assert cal.rms_mm < 1e-6
    with pytest.raises(CalibrationError, match="swapped"):
        calibrate_from_pairs(virtual, real)
    with pytest.raises(CalibrationError,
                       match="pair\\(s\\) 1 have the real and virtual point in the same place"):
        calibrate_from_pairs(real[:1], real[:1])


def test_markers_project_where_clicked():
    """The calibration uses the pixel that was clicked: (u, v), not (v, u)."""
    cal = calibrate_from_markers(CAMERA, mirror_frame(), MARKERS, np.random.default_rng(0))
    centre = GLASS.project(np.array([0.4, 0.0, 2.6]))
    uv, _ = project_points(CAMERA, centre[None])
    assert 300 < uv[0, 0] < 640 and cal.plane.signed_distance(centre) == pytest.approx(0, abs=1e-5)


def test_a_stray_marker_far_behind_the_glass_does_not_tilt_the_plane():
    """A click below mirror 2's bottom markers lands on the floor seen through the glass (a virtual
    point 2 m farther, where the depth noise and so the inlier threshold are 3x larger). With
    outliers costing their own squared threshold, the plane through the bottom row and that marker
    cost less than the glass and won (75 degrees off); every outlier must cost the same."""
    from mirrorcore.sim.export import session_mirrors
    from mirrorcore.sim.layouts import paper_scene
    from mirrorcore.sim.simulator import Simulator
    rig = Simulator(paper_scene(object="sphere"), seed=1)
    mirror = session_mirrors(rig, rig.background().truth)[1]
    depth = np.stack([rig.frame(i).depth for i in range(5)])
    bottom = max(mirror.boundary, key=lambda p: p[1])
    stray = (bottom[0] - 10, bottom[1] - 6)
    cal = calibrate_from_markers(rig.intrinsics, depth, mirror.markers + (stray,),
                                 np.random.default_rng(0))
    assert cal.plane.angle_to(rig.planes[1]) < 0.5
    # behind the glass, named
    assert cal.markers.poor() == (6,) and cal.markers.signed_mm[6] < -1000


def test_markers_a_person_walks_in_front_of_are_read_behind_him(tmp_path):
    """A walking figure between the mirrors covers three of their markers in most frames: read on
    the median of the frames and the background, they would lie 0.4 to 0.55 m off the glass; the
    frames without what passes in front of the background read them on the glass."""
    scene = paper_scene(object="figure")
    session = load_session(write_session(Simulator(scene, SensorModel.kinect_v1(), seed=0),
                                         tmp_path / "gait", 5,
                                         progress=False))
    frames = np.stack([*session.read_frames(range(len(session.frames))), session.read_background()])
    _, on_median = calibrate_session(session, frames, np.random.default_rng(0))
    # the scene covers markers
    assert sum(c.markers.grades.count("poor") for _, c in on_median) >= 2
    _, behind = calibrate_session(session, calibration_depth(session), np.random.default_rng(0))
    for _, calibration in behind:
        assert "poor" not in calibration.markers.grades
        # on the glass, within its noise
        assert np.nanmax(np.abs(calibration.markers.signed_mm)) < 20
