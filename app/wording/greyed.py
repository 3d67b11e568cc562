"""Why buttons and choices are greyed out, in the panel's small print: the Mirrors step's buttons,
the colour control's true colour."""

from __future__ import annotations

from mirrorcore.base.words import listed
from mirrorcore.io.session import Session, SessionMirror

from ..markup import escape
from .mirrors import FIT_MARKERS, SMALL_TEXT


def greyed_out(
    session: Session,
    selected: SessionMirror | None,
    refused: dict[int, str],
    undo_elsewhere: tuple[str, ...] = (),
) -> str:
    """Why Fit plane, Fit all planes, Refine from the object, Find and Undo are greyed out.

    The fits' reasons only while a plane is missing.

    Parameters
    ----------
    session : Session
    selected : SessionMirror or None
        The selected mirror.
    refused : dict of int to str
        As Jobs.refusals.
    undo_elsewhere : tuple of str, optional
        The other mirrors with a change to undo while the selected one has none.

    Returns
    -------
    str
        Small print (HTML, names escaped), '' when nothing is greyed out.
    """
    if not session.mirrors:
        return ""
    reasons = []
    if selected is not None and selected.plane is None and len(selected.markers) < FIT_MARKERS:
        reasons.append(
            f"<b>Fit plane</b>: {escape(selected.name)} has {len(selected.markers)} of the "
            f"{FIT_MARKERS} markers it needs"
        )
    missing = any(m.plane is None for m in session.mirrors)
    if missing and not any(len(m.markers) >= FIT_MARKERS for m in session.mirrors):
        reasons.append(f"<b>Fit all planes</b>: no mirror has {FIT_MARKERS} markers")
    if all(m.plane is None for m in session.mirrors):
        reasons.append("<b>Refine</b>: no mirror has a plane yet")
    bare = [m for m in session.mirrors if m.boundary and m.plane is None]
    if bare and all(refused.get(m.id) == "scene" for m in bare):
        names = escape(listed([m.name for m in bare]))
        reasons.append(
            f"<b>Find</b>: {names} not found as {'it is' if len(bare) == 1 else 'they are'} (why: "
            "in the report below); offered again once an outline or a marker changes"
        )
    if undo_elsewhere and selected is not None:
        reasons.append(
            f"<b>Undo</b>: nothing to take back on {escape(selected.name)}; select "
            f"{escape(listed(undo_elsewhere, 'or'))} for "
            f"{'its' if len(undo_elsewhere) == 1 else 'their'} changes"
        )
    if not reasons:
        return ""
    return (
        f'<div style="{SMALL_TEXT};color:#666;padding-bottom:0.4em">Greyed out: '
        + " · ".join(reasons)
        + "</div>"
    )


def true_colour_greyed(source: str) -> str:
    """Why the colour control offers no true colour: the source gives no colour image.

    Parameters
    ----------
    source : str
        The source's name.

    Returns
    -------
    str
        Small print (HTML, the name escaped).
    """
    return (
        f'<div style="{SMALL_TEXT};color:#666;padding:0 12px 0.4em">Greyed out: '
        f"<b>true colour</b>: {escape(source)} has no colour image, so the points show their "
        "source's colour</div>"
    )
