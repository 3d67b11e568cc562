"""The status header's legend (HTML): the points per source, or, while the heat map shows, its key
and each mirror view's figures."""

from __future__ import annotations

from typing import Callable

import numpy as np

from mirrorcore.base.palette import (
    FIRST_MULTI_LABEL,
    HEAT_NEGATIVE,
    HEAT_POSITIVE,
    HEAT_UNCOMPARED,
    HEAT_ZERO,
    SOURCE_COLOURS,
    source_colour,
    source_name,
)
from mirrorcore.base.words import listed
from mirrorcore.io.session import Session

from ..jobs.heat import HEAT_LIMIT_MM
from ..markup import escape

# the panel's text is inset so; raw HTML is not
LEGEND_STYLE = "font-size:0.85em;line-height:1.5;padding:0 12px"


def source_names(session: Session) -> Callable[[int], str]:
    """A source label's name with the session's mirror names: 'direct', 'left then right'.

    Parameters
    ----------
    session : Session

    Returns
    -------
    callable
        The name of a source label.
    """
    names = [m.name for m in session.mirrors]
    return lambda label: source_name(label, names)


def legend_html(
    counts: dict[int, int],
    name: Callable[[int], str],
    mirror_ids: tuple[int, ...],
    unplaned: tuple[str, ...] = (),
    true_colour: bool = False,
    no_gain: tuple[str, ...] = (),
) -> str:
    """One line: a swatch in each source's colour, its name and its point count.

    In true colour, the sources' names and counts without swatches, after a head saying that the
    points show the scene's colour (each mirror's tint undone when there are mirrors and every one
    has its gain), then the mirrors whose tint is not undone. Then the mirrors with no plane yet,
    whose part of the frame is left out.

    Parameters
    ----------
    counts : dict of int to int
        {label: points}.
    name : callable
        A source label's name.
    mirror_ids : tuple of int
        The mirrors' ids, which set the sources' colours.
    unplaned : tuple of str, optional
        The names of the mirrors with no plane yet.
    true_colour : bool, optional
        The points show the colour the camera saw.
    no_gain : tuple of str, optional
        In true colour, the names of the mirrors with no colour gain yet.

    Returns
    -------
    str
        HTML.
    """
    if true_colour:
        undone = bool(mirror_ids) and not no_gain
        # the mirrors with no gain follow the counts in the same run of text: fewer lines above
        # the steps' buttons
        items = (TRUE_COLOUR_HEAD if undone else TRUE_COLOUR_PLAIN) + " · ".join(
            [
                f'<span style="white-space:nowrap">{escape(name(j))} <b>{count:,}</b></span>'
                for j, count in counts.items()
            ]
            + ([f"{escape(listed(no_gain))}: {NO_GAIN}"] if no_gain else [])
        )
    else:
        items = "".join(
            _swatch(source_colour(j, mirror_ids), f"{escape(name(j))} <b>{count:,}</b>")
            for j, count in counts.items()
        )
    if unplaned:
        items += (
            f"<br>{escape(listed(unplaned))}: no plane yet, so all inside "
            f"{'its outline' if len(unplaned) == 1 else 'their outlines'} is left out "
            "(the object in front too)"
        )
    return f'<div style="{LEGEND_STYLE}">{items}</div>'


# the true-colour legend's head, its head with no mirror or while a mirror has no colour gain, and
# what it says of those mirrors
TRUE_COLOUR_HEAD = "<b>True colour</b>, each mirror's tint undone by its colour gain: "
TRUE_COLOUR_PLAIN = "<b>True colour</b>: "
NO_GAIN = "no colour gain yet (the glass's tint shows)"

HEAT_KEY = (
    (HEAT_ZERO, "on the direct surface"),
    (HEAT_POSITIVE, f"{HEAT_LIMIT_MM:g} mm outside"),
    (HEAT_NEGATIVE, f"{HEAT_LIMIT_MM:g} mm inside"),
    (SOURCE_COLOURS[0], "the camera's points"),
    (HEAT_UNCOMPARED, "not seen by the camera"),
)


# what the map can show, as measured on the glass sphere (seed 1, ten frames: README) and on a box
# between three mirrors (seed 2), and what measures the glass
HEAT_READS = (
    "A tilted plane or a wrong boundary colours a mirror's points; a glass hardly does (3 mm read "
    "0.2 mm on the sphere)"
)
HEAT_GLASS = ": <b>Refine from the object</b> measures it."
HEAT_REFINED = "; these planes come from the object, where the glass plays no part."
# a view with fewer of its points compared than this is told where it is checked
HEAT_FEW = 0.05
FEW_COMPARED = (
    " (it sees little of what the camera sees: its agreement under Mirrors compares it with every "
    "view)"
)
FEW_COMPARED_MULTI = (
    " (seen through several mirrors: the agreement lines of those mirrors under Mirrors check it)"
)


def heat_legend_html(
    figures: dict[int, tuple[float, float]],
    frames: int,
    name: Callable[[int], str],
    refined: bool = False,
    planes: bool = True,
    no_glass: bool = True,
) -> str:
    """The heat map's key (its colours) and, per view seen in a mirror, its figures.

    Per view, the median distance to the direct surface and the share of its points compared over
    the heat maps of the last `frames` frames, against the camera's surface (the agreement lines
    beside it compare every view); then what the map can show (HEAT_READS) and what measures the
    glass.

    Parameters
    ----------
    figures : dict of int to (float, float)
        As in HeatChanged: {label: (median mm, share compared)}; empty until the first map
        arrives.
    frames : int
        The heat maps pooled.
    name : callable
        A source label's name.
    refined : bool, optional
        Every plane came from the refinement: say that it measured the glass.
    planes : bool, optional
        False when no mirror has a plane: say what to do first instead.
    no_glass : bool, optional
        A plane from markers has no glass set: say that the refinement measures it.

    Returns
    -------
    str
        HTML.
    """
    if not planes:
        return (
            f'<div style="{LEGEND_STYLE}">No mirror has a plane yet: the heat map compares the '
            "points seen in a "
            "mirror with the camera's surface. Fit the planes from markers, or find them from the "
            "object "
            "(Mirrors).</div>"
        )
    key = "".join(_swatch(colour, text) for colour, text in HEAT_KEY)

    # a view through several mirrors has no agreement line of its own
    def few(j: int) -> str:
        return FEW_COMPARED_MULTI if j >= FIRST_MULTI_LABEL else FEW_COMPARED

    lines = [
        f"{escape(name(j))}: median {median:+.1f} mm, {_share(share)} of its points compared"
        + (few(j) if share < HEAT_FEW else "")
        if np.isfinite(median)
        else f"{escape(name(j))}: none of its points seen by the camera{few(j)}"
        for j, (median, share) in figures.items()
    ]
    over = "this frame" if frames == 1 else f"the last {frames} frames"
    body = (
        "<br>".join([f"{over}, against the camera's surface (> 0: outside it):", *lines])
        if figures
        else "computing the heat map…"
    )
    reads = HEAT_READS + (HEAT_REFINED if refined else HEAT_GLASS if no_glass else ".")
    return f'<div style="{LEGEND_STYLE}">{key}<br>{body}<br><i>{reads}</i></div>'


def _share(share: float) -> str:
    """A share of a view's points, as a percentage: 'under 1%' for a few (not '0%')."""
    return f"{share:.0%}" if share >= 0.005 else "under 1%"


def _swatch(colour, text: str) -> str:
    """A square in `colour` before `text`, kept on one line (HTML)."""
    r, g, b = (int(c) for c in colour)
    return (
        '<span style="white-space:nowrap;margin-right:0.8em"><span '
        'style="display:inline-block;width:0.8em;'
        f"height:0.8em;background:rgb({r},{g},{b});margin-right:0.3em;border-radius:50%;"
        f'border:1px solid #999"></span>{text}</span>'
    )
