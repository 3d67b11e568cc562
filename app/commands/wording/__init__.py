"""What the `mirrorscan` commands print, built from the library's typed results.

Every message is a headline of at most HEADLINE_WORDS words (what happened, what to do), then the
figures behind it, which the commands print indented under it with `-v/--verbose` (message).

The messages of each command are in a module of their own (calibration, reconstruction,
accuracy); all are named here.
"""

from __future__ import annotations

from .accuracy import colour_error, no_scene_colour, plane_error, shape_fitted, surface_error
from .calibration import fitted, markers_unused, refined, unchanged
from .message import HEADLINE_WORDS, INDENT, Message, plane_figures, show
from .planning import plan_written
from .reconstruction import (
    batch_done,
    carved_written,
    cloud_written,
    colours_line,
    frame_list,
    mesh_written,
    retried,
)

__all__ = [
    "HEADLINE_WORDS",
    "INDENT",
    "Message",
    "batch_done",
    "carved_written",
    "cloud_written",
    "colour_error",
    "colours_line",
    "fitted",
    "frame_list",
    "markers_unused",
    "mesh_written",
    "no_scene_colour",
    "plan_written",
    "plane_error",
    "plane_figures",
    "refined",
    "retried",
    "shape_fitted",
    "show",
    "surface_error",
    "unchanged",
]
