"""What `mirrorscan calibrate` prints: planes fitted, found or refined, their glass, and the
mirrors' colour gains."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mirrorcore.base.words import listed
from mirrorcore.calibration.colourgain import MIN_PAIRS, OUT_OF_RANGE, TOO_FEW_PAIRS, MirrorGain
from mirrorcore.calibration.fit import Calibration
from mirrorcore.calibration.markers import GRADES
from mirrorcore.calibration.results import METHOD_BIAS, NOISE_EXPLAINS, SAME_GLASS_MM, SAME_PLANE
from mirrorcore.calibration.refine import MirrorRefinement

from .message import Message, plane_figures


def fitted(name: str, fit: Calibration, marker_names: list[str] | None = None) -> Message:
    """A plane fitted to a mirror's markers or its region (calibrate --method markers|region).

    Parameters
    ----------
    name : str
        The mirror's name.
    fit : Calibration
        The fit; without markers it was fitted to the region.
    marker_names : list of str, optional
        The markers' names; by default they are numbered from 1.

    Returns
    -------
    Message
        The headline names a marker lying off the plane; the details give the plane, its RMS
        (mm), the markers' grades, the farthest marker (mm and σ) and the glass (mm).
    """
    details = [
        f"plane {plane_figures(fit.plane.abcd)}",
        f"RMS {fit.rms_mm:.2f} mm over {fit.n_inliers} of {fit.n_points} points",
    ]
    if fit.markers is None:
        return Message(f"{name}: plane fitted to its region.", tuple(details))
    grades = fit.markers.grades
    counts = ", ".join(f"{grades.count(g)} {g}" for g in GRADES if grades.count(g))
    poor = [marker_names[i] if marker_names else str(i + 1) for i in fit.markers.poor()]
    headline = f"{name}: plane fitted to its {len(grades)} markers; " + (
        f"marker {listed(poor)} lies off it: check the click or move the marker."
        if poor
        else "they agree with it."
    )
    ratio = np.asarray(fit.markers.distance_mm) / np.asarray(fit.markers.sigma_mm)
    details.append(f"markers: {counts}")
    if np.any(np.isfinite(ratio)):
        worst = int(np.nanargmax(ratio))
        label = marker_names[worst] if marker_names else str(worst + 1)
        details.append(
            f"farthest: marker {label}, {fit.markers.distance_mm[worst]:.1f} mm from the plane "
            f"({ratio[worst]:.1f}σ)"
        )
    details.append(
        f"glass: plane {1e3 * fit.marker_offset:.1f} mm behind the markers"
        if fit.marker_offset
        else "glass: 0 mm, the plane on the markers' faces"
    )
    return Message(headline, tuple(details))


def refined(report: MirrorRefinement, searched: bool, saved: bool) -> Message:
    """A plane refined, or found by calibrate --method scene.

    Parameters
    ----------
    report : MirrorRefinement
        What the refinement did to the mirror.
    searched : bool
        The plane was found (calibrate --method scene) rather than refined.
    saved : bool
        The glass measured is written (False: the session holds it already).

    Returns
    -------
    Message
        Whether the view agrees with the others within the depth noise, then the plane, its move,
        the agreement before and after (mm), the noise, the 1σ, what was compared and the glass.
    """
    verdict = (
        "it agrees with the other views as well as the depth noise allows."
        if report.agreement_after_mm <= NOISE_EXPLAINS * report.noise_mm
        else "its view disagrees with the others beyond the depth noise: check its outline."
    )
    headline = f"{report.name}: plane {'found' if searched else 'refined'}; {verdict}"
    details = [f"plane {plane_figures(report.after.abcd)}"]
    if searched:
        details.append(
            f"agreement with the other views: RMS {report.agreement_after_mm:.2f} mm, mean "
            f"{report.offset_after_mm:+.2f} mm"
        )
    else:
        details += [
            f"moved {report.shift_mm:+.2f} mm at the object (> 0: away from the camera) and "
            f"{report.tilt_deg:.3f}°",
            f"agreement with the other views: RMS {report.agreement_before_mm:.2f} mm before, "
            f"{report.agreement_after_mm:.2f} mm after; mean {report.offset_before_mm:+.2f} mm "
            f"before, {report.offset_after_mm:+.2f} mm after",
        ]
    details.append(f"depth noise alone: {report.noise_mm:.2f} mm RMS over the frames used")
    details.append(f"known to ±{report.shift_std_mm:.2f} mm and ±{report.tilt_std_deg:.3f}° (1σ)")
    details += _compared(report)
    glass = _glass(report, saved)
    return Message(headline, tuple(details + ([glass] if glass else [])))


def _compared(report: MirrorRefinement) -> list[str]:
    """What the refinement compared, and what the method may add beyond the 1σ."""
    if report.sphere_radius_mm is not None:
        bias = METHOD_BIAS["sphere"]
        return [
            f"compared: the centres of the sphere (radius {report.sphere_radius_mm:.1f} mm) seen "
            "directly and in the mirror",
            f"the method may add {1e3 * bias.shift:.1f} mm and {bias.tilt_deg:.2f}°",
        ]
    bias, ball = METHOD_BIAS["surfaces"], METHOD_BIAS["sphere"]
    whom = (
        "the camera"
        if report.agreements == report.camera_agreements
        else f"the camera and the mirrors that fix it ({report.camera_agreements:,} with the "
        "camera)"
    )
    return [
        f"compared: {report.agreements:,} points seen both ways with {whom}",
        f"the method may add up to {1e3 * bias.shift:.1f} mm and {bias.tilt_deg:.2f}°; a ball in "
        f"every view {1e3 * ball.shift:.1f} mm",
    ]


def _glass(report: MirrorRefinement, saved: bool) -> str | None:
    """The glass the markers show in front of the refined plane, or None without usable markers."""
    if report.marker_offset is None:
        return None
    markers = (
        f"markers {1e3 * report.marker_offset:.1f} ± {1e3 * report.marker_offset_std:.1f} mm in "
        "front of the"
    )
    if report.glass_typed is not None:
        return (
            f"glass: {markers} refined plane; its glass stays {1e3 * report.glass_typed:.1f} mm, "
            "as typed in"
        )
    return f"glass: {markers} silver ({'saved as its glass' if saved else 'its glass already'})"


def unchanged(path: Path) -> Message:
    """A refinement that moved no plane and no glass by more than nothing (Refinement.changed).

    Parameters
    ----------
    path : Path
        The session file, not written.

    Returns
    -------
    Message
    """
    return Message(
        "nothing changed: the planes and the glass are already where this object puts them; "
        f"{path} not written.",
        (f"within {SAME_PLANE[0]} mm, {SAME_PLANE[1]}° and {SAME_GLASS_MM} mm of glass",),
    )


def markers_unused(names: list[str]) -> Message:
    """After calibrate --method scene: the mirrors found with markers, which set only their glass.

    Parameters
    ----------
    names : list of str
        Those mirrors' names.

    Returns
    -------
    Message
    """
    planes = "its plane was" if len(names) == 1 else "their planes were"
    return Message(
        f"{listed(names)}: {planes} found from the object alone; the markers only read the glass.",
        ("--method markers fits the planes to the markers",),
    )


def colour_gain(measured: MirrorGain, frames: int) -> Message:
    """A mirror's colour gain measured by calibrate (or why not).

    Parameters
    ----------
    measured : MirrorGain
        The mirror's result.
    frames : int
        The frames it was measured on.

    Returns
    -------
    Message
        What the mirror reflects of each channel, then the pairs it rests on and their spread.
    """
    pairs = (
        f"from {measured.pairs} pairs of its points with the other views' over {frames} "
        f"frame{'s' if frames != 1 else ''} ({measured.with_camera} with the camera's; "
        f"{measured.trimmed} left out across the texture's edges)"
    )
    if measured.gain is None:
        why = {
            TOO_FEW_PAIRS: "too little of the object is seen both in it and in another view",
            OUT_OF_RANGE: "the pairs make it reflect more than all of the light",
        }.get(measured.reason, measured.reason)
        return Message(
            f"{measured.name}: colour gain not measured: {why}; its colours stay as they are.",
            (pairs, f"at least {MIN_PAIRS} pairs needed"),
        )
    spread = " / ".join(f"{100 * s:.1f}" for s in measured.spread)
    return Message(
        f"{measured.name}: colour gain measured; its points show the scene's own colour.",
        (
            "reflects " + " / ".join(f"{100 * g:.1f}" for g in measured.gain)
            + " % of red / green / blue",
            pairs,
            f"one pair's spread: {spread} %",
        ),
    )
