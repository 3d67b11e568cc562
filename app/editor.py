"""Editing a session from the browser: mirrors, markers, boundary polygons (drawn vertex by vertex, then closed),
planes and the object selection, with undo and autosave. Pure logic over mirrorcore.session; thread-safe."""
from __future__ import annotations

import functools
import threading
from dataclasses import replace
from typing import Callable

import numpy as np

from mirrorcore.errors import MirrorscanError
from mirrorcore.geometry.plane import Plane
from mirrorcore.geometry.polygon import validate_polygon
from mirrorcore.selection import Selection
from mirrorcore.session import Session, SessionMirror, save_session

UNDO_DEPTH = 100
PICK_RADIUS = 8.0   # pixels: a click this close to a vertex picks it


def _edits(method):
    """Run an editing method under the editor's lock, then tell the listeners (outside the lock, so that a listener
    may take its own locks in any order) when it changed something."""

    @functools.wraps(method)
    def wrapper(self: "SessionEditor", *args, **kwargs):
        with self._lock:
            try:
                result = method(self, *args, **kwargs)
            finally:
                session, changed, self._changed = self._session, self._changed, False
        if changed:
            for listener in list(self.listeners):
                listener(session)
        return result
    return wrapper


class SessionEditor:
    """The session being edited and the boundaries being drawn.

    Every change validates its input (MirrorscanError with a one-line message on refusal, nothing changed), records
    the previous session for undo, saves the session when `autosave` is on and it has a folder, and calls the
    listeners with the new session. Drafts (boundaries still open) are not part of the session until closed.
    """

    def __init__(self, session: Session, autosave: bool = True):
        self._lock = threading.RLock()
        self._session = session
        self._undo: list[Session] = []
        self.drafts: dict[int, tuple[tuple[float, float], ...]] = {}
        self.autosave = autosave
        self.listeners: list[Callable[[Session], None]] = []
        self.last_save_error: str | None = None
        self._changed = False

    @property
    def session(self) -> Session:
        with self._lock:
            return self._session

    # ------------------------------------------------------------------ mirrors
    @_edits
    def add_mirror(self, name: str | None = None) -> int:
        """Append a mirror (named 'mirror N' by default); returns its index (0-based)."""
        names = {m.name for m in self._session.mirrors}
        name = (name or "").strip() or next(f"mirror {k}" for k in range(1, 1000) if f"mirror {k}" not in names)
        self._check_name(name, None)
        self._commit(replace(self._session, mirrors=self._session.mirrors + (SessionMirror(name),)))
        return len(self._session.mirrors) - 1

    @_edits
    def rename_mirror(self, index: int, name: str) -> None:
        name = name.strip()
        self._check_name(name, index)
        self._set_mirror(index, replace(self._mirror(index), name=name))

    @_edits
    def remove_mirror(self, index: int) -> None:
        self._mirror(index)
        mirrors = self._session.mirrors[:index] + self._session.mirrors[index + 1:]
        self.drafts = {(k if k < index else k - 1): v for k, v in self.drafts.items() if k != index}
        self._commit(replace(self._session, mirrors=mirrors))

    # ------------------------------------------------------------------ markers
    @_edits
    def add_marker(self, index: int, uv: tuple[float, float]) -> None:
        mirror = self._mirror(index)
        self._set_mirror(index, replace(mirror, markers=mirror.markers + (self._pixel(uv),)))

    @_edits
    def remove_last_marker(self, index: int) -> None:
        mirror = self._mirror(index)
        if not mirror.markers:
            raise MirrorscanError(f"{mirror.name}: no marker to remove")
        self._set_mirror(index, replace(mirror, markers=mirror.markers[:-1]))

    @_edits
    def clear_markers(self, index: int) -> None:
        self._set_mirror(index, replace(self._mirror(index), markers=()))

    # ------------------------------------------------------------------ boundaries
    def open_drafts(self) -> dict[int, tuple[tuple[float, float], ...]]:
        """A copy of the boundaries being drawn, {mirror index: vertices} (safe to read from another thread)."""
        with self._lock:
            return dict(self.drafts)

    def boundary_vertices(self, index: int) -> tuple[tuple[float, float], ...]:
        """The vertices shown for a mirror: its open draft if one is being drawn, else its closed boundary."""
        with self._lock:
            return self.drafts.get(index, self._mirror(index).boundary)

    @_edits
    def add_vertex(self, index: int, uv: tuple[float, float]) -> None:
        """Add a corner to the mirror's open boundary (starting a new draft if its boundary is closed or empty)."""
        self._mirror(index)
        self.drafts[index] = self.drafts.get(index, ()) + (self._pixel(uv),)
        self._notify()

    @_edits
    def close_boundary(self, index: int) -> None:
        """Validate the draft (>= 3 vertices, not self-crossing) and make it the mirror's boundary."""
        mirror = self._mirror(index)
        draft = self.drafts.get(index)
        if not draft:
            raise MirrorscanError(f"{mirror.name}: no open boundary to close; click its corners first")
        validate_polygon(draft, self._session.camera.shape, f"{mirror.name}: boundary")
        del self.drafts[index]
        self._set_mirror(index, replace(mirror, boundary=draft))

    def nearest_vertex(self, index: int, uv: tuple[float, float]) -> int | None:
        """The vertex of the shown boundary within PICK_RADIUS pixels of uv, or None."""
        vertices = np.asarray(self.boundary_vertices(index), dtype=float).reshape(-1, 2)
        if not len(vertices):
            return None
        dist = np.hypot(*(vertices - np.asarray(uv, dtype=float)).T)
        k = int(np.argmin(dist))
        return k if dist[k] <= PICK_RADIUS else None

    @_edits
    def move_vertex(self, index: int, vertex: int, uv: tuple[float, float]) -> None:
        self._edit_vertices(index, vertex, lambda v: v[:vertex] + (self._pixel(uv),) + v[vertex + 1:])

    @_edits
    def delete_vertex(self, index: int, vertex: int) -> None:
        self._edit_vertices(index, vertex, lambda v: v[:vertex] + v[vertex + 1:])

    @_edits
    def clear_boundary(self, index: int) -> None:
        self.drafts.pop(index, None)
        self._set_mirror(index, replace(self._mirror(index), boundary=()))

    def _edit_vertices(self, index: int, vertex: int, edit) -> None:
        mirror = self._mirror(index)
        vertices = self.boundary_vertices(index)
        if not 0 <= vertex < len(vertices):
            raise MirrorscanError(f"{mirror.name}: no vertex {vertex + 1}")
        edited = edit(vertices)
        if index in self.drafts:
            self.drafts[index] = edited
            self._notify()
            return
        validate_polygon(edited, self._session.camera.shape, f"{mirror.name}: boundary")
        self._set_mirror(index, replace(mirror, boundary=edited))

    # ------------------------------------------------------------------ calibration and selection
    @_edits
    def set_planes(self, planes: dict[int, Plane | None]) -> None:
        """Set the planes of several mirrors {index: plane} as one change (one undo step, one save)."""
        session = self._session
        for index, plane in planes.items():
            session = session.with_mirror(index, replace(self._mirror(index), plane=plane))
        self._commit(session)

    @_edits
    def set_selection(self, selection: Selection) -> None:
        self._commit(replace(self._session, selection=selection))

    @_edits
    def set_background(self, relative_path: str | None) -> None:
        self._commit(replace(self._session, background=relative_path))

    @_edits
    def replace_session(self, session: Session) -> None:
        """Open another session (undo history and drafts are dropped)."""
        self._session, self._undo, self.drafts = session, [], {}
        self._notify()

    # ------------------------------------------------------------------ undo
    @_edits
    def undo(self) -> None:
        """Go back one change: an open draft loses its last vertex first, then sessions are restored."""
        open_drafts = [k for k, v in self.drafts.items() if v]
        if open_drafts:
            k = open_drafts[-1]
            self.drafts[k] = self.drafts[k][:-1]
            if not self.drafts[k]:
                del self.drafts[k]
            self._notify()
            return
        if not self._undo:
            raise MirrorscanError("nothing to undo")
        self._session = self._undo.pop()
        self._save_and_notify()

    # ------------------------------------------------------------------ internals
    def _mirror(self, index: int) -> SessionMirror:
        if not 0 <= index < len(self._session.mirrors):
            raise MirrorscanError(f"no mirror {index + 1}; the session has {len(self._session.mirrors)}")
        return self._session.mirrors[index]

    def _check_name(self, name: str, index: int | None) -> None:
        if not name:
            raise MirrorscanError("a mirror needs a name")
        if any(m.name == name for k, m in enumerate(self._session.mirrors) if k != index):
            raise MirrorscanError(f"there is already a mirror named {name!r}")

    def _pixel(self, uv) -> tuple[float, float]:
        u, v = float(uv[0]), float(uv[1])
        cam = self._session.camera
        if not (np.isfinite(u) and np.isfinite(v) and -0.5 <= u <= cam.width - 0.5 and -0.5 <= v <= cam.height - 0.5):
            raise MirrorscanError(f"pixel ({u:g}, {v:g}) is outside the {cam.width}x{cam.height} image")
        return round(u, 2), round(v, 2)

    def _set_mirror(self, index: int, mirror: SessionMirror) -> None:
        self._commit(self._session.with_mirror(index, mirror))

    def _commit(self, session: Session) -> None:
        self._undo = (self._undo + [self._session])[-UNDO_DEPTH:]
        self._session = session
        self._save_and_notify()

    def _save_and_notify(self) -> None:
        self.last_save_error = None
        if self.autosave:
            try:
                save_session(self._session)
            except OSError as exc:   # the previous file is intact (atomic write); say so and go on
                self.last_save_error = f"{exc.filename}: {exc.strerror or exc}"
        self._notify()

    def _notify(self) -> None:
        self._changed = True
