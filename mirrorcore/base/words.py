"""Things in words, for the one-line messages and labels a user reads."""
from __future__ import annotations

from collections.abc import Iterable


def listed(words: Iterable[str], conjunction: str = "and") -> str:
    """List words in a phrase: 'a', 'a and b', 'a, b and c' ('' for none).

    Parameters
    ----------
    words : iterable of str
        The words.
    conjunction : str
        The last joint: 'a, b or c' with 'or'.

    Returns
    -------
    str
        The phrase.
    """
    words = list(words)
    return ", ".join(words[:-1]) + f" {conjunction} " + words[-1] if len(words) > 1 else "".join(
        words)


def sentences(reasons: Iterable[str]) -> str:
    """Join one-line reasons as one line of sentences, each once, in order: 'a. b.'

    Parameters
    ----------
    reasons : iterable of str
        The reasons, with or without a final full stop.

    Returns
    -------
    str
        The sentences.
    """
    return " ".join(f"{reason.rstrip('.')}." for reason in dict.fromkeys(reasons))
