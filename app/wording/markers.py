"""The words of a mirror's markers: the note on a marker clicked where it cannot serve, and the
list of the markers with their distances to the plane."""

from __future__ import annotations

import numpy as np

from mirrorcore.io.session import SessionMirror

from ..markup import escape
from . import Message
from .mirrors import SMALL_TEXT


def no_depth_note() -> Message:
    """A marker clicked where the camera reads nothing."""
    return Message(
        "the camera reads nothing there in the recent frames: a fit cannot use it (click the "
        "sticker's centre; Undo takes it back)"
    )


def marker_off_note(mirror: str, signed_mm: float, sigma_mm: float) -> Message:
    """A marker clicked far off its mirror's plane: how far (mm and σ) and on which side.

    Parameters
    ----------
    mirror : str
        The mirror's name.
    signed_mm : float
        Its distance to the plane (mm); > 0: in front of it, behind something.
    sigma_mm : float
        The depth noise there (mm).

    Returns
    -------
    Message
    """
    where = (
        "behind something in front of the mirror"
        if signed_mm > 0
        else "off the glass (on the object seen in it?)"
    )
    return Message(
        f"{abs(signed_mm):.0f} mm ({abs(signed_mm) / sigma_mm:.0f}σ) from {mirror}'s plane: "
        f"{where}. "
        "Undo takes it back; a fit would ask first."
    )


def _dot(grade: str, colours: dict[str, str]) -> str:
    """A round dot in the grade's colour (HTML)."""
    return (
        '<span style="display:inline-block;width:0.7em;height:0.7em;border-radius:50%;margin:0 '
        "0.25em;"
        f'background:{colours[grade]}"></span>'
    )


def marker_list(
    mirror: SessionMirror | None, residuals, picked: int | None, colours: dict[str, str]
) -> str:
    """Every marker of the mirror with its distance to the plane and the noise there (HTML).

    Each in its grade's colour, as its centre on the depth frame; a poor one says which way it is
    off.

    Parameters
    ----------
    mirror : SessionMirror or None
    residuals : MarkerResiduals or None
        The markers' grades and distances; None lists their pixels.
    picked : int or None
        The picked marker (0-based), in bold.
    colours : dict of str to str
        Grade -> CSS colour.

    Returns
    -------
    str
        '' when the mirror has no markers.
    """
    if mirror is None or not mirror.markers:
        return ""
    rows = []
    for k, (u, v) in enumerate(mirror.markers):
        name = escape(mirror.marker_name(k))
        if k == picked:
            name = f"<b>{name}</b>"
        if residuals is None:
            rows.append(_dot("unknown", colours) + f"{name} ({u:.0f}, {v:.0f})")
            continue
        grade, d, s = residuals.grades[k], residuals.signed_mm[k], residuals.sigma_mm[k]
        text = "no depth" if not np.isfinite(d) else f"{abs(d):.1f} mm ({abs(d) / s:.1f}σ)"
        if grade == "poor":
            text += " (hidden by something in front?)" if d > 0 else " (off the glass?)"
        rows.append(_dot(grade, colours) + f"{name} {text}")
    legend = (
        ""
        if residuals is None
        else (
            f"{_dot('good', colours)}within 2σ of the plane {_dot('fair', colours)}3σ "
            f"{_dot('poor', colours)}beyond (σ: the depth noise at the marker)"
        )
    )
    return (
        f'<div style="{SMALL_TEXT}">{legend}<br>'
        + " · ".join(f'<span style="white-space:nowrap">{r}</span>' for r in rows)
        + "</div>"
    )
