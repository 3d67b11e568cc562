"""The words of a calibration from the object (a refinement, or a search without markers), built
from its typed results."""

from __future__ import annotations

from mirrorcore.base.words import listed
from mirrorcore.calibration.colourgain import MIN_PAIRS, NO_PLANE, ColourGains
from mirrorcore.calibration.results import (
    METHOD_BIAS, NOISE_EXPLAINS,
)
from mirrorcore.calibration.refine import MirrorRefinement

from ..results import (
    CalibrationReport,
    CalibrationWork,
    FramesUsed,
    NotFound,
)
from . import Message, refusal

CANCELLED = Message("Cancelled: the planes are as they were.")
GLASS_WHERE = "Mirrors › Rename, glass, remove, clear"


def method_bias(compared: str, better: bool = True) -> str:
    """What a way of comparing may add beyond the planes' 1σ.

    Parameters
    ----------
    compared : str
        "surfaces" or "sphere".
    better : bool, optional
        For the surfaces, also say what does better.

    Returns
    -------
    str
    """
    bias = METHOD_BIAS[compared]
    if compared == "sphere":
        return f"the method may add {1e3 * bias.shift:.1f} mm and {bias.tilt_deg:.2f}°"
    ball = (
        f", a ball in every view only {1e3 * METHOD_BIAS['sphere'].shift:.1f} mm" if better else ""
    )
    return f"the method may add {1e3 * bias.shift_low:.0f} to {1e3 * bias.shift:.0f} mm{ball}"


def frames_used(used: FramesUsed) -> str:
    """The frames a calibration read, in words.

    Parameters
    ----------
    used : FramesUsed
        The frames picked, and the recording's frame count (None: live frames).

    Returns
    -------
    str
        'the last 5 live frames', 'frames 0, 4 and 9 of the recording's 10 (numbered as in the
        header)'.
    """
    if used.count is None:
        return (
            "the last live frame"
            if len(used.picks) == 1
            else f"the last {len(used.picks)} live frames"
        )
    if used.count == 1:
        return "the recording's only frame"
    which = (
        f"frame {used.picks[0]}"
        if len(used.picks) == 1
        else f"frames {', '.join(map(str, used.picks))}"
    )
    return f"{which} of the recording's {used.count} (numbered as in the header)"


def working(work: CalibrationWork) -> Message:
    """A calibration from the object under way.

    Parameters
    ----------
    work : CalibrationWork

    Returns
    -------
    Message
    """
    doing = "Finding the planes" if work.search else "Refining the planes"
    return Message(f"{doing} from the object…", (f"Over {frames_used(work.used)}.",))


def signed(mm: float) -> str:
    """Millimetres to 0.1 with their sign, '0.0' when they round to nothing.

    Parameters
    ----------
    mm : float

    Returns
    -------
    str
    """
    return f"{mm:+.1f}" if round(mm, 1) != 0 else "0.0"


def _glass_measured(report: CalibrationReport) -> bool:
    """Whether a mirror's glass was measured from its markers, not typed in."""
    return any(r.marker_offset is not None and r.glass_typed is None for r in report.mirrors)


def headline(report: CalibrationReport) -> Message:
    """The calibration's headline: what it did and what to do now (Undo, the glass).

    Parameters
    ----------
    report : CalibrationReport

    Returns
    -------
    Message
        The frames, the sign convention and the method's bias in the details.
    """
    used = f"Over {frames_used(report.used)}."
    if not report.changed:
        return Message(
            "Nothing changed: the planes and the glass already fit this object (no undo step).",
            (used, "Undo still takes back the step before."),
        )
    sphere = " from the sphere's centres" if report.compared == "sphere" else ""
    bias = f"Beyond the 1σ of each plane, {method_bias(report.compared)}."
    if report.search:
        head = f"Planes found{sphere} (no markers): check the agreement below. Undo takes them back"
        if report.not_found:
            names = listed(m.name for m in report.not_found)
            head = (
                f"Planes found{sphere}; ⚠ {names} not found (why below). "
                "Undo takes the planes found back"
            )
            found = listed(r.name for r in report.mirrors)
            details = (
                used,
                f"Undo goes by mirror: select {found} to take the planes found back.",
                bias,
            )
            return Message(f"{head}.", details)
        return Message(f"{head}.", (used, bias))
    details = [used, "A move > 0 is away from the camera.", bias]
    glass = ""
    if report.compared == "surfaces" and _glass_measured(report):
        glass = " Glass measured: type it in if you know it (how: in the details)."
        details.append(
            f"Type it in under {GLASS_WHERE}. The glass is measured on these planes, which "
            f"{method_bias('surfaces', better=False).removeprefix('the method ')}: an ordinary "
            "mirror's is "
            "3 to 6 mm. Typed in, the markers fit uses it; a refinement keeps it, and its planes "
            "do "
            "not depend on it."
        )
    return Message(
        f"Planes refined{sphere}. Undo restores the previous planes.{glass}", tuple(details)
    )


def mirror_line(r: MirrorRefinement, search: bool, saved: bool = True) -> Message:
    """One refined (or found) mirror: its move and whether its view agrees within the noise.

    Parameters
    ----------
    r : MirrorRefinement
        What the calibration did to the mirror.
    search : bool
        The plane was found (no markers) rather than refined.
    saved : bool, optional
        The glass read from the markers is saved as the mirror's glass.

    Returns
    -------
    Message
        The figures before and after, how well the data fix it and its glass in the details.
    """
    agrees = r.agreement_after_mm <= NOISE_EXPLAINS * r.noise_mm
    moved = "" if search else f" moved {signed(r.shift_mm)} mm and {r.tilt_deg:.2f}°;"
    verdict = (
        "its view agrees with the others as the depth noise allows."
        if agrees
        else "⚠ its view agrees less well than the depth noise explains: check its boundary."
    )
    done = "found" if search else "refined"
    if search:
        figures = f"RMS {r.agreement_after_mm:.2f} mm, mean {r.offset_after_mm:+.2f} mm"
    else:
        figures = (
            f"RMS {r.agreement_before_mm:.2f} mm before, {r.agreement_after_mm:.2f} mm after; mean "
            f"{r.offset_before_mm:+.2f} mm before, {r.offset_after_mm:+.2f} mm after"
        )
    details = [f"{figures}; the depth noise alone gives {r.noise_mm:.2f} mm RMS."]
    if not search:
        details.append(
            f"Moved {r.shift_mm:+.2f} mm (> 0: away from the camera) and {r.tilt_deg:.3f}°."
        )
    if r.sphere_radius_mm is None:
        whom = (
            "the camera"
            if r.agreements == r.camera_agreements
            else f"the camera and the mirrors that fix it, {r.camera_agreements:,} with the camera"
        )
        seen = f"{r.agreements:,} points seen both ways with {whom}"
        how = f"{method_bias('surfaces')}; {seen}"
    else:
        how = (
            f"from the centres of the sphere (radius {r.sphere_radius_mm:.1f} mm) seen directly "
            "and in it; "
            f"{method_bias('sphere')}"
        )
    details.append(
        f"The data fix it to ±{r.shift_std_mm:.2f} mm and ±{r.tilt_std_deg:.3f}° (1σ; {how})."
    )
    if r.marker_offset is not None:
        read = f"{1e3 * r.marker_offset:.1f} ± {1e3 * r.marker_offset_std:.1f} mm"
        details.append(
            f"Markers {read} in front of the refined plane; its glass stays "
            f"{1e3 * r.glass_typed:.1f} mm, as typed in."
            if r.glass_typed is not None
            else f"Glass: markers {read} in front of the silver "
            f"({'saved as its glass' if saved else 'its glass already'})."
        )
    return Message(f"**{r.name}** {done}:{moved} {verdict}", tuple(details))


def not_found_line(missing: NotFound) -> Message:
    """A mirror a search could not find: its plane stays.

    Parameters
    ----------
    missing : NotFound

    Returns
    -------
    Message
        The library's why in the details.
    """
    return Message(
        f"**{missing.name}** ⚠ not found: its plane is as it was (why in the details).",
        (missing.why,),
    )


def report(result: CalibrationReport) -> list[Message]:
    """The report of a calibration from the object: its headline, then a line per mirror.

    Parameters
    ----------
    result : CalibrationReport

    Returns
    -------
    list of Message
        The headline, a line per mirror calibrated, then one per mirror not found.
    """
    lines = [headline(result)]
    lines += [mirror_line(r, result.search, result.changed) for r in result.mirrors]
    lines += [not_found_line(m) for m in result.not_found]
    if result.gains is not None:
        lines.append(gains_line(result.gains))
    return lines


def colour_line(gain: tuple[float, float, float]) -> str:
    """A mirror's colour gain, for its details fold.

    Parameters
    ----------
    gain : (float, float, float)
        SessionMirror.colour_gain.

    Returns
    -------
    str
        'colour 84 / 88 / 86 % (the red, green and blue it reflects; ...)'.
    """
    percent = " / ".join(f"{100 * g:.0f}" for g in gain)
    return (
        f"colour {percent} % (the red, green and blue it reflects; its points are corrected by "
        "it)"
    )


def gains_line(gains: ColourGains) -> Message:
    """The colour gains a calibration from the object measured on frames with colour.

    Parameters
    ----------
    gains : ColourGains

    Returns
    -------
    Message
        Which mirrors have their gain; per mirror its percentages, the pairs it rests on and
        their spread, or why not measured, in the details.
    """
    done = [m.name for m in gains.mirrors if m.gain is not None]
    missed = [m.name for m in gains.mirrors if m.gain is None and m.reason != NO_PLANE]
    heads = []
    if done:
        heads.append(f"Colour gain measured for {listed(done)}: their points show the scene's "
                     "own colour.")
    if missed:
        heads.append(f"Colour gain not measured for {listed(missed)}: see the details.")
    details = []
    for m in gains.mirrors:
        if m.gain is not None:
            details.append(
                f"{m.name}: colour {' / '.join(f'{100 * g:.1f}' for g in m.gain)} % from "
                f"{m.pairs} pairs ({m.with_camera} with the camera's), one pair's spread "
                f"{' / '.join(f'{100 * v:.1f}' for v in m.spread)} %")
        elif m.reason != NO_PLANE:
            details.append(f"{m.name}: {m.pairs} pairs, {MIN_PAIRS} needed ({m.reason})")
    return Message(" ".join(heads) or "No colour gain measured.", tuple(details))


def note(result: CalibrationReport) -> Message:
    """The calibration's notification: its headline, and where the report is.

    Parameters
    ----------
    result : CalibrationReport

    Returns
    -------
    Message
    """
    head = headline(result).headline
    return Message(f"{head} The report is under Mirrors.")


def undone(result: CalibrationReport, verb: str) -> Message:
    """After an undo or redo of the calibration `result`: what was undone or redone.

    Parameters
    ----------
    result : CalibrationReport
    verb : str
        'Undone' or 'Redone', the headline's first word.

    Returns
    -------
    Message
    """
    what = "found" if result.search else "refined"
    names = listed(r.name for r in result.mirrors)
    return Message(f"{verb}: the planes {what} from the object for {names}.")


def calibration_refused(reason: str, mirrors: tuple[str, ...], search: bool) -> Message:
    """A calibration from the object refused.

    Parameters
    ----------
    reason : str
        The library's reason.
    mirrors : tuple of str
        The names the refusal is about; empty for a refusal of the whole.
    search : bool
        The calibration was a search (no markers).

    Returns
    -------
    Message
    """
    if mirrors:
        what = "not found from the object" if search else "not refined from the object"
        return Message(
            f"{listed(mirrors)} {what}: the planes are as they were; why and what to do are in the "
            "details.",
            (reason,),
        )
    return refusal(reason, "the planes are as they were")


# ------------------------------------------------------------------------------------------
# agreement
