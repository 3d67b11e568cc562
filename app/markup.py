"""Text for the browser's Markdown and HTML elements. viser renders both with any raw HTML in them
unsanitised, script handlers included, so a mirror named `<img src=x onerror=...>` in a session file
would run its script in the technician's browser. Every Markdown content the tool shows goes through
`markdown`; the HTML elements (legends, marker lists) pass each piece of text through `escape`.
Notifications, labels and buttons are text already.

A file name that is not UTF-8 reaches Python with lone surrogates (os.fsdecode), which viser cannot
send: the tab's connection would close. `markdown` and the notifications pass their text through
`shown` (mirrorcore.io.fields), which puts the replacement character in their place."""

from __future__ import annotations

import re
from html import escape

from mirrorcore.io.fields import shown

__all__ = ["escape", "fold", "fold_under", "markdown", "shown"]

FOLD_TITLE = "Details"


def markdown(text: str) -> str:
    """Markdown `text` with any HTML tag in it shown as text.

    '<' becomes an entity, so that no tag (and no autolink) starts; the rest of the Markdown stays.
    Lone surrogates become U+FFFD (`shown`).

    Parameters
    ----------
    text : str
        Markdown (the tool's own has no HTML).

    Returns
    -------
    str
    """
    return shown(text).replace("<", "&lt;")


def fold(headline: str, details: list[str]) -> str:
    """Markdown: `headline`, then `details` in a collapsed HTML <details> fold.

    viser's Markdown renders the fold.

    Parameters
    ----------
    headline : str
    details : list of str
        Markdown paragraphs, already passed through `markdown`.

    Returns
    -------
    str
        The headline alone without details.
    """
    if not details:
        return headline
    body = "\n\n".join(details)
    return f"{headline}\n\n<details><summary>{FOLD_TITLE}</summary>\n\n{body}\n\n</details>"


def fold_under(headline: str, details: list[str]) -> str:
    """Markdown: `headline` as the title of a collapsed <details> fold of `details`.

    The fold takes no line of its own: a click on the headline opens it.

    Parameters
    ----------
    headline : str
        One line of Markdown of the tool's own; its **bold** is kept, any HTML shown as text.
    details : list of str
        Markdown paragraphs, already passed through `markdown`.

    Returns
    -------
    str
        The headline alone (through `markdown`) without details.
    """
    if not details:
        return markdown(headline)
    title = re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", escape(shown(headline), quote=False))
    body = "\n\n".join(details)
    return f"<details><summary>{title}</summary>\n\n{body}\n\n</details>"

