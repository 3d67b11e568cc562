"""The words of the views' agreement: a mirror's line, the list of them and the note on the
mirrors whose views disagree, built from their typed results."""

from __future__ import annotations

import numpy as np

from mirrorcore.base.words import listed
from mirrorcore.calibration.results import CAMERA_MEAN_EXPLAINS, MEAN_EXPLAINS, NOISE_EXPLAINS
from mirrorcore.calibration.fixing import MIN_AGREEMENTS
from mirrorcore.calibration.residuals import ViewAgreement, reads_as_glass

from ..results import AgreementReport, MirrorAgreement
from . import Message

NO_AGREEMENT = Message(
    "No mirror has a plane yet, so no view can be compared: fit the planes from markers, or "
    "find them from the object."
)
CHECKING = Message("Checking how the views agree…")

def doubt(found: ViewAgreement) -> str:
    """Which comparisons of a mirror go beyond the depth noise.

    The camera's alone single out a tilted plane: the comparisons between two mirrors put a tilt
    or an offset of one on both.

    Parameters
    ----------
    found : ViewAgreement
        The mirror's comparisons with the other views.

    Returns
    -------
    str
        'camera' when its comparisons with the camera (MIN_AGREEMENTS or more) go beyond the noise
        (their RMS beyond NOISE_EXPLAINS times it, or their mean beyond CAMERA_MEAN_EXPLAINS
        times), 'mirrors' when only all its comparisons together do (MEAN_EXPLAINS for their
        mean), else ''.
    """

    def beyond(rms: float, mean: float, noise: float, share: float) -> bool:
        return rms > NOISE_EXPLAINS * noise or abs(mean) > share * noise

    if found.camera_points >= MIN_AGREEMENTS and beyond(
        found.camera_rms_mm, found.camera_mean_mm, found.camera_noise_mm, CAMERA_MEAN_EXPLAINS
    ):
        return "camera"
    return "mirrors" if beyond(found.rms_mm, found.mean_mm, found.noise_mm, MEAN_EXPLAINS) else ""


def disagrees(found: ViewAgreement) -> bool:
    """Whether an agreement line warns of the mirror (enough comparisons, beyond the noise).

    Parameters
    ----------
    found : ViewAgreement

    Returns
    -------
    bool
    """
    return found.points >= MIN_AGREEMENTS and bool(doubt(found))


def _over(found: ViewAgreement) -> str:
    """'on one frame' or 'over N frames'."""
    return "on one frame" if found.frames == 1 else f"over {found.frames} frames"


def _apart(value: float, limit: float) -> tuple[str, str]:
    """Two figures (mm) to 0.1, or to 0.01 where they would read the same."""
    places = 2 if f"{value:.1f}" == f"{limit:.1f}" else 1
    return f"{value:.{places}f}", f"{limit:.{places}f}"


def _step(found: ViewAgreement) -> str:
    """How a refinement step would move the plane (the figures behind the advice)."""
    return (
        f"A refinement step would move it {found.step_shift_mm:+.1f} mm (> 0: away from the "
        f"camera) and turn it {found.step_tilt_deg:.2f}°."
    )


def agreement_line(line: MirrorAgreement, glass: bool = False) -> Message:
    """One mirror's agreement with the other views against what the depth noise explains.

    A mirror that disagrees with the camera may be tilted or have its boundary off; one that
    agrees with the camera but not with another mirror has a plane off along its normal (its own
    or another's). Fewer than MIN_AGREEMENTS comparisons judge nothing. A mirror is sent to its
    glass only when the measurement reads as glass (`glass`, residuals.reads_as_glass; an offset
    along the normal the lines' RMS and mean hardly show) and its plane comes from markers; a
    flagged mirror otherwise to the refinement.

    Parameters
    ----------
    line : MirrorAgreement
    glass : bool
        The views' disagreement reads as glass over the markers of every markers fit.

    Returns
    -------
    Message
    """
    name, found = line.name, line.found
    if not found.points or not np.isfinite(found.rms_mm):
        return Message(
            f"{name}: nothing of the object is seen both in it and by another view: put the object "
            "in "
            "view to check it."
        )
    if found.points < MIN_AGREEMENTS:
        return Message(
            f"{name}: too little is seen both in it and by another view to judge its plane: move "
            "the object where both see it.",
            (
                f"{found.points:,} points seen both ways {_over(found)}, {MIN_AGREEMENTS} needed; "
                "a person "
                "or a sphere seen from the side serves; or check its markers' grades.",
            ),
        )
    kind = doubt(found)
    if glass and line.by_markers:
        warn = "⚠ " if kind else ""
        return Message(
            f"{name}: {warn}its plane reads too near, as glass over the markers makes it: set each "
            "mirror's glass and fit again.",
            (
                f"RMS {found.rms_mm:.1f} mm against {found.noise_mm:.1f} mm of depth noise, mean "
                f"{found.mean_mm:+.1f} mm, {found.points:,} points {_over(found)}.",
                _step(found) + " Every plane from markers moves back alike: the glass's "
                "thickness. Refine from the object measures it.",
            ),
        )
    if kind == "camera":
        rms, noise = _apart(found.camera_rms_mm, found.camera_noise_mm)
        check = "markers" if line.by_markers else "boundary"
        return Message(
            f"{name}: ⚠ disagrees with the camera: its plane may be tilted or its boundary off. "
            f"Refine from the object, or check its {check}.",
            (
                f"Its points lie {found.camera_mean_mm:+.1f} mm from the camera's surface on "
                "average "
                f"(good planes within {CAMERA_MEAN_EXPLAINS * found.camera_noise_mm:.1f} mm); RMS "
                f"{rms} "
                f"mm, the depth noise {noise} mm; {found.camera_points:,} points seen both ways "
                f"{_over(found)}.",
                *((_step(found),) if np.isfinite(found.step_shift_mm) else ()),
            ),
        )
    if kind == "mirrors":
        head = (
            f"{name}: ⚠ agrees with the camera, not with the other mirrors: a plane is off along "
            "its "
            "normal. Refine from the object."
            if found.camera_points >= MIN_AGREEMENTS
            else f"{name}: ⚠ disagrees with the other mirrors: a plane is off. Refine from the "
            "object."
        )
        limit = MEAN_EXPLAINS * found.noise_mm
        rms, noise = _apart(found.rms_mm, found.noise_mm)
        details = [
            f"Its points lie {found.mean_mm:+.1f} mm from theirs on average (good planes within "
            f"{limit:.1f} mm); RMS {rms} mm against {noise} mm of depth noise; {found.points:,} "
            "points "
            f"seen both ways {_over(found)}."
        ]
        if found.camera_points >= MIN_AGREEMENTS:
            details.append(f"Against the camera: mean {found.camera_mean_mm:+.1f} mm.")
        if np.isfinite(found.step_shift_mm):
            details.append(_step(found))
        return Message(head, tuple(details))
    return Message(
        f"{name}: agrees with the other views as the depth noise explains.",
        (
            f"{found.rms_mm:.1f} mm RMS {_over(found)}; the depth noise there {found.noise_mm:.1f} "
            "mm; mean "
            f"{found.mean_mm:+.1f} mm over {found.points:,} points seen both ways.",
        ),
    )


def agreement(report: AgreementReport) -> list[Message]:
    """The agreement lines, a mirror each; NO_AGREEMENT when no mirror has a plane.

    Parameters
    ----------
    report : AgreementReport

    Returns
    -------
    list of Message
    """
    glass = reads_as_glass(
        [m.found for m in report.mirrors if m.by_markers],
        [m.found for m in report.mirrors if not m.by_markers],
    )
    return [agreement_line(m, glass) for m in report.mirrors] or [NO_AGREEMENT]


def disagreement_note(names: tuple[str, ...]) -> Message:
    """The notification naming the mirrors the agreement lines flag.

    Parameters
    ----------
    names : tuple of str

    Returns
    -------
    Message
    """
    views = "its view disagrees" if len(names) == 1 else "their views disagree"
    return Message(
        f"{listed(names)}: ⚠ {views} with the others beyond the depth noise; why and what to do "
        "are "
        "under Mirrors."
    )
