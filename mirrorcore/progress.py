"""Long work in the library: the progress callback's type and the test of a cancel request."""
from __future__ import annotations

from collections.abc import Callable

Progress = Callable[[float], None]   # called with the fraction done, 0 < fraction <= 1


def cancel_requested(cancel) -> bool:
    """True when `cancel` (None, a threading.Event-like object with is_set(), or a callable) asks to stop."""
    if cancel is None:
        return False
    return bool(cancel.is_set() if hasattr(cancel, "is_set") else cancel())


class Ratchet:
    """`progress` (or None) that never goes back, for work that guesses its parts' shares: a part that took longer
    than its share holds the bar until the work catches up, where the bar would have gone back."""

    def __init__(self, progress: Progress | None):
        self.progress, self.shown = progress, 0.0

    def __call__(self, fraction: float) -> None:
        if self.progress is not None and fraction > self.shown:
            self.shown = fraction
            self.progress(fraction)

    def part(self, start: float, end: float) -> Progress:
        """A Progress of a part of the work that runs from `start` to `end` of the whole."""
        return lambda f: self(start + (end - start) * f)
