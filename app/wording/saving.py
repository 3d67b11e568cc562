"""The words of saving: a session that cannot be saved (the lasting notification, the header, the
Session step) and one open read-only because another program edits it."""

from __future__ import annotations

from pathlib import Path

from . import Message

NOT_SAVED = "Session not saved"
READ_ONLY = "Session open read-only"


def unsaved(root: str | Path, error: str) -> Message:
    """What is said while saving fails: the edits are in memory, and what to do.

    Parameters
    ----------
    root : str or Path
        The session's folder.
    error : str
        Why the save failed: 'PATH: reason'.

    Returns
    -------
    Message
    """
    reason = error.rsplit(": ", 1)[-1]
    return Message(f"Not saved ({reason}): edits are kept in memory and saved when the disk "
                   "allows; free space, or *Save elsewhere* below.",
                   (f"folder `{root}`", f"error: {error}"))


def read_only(why: str) -> Message:
    """What is said of a session open read-only.

    Parameters
    ----------
    why : str
        Who edits it (SessionLocked's message).

    Returns
    -------
    Message
    """
    return Message("**Read-only**: another program edits this session, so every edit is refused; "
                   "*Save elsewhere* below edits a copy.", (why,))


def header_state(error: str | None, why_read_only: str | None) -> str:
    """What the header adds to its title about saving: '' while every edit is saved.

    Parameters
    ----------
    error : str or None
        Why saving fails.
    why_read_only : str or None
        Why the session is open read-only.

    Returns
    -------
    str
        Markdown.
    """
    if why_read_only is not None:
        return " · ⚠ **read-only**: another program edits it"
    if error is not None:
        return " · ⚠ **not saved**: edits kept in memory"
    return ""


def saving_note(editor) -> tuple[str, str, str] | None:
    """The notification that stays on every tab while the session is not saved or is read-only.

    Parameters
    ----------
    editor : mirrorscan.editing.EditorCore

    Returns
    -------
    tuple of str or None
        (title, plain text, kind); None while every edit is saved.
    """
    if editor.read_only is not None:
        return READ_ONLY, read_only(editor.read_only).plain, "warning"
    if editor.last_save_error is not None:
        return NOT_SAVED, unsaved(editor.session.root, editor.last_save_error).plain, "error"
    return None
