"""The refinement's wording (mirrorscan.wording.refinement): a refined mirror's line, agreement
lines for mirrors not overlapped, seen too little or worse than the noise, the frames used."""


from mirrorscan.results import CalibrationReport, FramesUsed
from mirrorscan.wording import refinement as calibration_words
from mirrorscan.wording.refinement import frames_used

from mirrorcore.calibration.residuals import ViewAgreement
from tests.app.support import line, refined


def test_a_refined_mirrors_line_says_no_sign_for_a_shift_that_rounds_to_nothing():
    """Beside the details' "-0.02 mm", the headline says "moved 0.0 mm", not "+0.0"."""
    assert calibration_words.mirror_line(
        refined(shift_mm=-0.02, tilt_deg=0.05), False
    ).headline.startswith("**left** refined: moved 0.0 mm and 0.05°;")
    said = calibration_words.mirror_line(refined(shift_mm=-1.47, tilt_deg=0.05), False)
    assert said.headline.startswith("**left** refined: moved -1.5 mm and 0.05°;")
    assert "Moved -1.47 mm (> 0: away from the camera) and 0.050°." in said.details
    # typed in: kept, said so
    typed = calibration_words.mirror_line(refined(glass_typed=0.003), False)
    assert (
        "Markers 0.5 ± 1.2 mm in front of the refined plane; its glass stays 3.0 mm, as typed in."
        in typed.details
    )
    sphere = CalibrationReport(
        (refined(sphere_radius_mm=115.0),), False, "sphere", True, FramesUsed((0,))
    )
    # no glass advice from a sphere
    head = calibration_words.headline(sphere)
    assert (
        head.headline
        == "Planes refined from the sphere's centres. Undo restores the previous planes."
    )
    assert "Beyond the 1σ of each plane, the method may add 0.3 mm and 0.04°." in head.details
    found = calibration_words.mirror_line(refined(sphere_radius_mm=115.0), True)
    assert (
        found.headline.startswith("**left** found: its view agrees")
        and "moved" not in found.headline
    )
    assert any("from the centres of the sphere (radius 115.0 mm)" in d for d in found.details)


def test_a_mirror_that_no_other_view_overlaps_is_said_so_not_nan():
    said = line("left", ViewAgreement(1.234, -0.16, 1200, 1.3))
    assert said.headline == "left: agrees with the other views as the depth noise explains."
    assert said.details == (
        "1.2 mm RMS on one frame; the depth noise there 1.3 mm; mean -0.2 mm "
        "over 1,200 points "
        "seen both ways.",
    )
    assert (
        "1.2 mm RMS over 5 frames;"
        in line("left", ViewAgreement(1.234, -0.16, 1200, 1.3, frames=5)).details[0]
    )
    nan = float("nan")
    assert (
        "put the object in view to check it"
        in line("left", ViewAgreement(nan, nan, 0, nan)).headline
    )


def test_a_mirror_seen_too_little_by_the_others_is_not_judged():
    """Fewer comparisons than fix a plane in the refinement judge nothing; few with the camera leave
    the judgement to those with the mirrors."""
    few = line("left", ViewAgreement(30.0, -9.0, 150, 11.7, 30.0, -9.0, 9.0, 26, frames=5))
    assert few.headline.startswith(
        "left: too little is seen both in it and by another view to judge its plane"
    )
    assert few.details[0].startswith("150 points seen both ways over 5 frames, 200 needed")
    # the middle mirror of an arc
    arc = ViewAgreement(10.0, 0.5, 7565, 11.7, 30.0, -9.0, 9.0, 42, frames=5)
    assert line("middle", arc).headline.startswith("middle: agrees with the other views")
    off = line("middle", arc._replace(mean_mm=-4.0))
    assert (
        off.headline
        == "middle: ⚠ disagrees with the other mirrors: a plane is off. Refine from the object."
    )
    assert off.details[0] == (
        "Its points lie -4.0 mm from theirs on average (good planes within "
        "3.5 mm); RMS "
        "10.0 mm against 11.7 mm of depth noise; 7,565 points seen both ways "
        "over 5 frames."
    )


def test_a_mirror_that_agrees_worse_than_the_noise_is_flagged_and_the_one_at_fault_singled_out():
    """The comparisons with the camera single out the mirror at fault; one that agrees with the
    camera but not with another mirror says so instead of being told to fix itself."""
    good_camera = dict(
        camera_rms_mm=5.0, camera_mean_mm=0.5, camera_noise_mm=9.0, camera_points=800
    )
    tilted = line("left", ViewAgreement(12.0, 3.0, 900, 11.7, 8.0, -4.0, 9.0, 800))  # 0.44 x 9 mm
    assert tilted.headline == (
        "left: ⚠ disagrees with the camera: its plane may be tilted or its "
        "boundary off. "
        "Refine from the object, or check its markers."
    )
    assert tilted.details == (
        "Its points lie -4.0 mm from the camera's surface on average (good "
        "planes within "
        "3.6 mm); RMS 8.0 mm, the depth noise 9.0 mm; 800 points seen both "
        "ways on one "
        "frame.",
    )
    assert (
        "RMS 9.04 mm, the depth noise 9.00 mm"
        in line("left", ViewAgreement(10.0, 0.5, 900, 11.7, 9.04, 0.5, 9.0, 800)).details[0]
    )
    # the mean: 0.34 x
    neighbour = line("right", ViewAgreement(10.1, -4.0, 900, 11.7, **good_camera))
    assert neighbour.headline == (
        "right: ⚠ agrees with the camera, not with the other mirrors: a "
        "plane is off "
        "along its normal. Refine from the object."
    )
    assert neighbour.details[0].startswith(
        "Its points lie -4.0 mm from theirs on average (good planes within 3.5 mm); RMS 10.1 mm"
    )
    assert "Against the camera: mean +0.5 mm." in neighbour.details
    # the glass only when the step measures it (tests/app/wording/test_agreement.py)
    assert not any("glass" in d for d in neighbour.details)
    stepped = line("right", ViewAgreement(10.1, -4.0, 900, 11.7, **good_camera, step_shift_mm=-1.26,
                                          step_tilt_deg=0.031))
    assert stepped.details[-1] == (
        "A refinement step would move it -1.3 mm (> 0: away from the camera) and turn it 0.03°."
    )
    # a plane found from the object is not sent to its markers or its glass
    assert line(
        "left", ViewAgreement(12.0, 3.0, 900, 11.7, 8.0, -4.0, 9.0, 800), False
    ).headline.endswith("Refine from the object, or check its boundary.")
    found = line("right", ViewAgreement(10.1, -4.0, 900, 11.7, **good_camera), False)
    assert not any("glass" in d for d in found.details)
    assert (
        "RMS 15.2 mm against 11.7 mm of depth noise"
        in line("right", ViewAgreement(15.2, 0.4, 900, 11.7, **good_camera)).details[0]
    )
    assert line("right", ViewAgreement(10.1, -3.0, 900, 11.7, **good_camera)).headline.startswith(
        "right: agrees with the other views"
    )
    # without figures against the camera alone, all the comparisons are judged together
    assert (
        "⚠ disagrees with the other mirrors: a plane is off"
        in line("right", ViewAgreement(15.2, 0.4, 900, 11.7)).headline
    )


def test_the_frames_a_calibration_used_are_said_plainly():
    """A recording's only frame, one frame, several frames, the last live frames."""
    assert frames_used(FramesUsed((0,), 1)) == "the recording's only frame"
    assert (
        frames_used(FramesUsed((3,), 8))
        == "frame 3 of the recording's 8 (numbered as in the header)"
    )
    assert frames_used(FramesUsed((0, 4, 9), 10)) == (
        "frames 0, 4, 9 of the recording's 10 (numbered as in the header)"
    )
    assert frames_used(FramesUsed((0, 1, 2, 3, 4))) == "the last 5 live frames"
    assert frames_used(FramesUsed((0,))) == "the last live frame"
