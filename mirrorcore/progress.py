"""Long work in the library: the progress callback's type and the test of a cancel request."""
from __future__ import annotations

from collections.abc import Callable

Progress = Callable[[float], None]   # called with the fraction done, 0 < fraction <= 1


def cancel_requested(cancel) -> bool:
    """True when `cancel` (None, a threading.Event-like object with is_set(), or a callable) asks to stop."""
    if cancel is None:
        return False
    return bool(cancel.is_set() if hasattr(cancel, "is_set") else cancel())
