"""Things in words, for the one-line messages and labels a user reads."""
from __future__ import annotations

from collections.abc import Iterable


def listed(words: Iterable[str], conjunction: str = "and") -> str:
    """'a', 'a and b', 'a, b and c' ('' for none); 'a, b or c' with conjunction 'or'."""
    words = list(words)
    return ", ".join(words[:-1]) + f" {conjunction} " + words[-1] if len(words) > 1 else "".join(
        words)


def sentences(reasons: Iterable[str]) -> str:
    """One-line reasons as one line of sentences, each once, in order: 'a. b.'"""
    return " ".join(f"{reason.rstrip('.')}." for reason in dict.fromkeys(reasons))
