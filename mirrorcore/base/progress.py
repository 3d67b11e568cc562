"""Long work in the library: the progress callback's type, the test of a cancel request, and a bar
that never goes back (Ratchet)."""
from __future__ import annotations

import time
from collections.abc import Callable

Progress = Callable[[float], None]   # called with the fraction done, 0 < fraction <= 1


def cancel_requested(cancel) -> bool:
    """True when `cancel` (None, a threading.Event-like object with is_set(), or a callable) asks to
    stop."""
    if cancel is None:
        return False
    return bool(cancel.is_set() if hasattr(cancel, "is_set") else cancel())


# a throttled Ratchet passes on at most one fraction this often, and the end
RATCHET_SECONDS = 0.1


class Ratchet:
    """`progress` (or None) that never goes back, for work that guesses its parts' shares: a part
    that took longer than its share holds the bar until the work catches up, where the bar would
    have gone back. Throttled (`seconds`), it passes on at most one fraction that often, and the end
    (a search's candidates reported 380 times in 17 s)."""

    def __init__(self, progress: Progress | None, seconds: float = 0.0):
        self.progress, self.seconds, self.shown, self.when = progress, seconds, 0.0, float("-inf")

    def __call__(self, fraction: float) -> None:
        now = time.monotonic()
        if self.progress is not None and fraction > self.shown and (
            now - self.when >= self.seconds or fraction >= 1.0):
            self.shown, self.when = fraction, now
            self.progress(fraction)

    def part(self, start: float, end: float) -> Progress:
        """A Progress of a part of the work that runs from `start` to `end` of the whole."""
        return lambda f: self(start + (end - start) * f)
