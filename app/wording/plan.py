"""The words of the plan served in the browser (`mirrorscan plan --serve`): the figures of the
layout, the key of the subject's colours, and what Optimise, Save plan and Simulate did."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mirrorcore.plan.coverage import Coverage, view_name

from ..markup import escape
from . import Message
from .legend import LEGEND_STYLE, _swatch

# the subject's points by how many views see them: 0, 1, 2, 3 or more (Okabe-Ito's vermilion,
# yellow, bluish green, blue)
COUNT_COLOURS = np.array([[213, 94, 0], [240, 228, 66], [0, 158, 115], [0, 114, 178]], np.uint8)
COUNT_NAMES = ("unseen", "1 view", "2 views", "3+ views")
TITLE = "Plan the rig"
CANCELLED = "Search cancelled: the layout is as it was."
SEARCHING = "the search runs from the layout as it was (wait for it, or cancel it)"
HELP = ("Drag a mirror's arrows to move it on the floor, its ring to turn it. "
        "*Optimise* searches from this layout.")


def figures(cov: Coverage, seconds: float | None = None) -> Message:
    """The layout's coverage: the headline, then each view's share and noise.

    Parameters
    ----------
    cov : Coverage
    seconds : float, optional
        How long its evaluation took.

    Returns
    -------
    Message
    """
    head = (f"**{cov.coverage:.1%}** of the subject seen, **{cov.coverage_2:.1%}** by two views "
            "or more")
    rows = ["| view | sees | noise |", "|---|---|---|"]
    for view, share, noise in zip(cov.views, cov.per_view, cov.noise_mm()):
        said = "-" if np.isnan(noise) else f"{noise:.1f} mm"
        rows.append(f"| {view_name(view)} | {share:.1%} | {said} |")
    details = ("\n".join(rows),)
    if seconds is not None:
        details += (f"Evaluated on {len(cov.weight):,} surface samples in "
                    f"{seconds * 1e3:.0f} ms.",)
    return Message(head, details)


def legend_html() -> str:
    """The key of the subject's colours (HTML)."""
    swatches = "".join(_swatch(c, escape(n)) for c, n in zip(COUNT_COLOURS, COUNT_NAMES))
    return f'<div style="{LEGEND_STYLE}">Subject by views seeing it: {swatches}</div>'


def refused(reason: str) -> Message:
    """A move the limits refuse: the mirror is put back."""
    return Message(f"Not moved: {reason}. The mirror is back where it was.")


def optimised(before: float, after: float, seconds: float) -> Message:
    """The search from the layout done."""
    return Message(f"Optimised: coverage {before:.1%} → {after:.1%}.",
                   (f"The search took {seconds:.0f} s.",))


def saved(folder: Path, files: list[Path]) -> Message:
    """The plan folder written."""
    return Message(f"Plan saved in `{folder}`.",
                   (", ".join(f"`{f.name}`" for f in files),))


def simulating(url: str, uncalibrated: str | None) -> Message:
    """Where the simulated rig of the layout is served; why its planes are not fitted, if not."""
    link = f"The simulated rig of this layout: [open it]({url})"
    if uncalibrated is None:
        return Message(f"{link}, its mirrors calibrated from their markers.")
    return Message(f"{link}. Its markers do not give the planes: it uses the simulator's true "
                   "planes.", (uncalibrated,))
