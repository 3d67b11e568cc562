"""Things in words, for the one-line messages and labels a user reads."""
from __future__ import annotations

from collections.abc import Iterable


def listed(words: Iterable[str]) -> str:
    """'a', 'a and b', 'a, b and c' ('' for none)."""
    words = list(words)
    return ", ".join(words[:-1]) + " and " + words[-1] if len(words) > 1 else "".join(words)
