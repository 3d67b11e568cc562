"""The words of the Mirrors step: the click modes' help, the markers fits (notification, report,
proposal), a mirror's status line and the removal question (the markers' words are in
wording.markers, why buttons are greyed out in wording.greyed)."""

from __future__ import annotations

import numpy as np

from mirrorcore.base.words import listed
from mirrorcore.calibration.markers import GRADES, MAX_SHIFT_MM, MAX_TILT_DEG
from mirrorcore.io.session import SessionMirror

from ..markup import fold_under, markdown
from ..results import Fit, FitsApplied
from . import Message, joined, refinement

# the modes of the Click to buttons, in their hint; Inspect, the default, has no line of its own
CLICK_HINT = ("Inspect: a click on the depth frame reads the pixel. Markers: a click adds or picks "
              "a marker. Boundary: clicks draw the mirror's outline.")
HELP = {
    "inspect": "",
    "markers": "**Markers** mode: click a marker's centre on **{name}** to add it; click an "
    "existing one to pick it.",
    "boundary": "**Boundary** mode: click the corners of **{name}** in order; click the first "
    "again to close.",
    "region": "**Region** mode: drawing the region of interest (Object step).",
}
CLOSED_HELP = ("**Boundary** mode: the outline of **{name}** is closed: click a corner to pick "
               "it, click again to move it, or *Clear boundary* to draw it again.")
NO_GLASS_NOTE = Message(
    "No glass set: **Refine from the object** measures it and moves the plane behind it.",
    (
        "Markers stuck on an ordinary mirror's glass stand 3 to 6 mm in front of its silver, and "
        "a plane on their faces is that much too near.",
    ),
)
PROPOSAL_HEAD = (
    "**Proposal, not applied**: look at it below{crossed}, then apply or discard it (the "
    "calibration "
    "from the object waits for that)."
)
CROSSED = " and at the crossed markers"
FIT_MARKERS = 3  # the markers a plane's fit needs
# small print, inset as the panel's text
SMALL_TEXT = "font-size:0.8em;line-height:1.45;padding:0 12px"


def _why_off(signed_mm: float) -> str:
    """Which way a marker lies off its plane: in front (> 0) or behind."""
    return "in front: hidden by something?" if signed_mm > 0 else "behind: off the glass?"


def concerns(fit: Fit) -> list[str]:
    """Why a fit asks for a look.

    Parameters
    ----------
    fit : Fit
        A markers fit and its review.

    Returns
    -------
    list of str
        A large turn or move, the poor markers, a plane from the object it replaces.
    """
    review, markers, names = fit.review, fit.calibration.markers, fit.mirror.marker_names
    said = []
    if review.moved:
        said.append(
            f"it turns the plane by {review.tilt_deg:.1f}° and moves it {review.shift_mm:.0f} mm "
            f"(more than {MAX_TILT_DEG:g}° or {MAX_SHIFT_MM:g} mm)"
        )
    if review.poor and markers is not None:
        worst = ", ".join(
            f"{names[i]} ({markers.distance_mm[i]:.0f} mm, "
            f"{markers.distance_mm[i] / markers.sigma_mm[i]:.0f}σ, "
            f"{_why_off(markers.signed_mm[i])})"
            for i in review.poor
        )
        said.append(f"marker(s) {worst} lie off the plane beyond the depth noise")
    if fit.replaces_object:
        glass = (
            "; the markers fit uses the glass typed in"
            if fit.mirror.glass_typed
            else ", and set the glass the markers fit now uses"
            if fit.mirror.glass_set
            else ""
        )
        said.append(
            "it replaces the plane found from the object: the markers alone are less accurate (the "
            f"refinement moved it{glass}); refine again after applying"
        )
    return said


def fit_line(fit: Fit, confirmed: bool = False) -> Message:
    """One mirror's markers fit: its RMS and the markers' grades (⚠ the poor ones).

    Parameters
    ----------
    fit : Fit
    confirmed : bool, optional
        The fit is applied on confirmation.

    Returns
    -------
    Message
        The points kept, the farthest marker, the glass and the concerns in the details.
    """
    c, m = fit.calibration, fit.mirror
    head = f"**{m.name}**: plane fitted, {c.rms_mm:.1f} mm RMS"
    details = [f"RMS {c.rms_mm:.2f} mm over {c.n_inliers}/{c.n_points} points."]
    if c.markers is not None:
        grades = c.markers.grades
        head += "; markers: " + ", ".join(
            f"{grades.count(g)} {g}" for g in GRADES if grades.count(g)
        )
        ratio = np.asarray(c.markers.distance_mm) / np.asarray(c.markers.sigma_mm)
        if np.any(np.isfinite(ratio)):
            worst = int(np.nanargmax(ratio))
            details.append(
                f"Farthest: marker {m.marker_names[worst]}, {c.markers.distance_mm[worst]:.1f} mm, "
                f"{ratio[worst]:.1f}σ."
            )
        details.append(
            f"Plane {1e3 * c.marker_offset:.1f} mm behind the markers (the mirror's glass)."
            if c.marker_offset
            else "Plane on the markers' faces (glass 0 mm)."
        )
    if confirmed:
        head += " (applied on confirmation)"
    if fit.review.poor:
        head += (
            f"; ⚠ marker(s) {', '.join(m.marker_names[i] for i in fit.review.poor)} lie off it: "
            "delete "
            "them and fit again"
        )
    details += [f"⚠ {concern}" for concern in concerns(fit)]
    return Message(head, tuple(details))


def fit_report(applied: FitsApplied) -> list[Message]:
    """The report of markers fits.

    Parameters
    ----------
    applied : FitsApplied

    Returns
    -------
    list of Message
        A line per mirror, how to get the glass when a mirror has none set, then what was
        discarded.
    """
    lines = [fit_line(f, f.mirror.id in applied.confirmed) for f in applied.fits]
    if any(not f.mirror.glass_set for f in applied.fits):
        lines.append(NO_GLASS_NOTE)
    if applied.discarded:
        lines.append(
            Message(
                f"{listed(applied.discarded)}: the proposed plane"
                f"{'s' if len(applied.discarded) > 1 else ''} discarded, as before."
            )
        )
    return lines


def proposal(fits: list[Fit]) -> list[Message]:
    """The proposal's lines: each plane against the one it replaces, and why it asks for a look.

    Parameters
    ----------
    fits : list of Fit

    Returns
    -------
    list of Message
    """
    lines = []
    for fit in fits:
        old = (
            "uncalibrated"
            if fit.mirror.plane is None
            else f"turned {fit.review.tilt_deg:.2f}°, moved {fit.review.shift_mm:.1f} mm"
        )
        said = fit_line(fit)
        lines.append(Message(f"**{fit.mirror.name}**: {old}", said.details))
    return lines


def fit_note(
    applied: list[Fit], waiting: list[Fit], without_markers: tuple[str, ...] = ()
) -> Message:
    """A markers fit's notification.

    Parameters
    ----------
    applied : list of Fit
        The planes applied (⚠ those with poor markers).
    waiting : list of Fit
        The proposal waiting for Apply or Discard.
    without_markers : tuple of str, optional
        The mirrors left out for want of markers.

    Returns
    -------
    Message
        The RMS, the glass and the poor markers in the details.
    """
    heads, details = [], []
    if applied:
        poor = [f for f in applied if f.review.poor]
        heads.append(
            f"Applied: {listed(f.mirror.name for f in applied)}"
            + (
                f"; ⚠ {listed(f.mirror.name for f in poor)}: markers off the plane, delete the "
                "crossed "
                "ones and fit again"
                if poor
                else ""
            )
            + "."
        )
        details.append(
            ", ".join(f"{f.mirror.name} {f.calibration.rms_mm:.1f} mm RMS" for f in applied) + "."
        )
        if any(not f.mirror.glass_set for f in applied):
            details.append("Glass 0 mm: Refine from the object measures it.")
        details += [
            f"⚠ {f.mirror.name}: the same markers as before, and marker(s) "
            f"{', '.join(f.mirror.marker_names[i] for i in f.review.poor)} lie off it beyond the "
            "depth "
            "noise: delete them (crossed on the depth frame) and fit again."
            for f in poor
        ]
    if waiting:
        crossed = " (the crossed markers)" if any(f.review.poor for f in waiting) else ""
        names = listed(f.mirror.name for f in waiting)
        heads.append(
            f"A new plane for {names} waits, not applied: look at it under Mirrors{crossed}, then "
            "Apply or Discard it."
            if not (applied or without_markers)
            else f"{names}: a new plane waits, Apply or Discard it."
        )
    if without_markers:
        them = "it is" if len(without_markers) == 1 else "they are"
        heads.append(f"{listed(without_markers)}: no markers, left as {them}.")
        details.append("Click 3 or more markers on each, or Find the planes from the object.")
    if applied and not waiting:
        heads.append("The report is under Mirrors.")
    return Message(" ".join(heads), tuple(details))


def mirror_status(
    mirror: SessionMirror | None, from_object: bool, glass_unused: bool = False
) -> str:
    """One line (Markdown) on a mirror: its plane, its markers' glass and how many markers it has.

    Parameters
    ----------
    mirror : SessionMirror or None
        The mirror; None gives ''.
    from_object : bool
        Its plane is from the object (else calibrated, or none yet).
    glass_unused : bool, optional
        Its glass was typed in after the plane was set, which it does not move.

    Returns
    -------
    str
        The glass is mm in front of the silver: typed in, or measured by a refinement with its
        1 sigma; none without markers. Its colour gain, when it has one, in a fold the line
        opens (refinement.colour_line).
    """
    if mirror is None:
        return ""
    plane = (
        "no plane yet"
        if mirror.plane is None
        else ("plane from the object" if from_object else "plane calibrated")
    )
    if mirror.marker_offset_std is not None:
        glass = (
            f"glass {mirror.marker_offset * 1e3:.1f} ± {mirror.marker_offset_std * 1e3:.1f} mm "
            "measured "
            "(type it in if you know it)"
        )
    elif mirror.glass_typed:
        glass = f"glass {mirror.marker_offset * 1e3:.1f} mm typed in"
    else:
        glass = "glass not measured" if from_object else "no glass set"
    if glass_unused:
        glass += (
            ": the next markers fit uses it, this plane does not depend on it"
            if from_object
            else ", not in the plane yet: **Fit plane** moves it behind the glass"
        )
    count = len(mirror.markers)
    line = " · ".join(
        [plane, *([glass] if count else []), f"{count} marker{'s' if count != 1 else ''}"]
    )
    gain = mirror.colour_gain
    colour = [] if gain is None else [markdown(refinement.colour_line(gain))]
    return fold_under(line, colour)



def removal_question(mirror: SessionMirror) -> str:
    """What removing a mirror takes out of the session, as much as it has, and how to undo it.

    Parameters
    ----------
    mirror : SessionMirror

    Returns
    -------
    str
    """
    count = len(mirror.markers)
    has = (
        ([f"{count} marker{'s' if count != 1 else ''}"] if count else [])
        + (["boundary"] if mirror.boundary else [])
        + (["plane"] if mirror.plane is not None else [])
    )
    what = f"{mirror.name} and its {listed(has)} leave" if has else f"{mirror.name} leaves"
    shows = (
        " What it shows then counts as seen directly: take the mirror out of the camera's view "
        "too, or what "
        "is seen in it stands in the cloud as an object of its own."
        if mirror.boundary
        else ""
    )
    back = "*Undo*, or *Bring back* below the Remove button, brings it back."
    return f"{what} the session.{shows} {back}"


def report_markdown(report) -> str:
    """The report of what left the planes as they are, as a panel's Markdown.

    Parameters
    ----------
    report : CalibrationReport, FitsApplied or None
        As Jobs.report.

    Returns
    -------
    str
    """
    if report is None:
        return ""
    if isinstance(report, FitsApplied):
        return joined(fit_report(report))
    return joined(refinement.report(report))


def removed_note(name: str) -> tuple[str, str]:
    """The note every tab gets when a mirror leaves the session (Remove, Undo or Redo).

    Parameters
    ----------
    name : str
        The mirror's name.

    Returns
    -------
    title, message : str
    """
    return f"{name} removed", f"{name} left the session; Undo in the Mirrors step brings it back."


def outline_taken_note(name: str) -> tuple[str, str]:
    """The note of a tab whose unfinished outline of a mirror another tab's outline replaced.

    Parameters
    ----------
    name : str
        The mirror's name.

    Returns
    -------
    title, message : str
    """
    return (f"Outline of {name} drawn in another tab",
            f"{name} now has the outline drawn in another tab; this tab's unfinished outline of it "
            "is dropped.")


def redo_removal_title(name: str, redo: bool) -> str:
    """The title of the question before an undo or redo that removes a mirror.

    Parameters
    ----------
    name : str
    redo : bool

    Returns
    -------
    str
    """
    return f"{'Redo' if redo else 'Undo'}: remove {name}?"
