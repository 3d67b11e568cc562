"""Step 1, "Mirrors": add and select mirrors, click their boundaries and markers on the depth frame,
fit their planes. Every marker is listed and coloured by its distance to the plane against the depth
noise; a single marker can be picked, moved or deleted; a fit that would move a calibrated plane a
lot, or that markers disagree with, is a proposal shown beside the plane it would replace and
applied only on confirmation, and so is a markers fit that would replace a plane found from the
object. Undo and redo are per mirror."""

from __future__ import annotations

from .panel import TITLE, MirrorsPanel

__all__ = ["TITLE", "MirrorsPanel"]
