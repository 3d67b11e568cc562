"""Long work in the library: the progress callback's type, the test of a cancel request, and a bar
that never goes back (Ratchet)."""
from __future__ import annotations

import time
from collections.abc import Callable

Progress = Callable[[float], None]   # called with the fraction done, 0 < fraction <= 1


def cancel_requested(cancel) -> bool:
    """Tell whether `cancel` asks to stop.

    Parameters
    ----------
    cancel : None, threading.Event-like or callable
        An object with ``is_set()``, or a callable returning a truth value.

    Returns
    -------
    bool
        True when it asks to stop; False for None.
    """
    if cancel is None:
        return False
    return bool(cancel.is_set() if hasattr(cancel, "is_set") else cancel())


# a throttled Ratchet passes on at most one fraction this often, and the end
RATCHET_SECONDS = 0.1


class Ratchet:
    """A progress callback that never goes back, for work that guesses its parts' shares.

    A part that took longer than its share holds the bar until the work catches up, where the bar
    would have gone back. Throttled, it passes on at most one fraction every `seconds`, and the end.

    Parameters
    ----------
    progress : Progress or None
        The callback passed on to.
    seconds : float
        The least time between two fractions passed on, in seconds (0: no throttle).

    Attributes
    ----------
    shown : float
        The last fraction passed on.
    when : float
        When it was passed on (time.monotonic seconds).
    """

    def __init__(self, progress: Progress | None, seconds: float = 0.0):
        self.progress, self.seconds, self.shown, self.when = progress, seconds, 0.0, float("-inf")

    def __call__(self, fraction: float) -> None:
        now = time.monotonic()
        if self.progress is not None and fraction > self.shown and (
            now - self.when >= self.seconds or fraction >= 1.0):
            self.shown, self.when = fraction, now
            self.progress(fraction)

    def part(self, start: float, end: float) -> Progress:
        """Return the Progress of a part of the work.

        Parameters
        ----------
        start, end : float
            The fractions of the whole at which the part starts and ends.

        Returns
        -------
        Progress
            Called with the part's fraction done.
        """
        return lambda f: self(start + (end - start) * f)
