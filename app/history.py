"""What the editor's undo history tells the panels: where undo acts, what it would move, and
what a mirror's plane was fitted on."""
from __future__ import annotations

import threading

from mirrorcore.io.session import Session, SessionMirror

from .undo import History


class HistoryView:
    """Questions to the undo history of an editor (mixed into `editing.EditorCore`).

    Attributes
    ----------
    _lock : threading.RLock
        The editor's lock, taken by every question.
    _history : History
        The editor's undo history.
    _session : Session
        The session as it now is.
    """

    _lock: threading.RLock
    _history: History
    _session: Session

    def travel_scope(self, mirror_id: int | None, redo: bool = False) -> int:
        """Where undo (or redo) acts for the selected mirror: its own history or the session's.

        Parameters
        ----------
        mirror_id : int or None
            The selected mirror.
        redo : bool, optional
            For redo rather than undo.

        Returns
        -------
        int
            A mirror id, or SESSION_SCOPE (see `History.scope`).
        """
        with self._lock:
            return self._history.scope(mirror_id, redo)

    def undo_label(self, scope: int) -> str | None:
        """What undo in this scope would take back.

        Parameters
        ----------
        scope : int
            A mirror id, or SESSION_SCOPE.

        Returns
        -------
        str or None
            None when there is nothing to undo.
        """
        with self._lock:
            return self._label(scope, redo=False)

    def redo_label(self, scope: int) -> str | None:
        """What redo in this scope would put back.

        Parameters
        ----------
        scope : int
            A mirror id, or SESSION_SCOPE.

        Returns
        -------
        str or None
            None when there is nothing to redo.
        """
        with self._lock:
            return self._label(scope, redo=True)

    def _label(self, scope: int, redo: bool) -> str | None:
        """What undo or redo in `scope` would move, or None."""
        ids = [m.id for m in self._session.mirrors]
        return self._history.label(scope, redo, ids, lambda i: self.mirror(i).name)

    def glass_unused(self, mirror_id: int) -> bool:
        """Whether the mirror's glass was typed in after its plane was set (History.glass_unused).

        Parameters
        ----------
        mirror_id : int

        Returns
        -------
        bool
        """
        with self._lock:
            return self._history.glass_unused(mirror_id)

    def fitted_on_its_markers(self, mirror_id: int) -> bool:
        """Whether the mirror's plane was set by a markers fit of this editor on what it has now.

        On the markers, boundary, region and glass it has now: a fit of them again only refits them
        on other frames.

        Parameters
        ----------
        mirror_id : int

        Returns
        -------
        bool
        """
        with self._lock:
            now = next((m for m in self._session.mirrors if m.id == mirror_id), None)
            return self._history.fitted_on(mirror_id, now)

    def removal(self, scope: int, redo: bool = False) -> SessionMirror | None:
        """The mirror that undo (or redo) in `scope` would remove, as it now is, else None.

        Parameters
        ----------
        scope : int
            A mirror id, or SESSION_SCOPE.
        redo : bool, optional
            For redo rather than undo.
        """
        with self._lock:
            ids = [m.id for m in self._session.mirrors]
            mirror_id = self._history.removal(scope, redo, ids)
            return None if mirror_id is None else self._session.mirrors[ids.index(mirror_id)]
