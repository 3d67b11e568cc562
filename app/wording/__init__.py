"""The browser's words, in one place: every notification and panel line of the jobs and the Mirrors
step is a Message built here from typed results (mirrorscan.results, mirrorcore's dataclasses),
never parsed back. A Message leads with a headline of at most HEADLINE_WORDS words (what happened,
what to do); the figures behind it go in its details, which a panel shows in a collapsed fold and a
notification leaves out."""

from __future__ import annotations

import re
from dataclasses import dataclass

from ..markup import fold, markdown

HEADLINE_WORDS = 25  # the most words a headline may have
_WORD = re.compile(r"[\w±.+-]*[A-Za-z0-9][\w±.,+-]*")


def words(text: str) -> int:
    """The words of `text` a reader counts: runs holding a letter or a digit.

    Markdown marks, arrows and '⚠' are not words.

    Parameters
    ----------
    text : str

    Returns
    -------
    int
    """
    return len(_WORD.findall(text))


@dataclass(frozen=True)
class Message:
    """A headline and the details behind it.

    Attributes
    ----------
    headline : str
        Markdown, at most HEADLINE_WORDS words.
    details : tuple of str
        Markdown lines.
    """

    headline: str
    details: tuple[str, ...] = ()

    def markdown(self) -> str:
        """The headline, then the details in a collapsed fold (markup.fold).

        Any HTML in the text is shown as text.
        """
        return fold(markdown(self.headline), [markdown(line) for line in self.details])

    @property
    def plain(self) -> str:
        """The headline without Markdown emphasis, for a notification (its body is plain text)."""
        return self.headline.replace("**", "").replace("*", "").replace("`", "")


def joined(messages: list[Message]) -> str:
    """Several messages as one panel's Markdown, a paragraph each.

    Parameters
    ----------
    messages : list of Message

    Returns
    -------
    str
    """
    return "\n\n".join(m.markdown() for m in messages)


def refusal(reason: str, where: str = "") -> Message:
    """A refused action: its reason as the headline when short enough.

    Otherwise the headline is the words before the reason's first parenthesis, semicolon or colon
    (cut at HEADLINE_WORDS), and the whole reason goes in the details.

    Parameters
    ----------
    reason : str
        Why the action was refused.
    where : str, optional
        Where more is said, appended to the headline.

    Returns
    -------
    Message
    """
    if words(reason) <= HEADLINE_WORDS:
        return Message(reason)
    head = reason
    for mark in (" (", "; ", ": "):
        if mark in head and words(head.split(mark)[0]) >= 3:
            head = head.split(mark)[0]
        if words(head) <= HEADLINE_WORDS:
            break
    if words(head) > HEADLINE_WORDS:
        head = " ".join(head.split()[: HEADLINE_WORDS - 2]) + " …"
    return Message(f"{head}{'; ' + where if where else ''}.", (reason,))
