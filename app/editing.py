"""The machinery under the session editor: the session held under a lock, autosave, changes made
to session.json by another program, and undo and redo.

session.json may also be written by another program while the tool edits it (`mirrorscan calibrate
SESSION` in a terminal): the editor never saves over such a change. It reloads the file
(`reload_if_changed`, which the server calls twice a second) and refuses an edit that would have
been saved over it, naming what happened.

Several browser tabs edit one session: an edit made inside `guards.made_on(session)` (a tab's
action, with the session as that tab drew it) is refused (`guards.StaleEdit`) when what it
changes (the mirror, or the session's own scope) is no longer as drawn. The check, the change and
the save are one step under the editor's lock.

`EditorCore` holds no edit of its own: `SessionEditor` (mirrorscan.editor) defines them, each
decorated with `edits`.
"""
from __future__ import annotations

import functools
import threading
from dataclasses import replace
from typing import Callable

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.session import Session, SessionMirror
from mirrorcore.io.sessionfile import check_session

from .guards import StaleEdit, check_drawn, drawn_moves_to
from .history import HistoryView
from .sessionfile import SavedEdits, SessionFile
from .undo import SESSION_SCOPE, History, Step, inverse, restore, touched


def edits(method):
    """Run an editing method under the editor's lock; tell the listeners when it changed something.

    The listeners are called outside the lock, so that a listener may take its own locks in any
    order.

    Parameters
    ----------
    method : callable
        A method of EditorCore.

    Returns
    -------
    callable
        The wrapped method. It raises MirrorscanError, and the session is reloaded, when another
        program changed session.json since the editor read or wrote it; StaleEdit when it is
        made on a drawing (`guards.made_on`) that what it changes no longer matches.
    """

    @functools.wraps(method)
    def wrapper(self: "EditorCore", *args, **kwargs):
        changed = False
        try:
            with self._lock:
                try:
                    self._writable()
                    message, reloaded = self._reload_external()
                    if reloaded:
                        raise MirrorscanError(f"{message}; this change was not made: make it again")
                    result = method(self, *args, **kwargs)
                    drawn_moves_to(self._session)
                    return result
                finally:
                    session, changed, self._changed = self._session, self._changed, False
        finally:
            if changed:
                self._tell(session)
    return wrapper


class EditorCore(SavedEdits, HistoryView):
    """A session under edit: its lock, undo history, autosave and listeners.

    Parameters
    ----------
    session : Session
        The session to edit.
    autosave : bool, optional
        Save it after every change; its folder is then locked until `close`.
    read_only : str, optional
        Why it is open read-only (another program edits it): its folder is not locked and every
        edit is refused with this reason.

    Attributes
    ----------
    autosave : bool
        Save it after every change.
    listeners : list of callable
        Called with the session after every change, and when saving fails or works again.
    read_only : str or None
        As given; None once another session is opened.

    Raises
    ------
    SessionLocked
        Another editor (in this process or another) holds the session's folder.
    """

    def __init__(self, session: Session, autosave: bool = True, read_only: str | None = None):
        self._lock = threading.RLock()
        self._session = session
        self._history = History()
        self.autosave = autosave
        self.read_only = read_only
        self.listeners: list[Callable[[Session], None]] = []
        self._changed = False
        self._file = SessionFile(session, lock=autosave and read_only is None)

    @property
    def session(self) -> Session:
        """The session as it now is."""
        with self._lock:
            return self._session

    def mirror(self, mirror_id: int) -> SessionMirror:
        """The mirror with this id.

        Parameters
        ----------
        mirror_id : int

        Returns
        -------
        SessionMirror

        Raises
        ------
        MirrorscanError
            When it is no longer in the session.
        """
        with self._lock:
            return self._session.mirrors[self._index(mirror_id)]

    def replace_session(self, session: Session) -> None:
        """Open another session, autosaved (the undo history is dropped), and tell the listeners.

        Its folder is locked (see `claim`), the previous one's let go.

        Parameters
        ----------
        session : Session

        Raises
        ------
        SessionLocked
            Another editor holds its folder; nothing changed.
        """
        with self._lock:
            self._file.take(session)
            self._open(session)
            self.autosave, self.read_only = True, None
            self._changed = False
        self._tell(session)

    def reload_if_changed(self) -> str:
        """Reload session.json when another program changed it since the editor read or wrote it.

        Returns
        -------
        str
            What happened, one line; '' when nothing did. See `_reload_external`.
        """
        with self._lock:
            message, reloaded = self._reload_external()
            session, self._changed = self._session, False
        if reloaded:
            self._tell(session)
        return message

    def _tell(self, session: Session) -> None:
        """Call every listener with the session."""
        for listener in list(self.listeners):
            listener(session)

    def _open(self, session: Session) -> None:
        """Take the session with a new undo history, as the file holds it."""
        self._session, self._history = session, History()
        self._file.written(session)

    def _reload_external(self) -> tuple[str, bool]:
        """Reload an autosaved session's session.json when another program changed it.

        The undo history, which describes the file before, is dropped.

        Returns
        -------
        message : str
            What happened, one line ('' when the file is unchanged; see
            `SessionFile.external_change`).
        reloaded : bool
            Whether the session was reloaded.
        """
        if not self.autosave:
            return "", False
        message, session = self._file.external_change(self._session)
        if session is None:
            return message, False
        self._open(session)
        self._changed = True
        return message, True

    # ------------------------------------------------------------------ undo and redo
    @edits
    def undo(self, scope: int) -> str:
        """Take back the last change in a scope.

        Parameters
        ----------
        scope : int
            A mirror id, or SESSION_SCOPE.

        Returns
        -------
        str
            The change's label.

        Raises
        ------
        MirrorscanError
            When there is nothing to undo.
        """
        return self._travel(scope, redo=False)

    @edits
    def redo(self, scope: int) -> str:
        """Make again the last change undone in a scope.

        Parameters
        ----------
        scope : int
            A mirror id, or SESSION_SCOPE.

        Returns
        -------
        str
            The change's label.

        Raises
        ------
        MirrorscanError
            When there is nothing to redo.
        """
        return self._travel(scope, redo=True)

    def _travel(self, scope: int, redo: bool) -> str:
        """Move the last step of `scope`, with its group, to the other history.

        Its `after` (redo) or `before` (undo) is put back.
        """
        label = self._label(scope, redo)
        ids = [m.id for m in self._session.mirrors]
        for s, step in self._history.peek(scope, redo, ids):
            check_drawn(self._session, touched(s, step.after if redo else step.before))
        moved = self._history.travel(scope, redo, ids)
        if not moved:
            raise MirrorscanError(f"nothing to {'redo' if redo else 'undo'}")
        for s, step in moved:
            self._session = restore(self._session, s, step.after if redo else step.before)
        self._save_and_notify()
        return label

    def _index(self, mirror_id: int) -> int:
        """The mirror's position in the session; StaleEdit when it is gone."""
        for i, m in enumerate(self._session.mirrors):
            if m.id == mirror_id:
                return i
        raise StaleEdit(f"mirror {mirror_id} is no longer in the session "
                        "(removed in another tab?)")

    def _set_mirror(self, mirror_id: int, label: str, group: int = 0, what: str = "",
                    save: bool = True, **changes) -> None:
        """Change fields of one mirror as an undo step of its own scope."""
        index = self._index(mirror_id)
        before = self._session.mirrors[index]
        after = replace(before, **changes)
        self._commit(mirror_id, Step(label, before, after, group, what),
                     self._session.with_mirror(index, after), save)

    def _change(self, label: str, change: tuple, session: Session) -> None:
        """Make a change of the session's own (SESSION_SCOPE).

        `change` is (kind, a, b), see `undo.restore` and `undo.inverse`.
        """
        self._commit(SESSION_SCOPE, Step(label, inverse(change), change), session)

    def _commit(self, scope: int, step: Step, session: Session, save: bool = True) -> None:
        """Record an undo step and take the session, saving it unless `save` is False.

        `save` is False for one of several steps that the last saves.
        """
        check_drawn(self._session, touched(scope, step.after))
        # what the session reader would refuse (or read back otherwise) would not reopen
        check_session(session, self._session)
        self._history.record(scope, step)
        self._session = session
        self._save_and_notify(save)

    def _save_and_notify(self, save: bool = True) -> None:
        """Autosave (unless `save` is False) and mark the session changed.

        A failed save keeps the session in memory (`last_save_error`).
        """
        if self.autosave and save:
            self._file.save(self._session)
        self._changed = True
