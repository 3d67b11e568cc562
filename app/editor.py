"""Editing the session from the browser: mirrors, markers, boundaries, planes, the object selection and the
background, every edit naming its mirror by its stable id. Undo and redo are kept per mirror (and for the session's
own changes: adding or removing a mirror, the selection, the background), each step named for the button; the
planes set by one fit or refinement of several mirrors are undone and redone together, from any of them. Pure logic
over mirrorcore.io.session; thread-safe; autosaved after every change.

session.json may also be written by another program while the tool edits it (`mirrorscan calibrate SESSION` in a
terminal): the editor never saves over such a change. It reloads the file (`reload_if_changed`, which the server
calls twice a second) and refuses an edit that would have been saved over it, naming what happened."""
from __future__ import annotations

import functools
import itertools
import os
import threading
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.geometry.plane import Plane
from mirrorcore.geometry.polygon import edge_distance, validate_polygon
from mirrorcore.rig.model import check_bounces
from mirrorcore.depth.selection import Selection
from mirrorcore.io.session import (
    MAX_MARKER_OFFSET,
    MAX_MIRRORS,
    Pixels,
    Session,
    SessionMirror,
    load_session,
    save_session,
)
from mirrorcore.io.limits import check_limits, check_name
from mirrorcore.base.words import listed

UNDO_DEPTH = 100
PICK_RADIUS = 8.0        # pixels: a click this close to a vertex or a marker picks it
ON_EDGE = 1.5            # pixels: a marker this close outside its mirror's boundary still counts as on it
SESSION_SCOPE = 0        # the undo scope of changes that are not one mirror's (mirror ids start at 1)


@dataclass(frozen=True)
class Step:
    """One undoable change: its label for the button ('marker 2.3', 'remove mirror 1'), and what undo and redo put
    back: in a mirror's scope, its SessionMirror before and after; in the session's scope, the change that undoes it
    and the change itself, (kind, a, b) as _restore reads them. `group` (0: none) ties the steps of several mirrors
    made by one action: undo and redo take every one of them that is still the last of its mirror."""

    label: str
    before: object
    after: object
    group: int = 0
    what: str = ""          # of set_planes' steps: what each mirror's change is ('plane' from the markers, 'refined
                            # plane'): names a part of a group, and tells a markers fit
    order: int = 0          # when it was made, undone or redone last (the editor's count): which history holds the
                            # newest step (travel_scope)


PARTIAL = " only: "     # in the label of a group's step that moves part of its mirrors (the others changed since)


def fit_inputs(mirror: SessionMirror | None) -> tuple | None:
    """What a plane computed for a mirror depends on: its markers, boundary, region, plane and glass (None: the
    mirror is gone). A plane computed on other inputs is never applied."""
    return None if mirror is None else (mirror.markers, mirror.boundary, mirror.region, mirror.plane,
                                        mirror.marker_offset)


def _edits(method):
    """Run an editing method under the editor's lock, then tell the listeners (outside the lock, so that a listener
    may take its own locks in any order) when it changed something. Refused (MirrorscanError), the session reloaded,
    when another program changed session.json since the editor read or wrote it."""

    @functools.wraps(method)
    def wrapper(self: "SessionEditor", *args, **kwargs):
        changed = False
        try:
            with self._lock:
                try:
                    message, reloaded = self._reload_external()
                    if reloaded:
                        raise MirrorscanError(f"{message}; this change was not made: make it again")
                    return method(self, *args, **kwargs)
                finally:
                    session, changed, self._changed = self._session, self._changed, False
        finally:
            if changed:
                self._tell(session)
    return wrapper


class SessionEditor:
    """The session being edited, shared by every tab.

    Every change validates its input (MirrorscanError with a one-line message on refusal, nothing changed), records
    an undo step in its scope (the mirror's id, or SESSION_SCOPE), saves the session when `autosave` is on, and calls
    the listeners with the new session. A mirror is named by its id everywhere: an edit meant for a mirror that was
    removed meanwhile is refused, never applied to another one.
    """

    def __init__(self, session: Session, autosave: bool = True):
        self._lock = threading.RLock()
        self._session = session
        self._undo: dict[int, list[Step]] = {}
        self._redo: dict[int, list[Step]] = {}
        self.autosave = autosave
        self.listeners: list[Callable[[Session], None]] = []
        self.last_save_error: str | None = None
        self._changed = False
        self._groups = itertools.count(1)
        self._orders = itertools.count(1)          # Step.order
        self._disk = _stamp(session.path)          # session.json as the editor last read or wrote it

    @property
    def session(self) -> Session:
        with self._lock:
            return self._session

    def mirror(self, mirror_id: int) -> SessionMirror:
        """The mirror with this id; MirrorscanError when it is gone."""
        with self._lock:
            return self._session.mirrors[self._index(mirror_id)]

    # ------------------------------------------------------------------ mirrors
    @_edits
    def add_mirror(self, name: str | None = None) -> int:
        """Append a mirror (named 'mirror N' by default, N its id); returns its id."""
        mirrors = self._session.mirrors
        if len(mirrors) >= MAX_MIRRORS:
            raise MirrorscanError(f"a session holds at most {MAX_MIRRORS} mirrors")
        mirror_id = max([m.id for m in mirrors] + [0]) + 1
        names = {m.name for m in mirrors}
        name = (name or "").strip() or next(f"mirror {k}" for k in range(mirror_id, mirror_id + 1000)
                                             if f"mirror {k}" not in names)
        self._check_name(name, None)
        mirror = SessionMirror(name, id=mirror_id)
        self._change(f"add {name}", ("add", len(mirrors), mirror), replace(self._session, mirrors=mirrors + (mirror,)))
        return mirror_id

    @_edits
    def rename_mirror(self, mirror_id: int, name: str) -> None:
        name = name.strip()
        self._check_name(name, mirror_id)
        self._set_mirror(mirror_id, f"name of {self.mirror(mirror_id).name}", name=name)

    @_edits
    def remove_mirror(self, mirror_id: int) -> None:
        """Remove a mirror; undo (in the session's scope) puts it back where it was, with its id and history."""
        index = self._index(mirror_id)
        mirror = self._session.mirrors[index]
        mirrors = self._session.mirrors[:index] + self._session.mirrors[index + 1:]
        self._change(f"remove {mirror.name}", ("remove", index, mirror), replace(self._session, mirrors=mirrors))

    # ------------------------------------------------------------------ markers
    @_edits
    def add_marker(self, mirror_id: int, uv: tuple[float, float]) -> int:
        """Add a marker; refused outside the image and, once the mirror has a boundary, outside it (a stray click
        under the panel or on another mirror must not reach the fit). Returns its index (0-based)."""
        mirror = self.mirror(mirror_id)
        uv = self._on_mirror(mirror, uv)
        self._set_mirror(mirror_id, f"marker {mirror.marker_name(len(mirror.markers))}",
                         markers=mirror.markers + (uv,))
        return len(mirror.markers)

    @_edits
    def move_marker(self, mirror_id: int, k: int, uv: tuple[float, float]) -> None:
        mirror = self.mirror(mirror_id)
        self._marker(mirror, k)
        uv = self._on_mirror(mirror, uv)
        self._set_mirror(mirror_id, f"move marker {mirror.marker_name(k)}",
                         markers=mirror.markers[:k] + (uv,) + mirror.markers[k + 1:])

    @_edits
    def delete_marker(self, mirror_id: int, k: int) -> None:
        mirror = self.mirror(mirror_id)
        self._marker(mirror, k)
        self._set_mirror(mirror_id, f"delete marker {mirror.marker_name(k)}",
                         markers=mirror.markers[:k] + mirror.markers[k + 1:])

    @_edits
    def clear_markers(self, mirror_id: int) -> None:
        self._clear(mirror_id, "markers")

    # ------------------------------------------------------------------ boundaries
    @_edits
    def set_boundary(self, mirror_id: int, vertices: Pixels) -> None:
        """Make a drawn polygon the mirror's boundary (at least 3 vertices in the image, not crossing itself)."""
        mirror = self.mirror(mirror_id)
        vertices = tuple(self._pixel(uv) for uv in vertices)
        validate_polygon(vertices, self._session.camera.shape, f"{mirror.name}: boundary")
        self._set_mirror(mirror_id, f"boundary of {mirror.name}", boundary=vertices)

    @_edits
    def move_vertex(self, mirror_id: int, vertex: int, uv: tuple[float, float]) -> None:
        mirror = self.mirror(mirror_id)
        self._vertex(mirror, vertex)
        edited = mirror.boundary[:vertex] + (self._pixel(uv),) + mirror.boundary[vertex + 1:]
        validate_polygon(edited, self._session.camera.shape, f"{mirror.name}: boundary")
        self._set_mirror(mirror_id, f"move corner {vertex + 1} of {mirror.name}", boundary=edited)

    @_edits
    def delete_vertex(self, mirror_id: int, vertex: int) -> None:
        mirror = self.mirror(mirror_id)
        self._vertex(mirror, vertex)
        edited = mirror.boundary[:vertex] + mirror.boundary[vertex + 1:]
        validate_polygon(edited, self._session.camera.shape, f"{mirror.name}: boundary")
        self._set_mirror(mirror_id, f"delete corner {vertex + 1} of {mirror.name}", boundary=edited)

    @_edits
    def clear_boundary(self, mirror_id: int) -> None:
        self._clear(mirror_id, "boundary")

    # ------------------------------------------------------------------ calibration, selection, background
    @_edits
    def set_planes(self, planes: dict[int, tuple[Plane | None, SessionMirror]],
                   glass: dict[int, tuple[float, float | None]] | None = None, what: str = "plane") -> bool:
        """Set the planes of several mirrors {id: (plane, the mirror as it was when the plane was computed)}, and
        their glass when given {id: (marker_offset, marker_offset_std) metres} (a refinement measures it), all or
        nothing; each mirror's change
        is an undo step in its own scope, and the steps of several mirrors are undone together ('{what}s of NAME and
        NAME'). A mirror whose plane and glass stay as they are is left out (a fit of the same frames again is no
        undo step). Refused when a mirror is gone or its markers, boundary, region, plane or glass changed since: a
        result computed on another state is never applied (compute it again). Returns whether anything changed."""
        for mirror_id, (_, based_on) in planes.items():
            current = self.mirror(mirror_id)
            if fit_inputs(current) != fit_inputs(based_on):
                again = "refine it again" if what.startswith("refined") else "fit it again"
                raise MirrorscanError(f"{current.name} changed while its {what} was computed; {again}")
        glass = {i: (glass or {}).get(i, (self.mirror(i).marker_offset, self.mirror(i).marker_offset_std))
                 for i in planes}
        planes = {i: given for i, given in planes.items() if (given[0], *glass[i]) != (
            self.mirror(i).plane, self.mirror(i).marker_offset, self.mirror(i).marker_offset_std)}
        if not planes:
            return False
        names = [self.mirror(mirror_id).name for mirror_id in planes]
        label = f"{what}{'s' if len(names) > 1 else ''} of {listed(names)}"
        group = next(self._groups) if len(names) > 1 else 0
        for k, (mirror_id, (plane, _)) in enumerate(planes.items()):     # saved once, with all of them (a file with
            offset, std = glass[mirror_id]                                # some had been the backup: a helper)
            self._set_mirror(mirror_id, label, group, what, save=k == len(planes) - 1, plane=plane,
                             marker_offset=offset, marker_offset_std=std)
        return True

    @_edits
    def set_marker_offset(self, mirror_id: int, metres: float) -> None:
        """How far the mirror's markers stand in front of its reflecting surface (the glass), 0 to
        MAX_MARKER_OFFSET metres, typed in (a refinement keeps it); the plane stays (fit again to use it:
        glass_unused)."""
        mirror = self.mirror(mirror_id)
        if not (np.isfinite(metres) and 0 <= metres <= MAX_MARKER_OFFSET):
            raise MirrorscanError(f"{mirror.name}: the glass in front of the silver must be 0 to "
                                  f"{MAX_MARKER_OFFSET * 1e3:g} mm, got {metres * 1e3:g} mm")
        self._set_mirror(mirror_id, f"glass of {mirror.name}", marker_offset=float(metres), marker_offset_std=None)

    @_edits
    def set_selection(self, selection: Selection) -> None:
        self._change("object selection", ("selection", self._session.selection, selection),
                     replace(self._session, selection=selection))

    @_edits
    def set_bounces(self, bounces: int) -> None:
        """How many mirrors in turn a camera ray is followed through (1 to 3; mirrorcore.rig.model)."""
        self._change("mirrors followed in turn", ("bounces", self._session.bounces, check_bounces(bounces)),
                     replace(self._session, bounces=check_bounces(bounces)))

    @_edits
    def set_background(self, relative_path: str | None) -> None:
        self._change("background", ("background", self._session.background, relative_path),
                     replace(self._session, background=relative_path))

    def replace_session(self, session: Session) -> None:
        """Open another session (the undo history is dropped)."""
        with self._lock:
            self._open(session)
            self._changed = False
        self._tell(session)

    def reload_if_changed(self) -> str:
        """Reload session.json when another program changed it since the editor read or wrote it; returns what
        happened in one line ('' when nothing did). See _reload_external."""
        with self._lock:
            message, reloaded = self._reload_external()
            session, self._changed = self._session, False
        if reloaded:
            self._tell(session)
        return message

    def _tell(self, session: Session) -> None:
        for listener in list(self.listeners):
            listener(session)

    def _open(self, session: Session) -> None:
        self._session, self._undo, self._redo = session, {}, {}
        self._disk = _stamp(session.path)

    def _reload_external(self) -> tuple[str, bool]:
        """When an autosaved session's session.json is not as the editor left it, read it again, dropping the undo
        history (which describes the file before). Returns what happened in one line ('' when the file is unchanged)
        and whether the session was reloaded. An unreadable or removed file is not read: the editor keeps its own
        session and writes it at the next change (save_session keeps what was there as session.json.bak)."""
        stamp = _stamp(self._session.path)
        if not self.autosave or stamp == self._disk:
            return "", False
        self._disk = stamp
        where = self._session.path
        if stamp is None:
            return f"{where} was removed by another program; the tool writes it again at the next change", False
        try:
            session = load_session(self._session.root)
        except FileFormatError as exc:
            return (f"{where} was changed by another program and cannot be read ({exc}); the tool keeps its own "
                    "session and writes it at the next change, keeping that file as session.json.bak"), False
        self._open(session)
        self._changed = True
        return f"{where} was changed by another program (mirrorscan calibrate?): reloaded, undo history cleared", True

    # ------------------------------------------------------------------ undo and redo
    def travel_scope(self, mirror_id: int | None, redo: bool = False) -> int:
        """Where undo (or redo) acts for the selected mirror: its own history, or the session's (mirrors added and
        removed, the bounces) when the mirror's holds nothing or the session's last step is a removal made, undone
        or redone after the mirror's last (a mirror removed, the main Undo had offered the selected mirror's older
        refinement: a helper). An added mirror is not taken back over the selected one's steps: its undo would
        take the new mirror's work with it."""
        with self._lock:
            source = self._redo if redo else self._undo
            own, shared = source.get(mirror_id) if mirror_id else None, source.get(SESSION_SCOPE)
            if not own:
                return SESSION_SCOPE
            removal = bool(shared) and shared[-1].after[0] == "remove" and shared[-1].order > own[-1].order
            return SESSION_SCOPE if removal else mirror_id

    def undo_label(self, scope: int) -> str | None:
        """What undo in this scope (a mirror id, or SESSION_SCOPE) would take back, or None."""
        with self._lock:
            return self._label(scope, self._undo)

    def _label(self, scope: int, source: dict) -> str | None:
        """The label of the last step of `scope` in `source`; of a group's step of which some mirrors changed since
        (their own steps come first), only the mirrors it would move, and which changed ('refined plane of mirror 2
        only: mirror 1 changed since'; the group's label had promised both: a helper)."""
        steps = source.get(scope)
        if not steps:
            return None
        step = steps[-1]
        if not step.group:
            return step.label
        moving, left = self._group_split(step, source)
        name = lambda ids: listed([self.mirror(i).name for i in ids])     # noqa: E731
        label = f"{step.what}{'s' if len(moving) > 1 else ''} of {name(moving)}"
        return f"{label}{PARTIAL}{name(left)} changed since" if left else label

    def _group_split(self, step: Step, source: dict) -> tuple[list[int], list[int]]:
        """The mirrors of `step`'s group (present, in session order) whose last step in `source` it is (they move
        together), and those that hold it under later steps (they stay). ([], []) for a step of no group."""
        if not step.group:
            return [], []
        holding = [m.id for m in self._session.mirrors if any(x.group == step.group for x in source.get(m.id, ()))]
        moving = [s for s in holding if source[s][-1].group == step.group]
        return moving, [s for s in holding if s not in moving]

    def glass_unused(self, mirror_id: int) -> bool:
        """Whether the mirror's glass was typed in after its plane was set (its undo steps, newest first, change the
        glass before they change the plane): the plane stands where the last fit put it until the next fit (a
        helper typed 4 mm and took the plane for moved)."""
        with self._lock:
            for step in reversed(self._undo.get(mirror_id, [])):
                if step.before.plane != step.after.plane:
                    return False
                if step.before.marker_offset != step.after.marker_offset:
                    return step.after.plane is not None
            return False

    def fitted_on_its_markers(self, mirror_id: int) -> bool:
        """Whether the mirror's plane was set by a markers fit of this editor on the markers, boundary, region and
        glass it has now (its newest undo step that set a plane, read against the mirror as it is): a fit of them
        again only refits them on other frames."""
        with self._lock:
            step = next((s for s in reversed(self._undo.get(mirror_id, [])) if s.before.plane != s.after.plane), None)
            now = next((m for m in self._session.mirrors if m.id == mirror_id), None)
            return (step is not None and step.what == "plane" and now is not None
                    and fit_inputs(step.after) == fit_inputs(now))

    def redo_label(self, scope: int) -> str | None:
        with self._lock:
            return self._label(scope, self._redo)

    @_edits
    def undo(self, scope: int) -> str:
        """Take back the last change in a scope (a mirror id, or SESSION_SCOPE); returns its label."""
        return self._travel(scope, self._undo, self._redo, "before", "undo")

    @_edits
    def redo(self, scope: int) -> str:
        return self._travel(scope, self._redo, self._undo, "after", "redo")

    def _travel(self, scope: int, source: dict, target: dict, side: str, verb: str) -> str:
        """Move the last step of `scope` (and of its group, in every scope where it is still the last) from the
        `source` history to `target`, putting back its `side`."""
        steps = source.get(scope)
        if not steps:
            raise MirrorscanError(f"nothing to {verb}")
        label = self._label(scope, source)
        scopes = self._group_split(steps[-1], source)[0] or [scope]
        order = next(self._orders)
        for s in scopes:
            moved = source[s].pop()
            self._session = self._restore(s, getattr(moved, side))
            target.setdefault(s, []).append(replace(moved, order=order))
        self._save_and_notify()
        return label

    def _restore(self, scope: int, state) -> Session:
        """The session with one side of a step put back: a mirror's record (mirror scope) or a session change."""
        session = self._session
        if scope != SESSION_SCOPE:
            return session.with_mirror(self._index(scope), state)
        kind, a, b = state
        if kind == "add":            # ("add", index, mirror): the mirror is absent before, present after
            return replace(session, mirrors=session.mirrors[:a] + (b,) + session.mirrors[a:])
        if kind == "remove":
            return replace(session, mirrors=tuple(m for m in session.mirrors if m.id != b.id))
        return replace(session, **{kind: b})

    # ------------------------------------------------------------------ internals
    def _index(self, mirror_id: int) -> int:
        for i, m in enumerate(self._session.mirrors):
            if m.id == mirror_id:
                return i
        raise MirrorscanError(f"mirror {mirror_id} is no longer in the session (removed in another tab?)")

    def _check_name(self, name: str, mirror_id: int | None) -> None:
        check_name(name)
        if any(m.name == name for m in self._session.mirrors if m.id != mirror_id):
            raise MirrorscanError(f"there is already a mirror named {name!r}")

    def _pixel(self, uv) -> tuple[float, float]:
        u, v = float(uv[0]), float(uv[1])
        cam = self._session.camera
        if not (np.isfinite(u) and np.isfinite(v) and -0.5 <= u <= cam.width - 0.5 and -0.5 <= v <= cam.height - 0.5):
            raise MirrorscanError(f"pixel ({u:g}, {v:g}) is outside the {cam.width}x{cam.height} image")
        return round(u, 2), round(v, 2)

    def _on_mirror(self, mirror: SessionMirror, uv) -> tuple[float, float]:
        """A marker's pixel, refused outside the image or (when the mirror has a boundary) off the mirror."""
        uv = self._pixel(uv)
        if mirror.boundary and edge_distance(mirror.boundary, uv) < -ON_EDGE:
            other = next((m.name for m in self._session.mirrors
                          if m.id != mirror.id and edge_distance(m.boundary, uv) >= 0), None)
            where = f"on {other}: select {other} (Mirror, above) to mark it" if other else "a marker must be on it"
            raise MirrorscanError(f"{mirror.name}: ({uv[0]:.0f}, {uv[1]:.0f}) is outside its boundary; {where}")
        return uv

    @staticmethod
    def _marker(mirror: SessionMirror, k: int) -> None:
        if not 0 <= k < len(mirror.markers):
            raise MirrorscanError(f"{mirror.name}: no marker {mirror.marker_name(k)}")

    @staticmethod
    def _vertex(mirror: SessionMirror, vertex: int) -> None:
        if not 0 <= vertex < len(mirror.boundary):
            raise MirrorscanError(f"{mirror.name}: no corner {vertex + 1}")

    def _clear(self, mirror_id: int, field: str) -> None:
        """Empty a mirror's markers or boundary (refused when there is nothing to clear)."""
        mirror = self.mirror(mirror_id)
        if not getattr(mirror, field):
            raise MirrorscanError(f"{mirror.name}: no {field} to clear")
        self._set_mirror(mirror_id, f"clear the {field} of {mirror.name}", **{field: ()})

    def _set_mirror(self, mirror_id: int, label: str, group: int = 0, what: str = "", save: bool = True,
                    **changes) -> None:
        index = self._index(mirror_id)
        before = self._session.mirrors[index]
        after = replace(before, **changes)
        self._commit(mirror_id, Step(label, before, after, group, what), self._session.with_mirror(index, after), save)

    def _change(self, label: str, change: tuple, session: Session) -> None:
        """A change of the session's own (SESSION_SCOPE): change = (kind, a, b), see _restore and _inverse."""
        self._commit(SESSION_SCOPE, Step(label, _inverse(change), change), session)

    def _commit(self, scope: int, step: Step, session: Session, save: bool = True) -> None:
        """Record an undo step and take the session, saving it unless `save` is False (one of several steps that
        the last saves)."""
        check_limits(session)                         # the limits of a session that is read: it would not reopen
        step = replace(step, order=next(self._orders))
        self._undo[scope] = (self._undo.get(scope, []) + [step])[-UNDO_DEPTH:]
        self._redo.pop(scope, None)
        self._session = session
        self._save_and_notify(save)

    def _save_and_notify(self, save: bool = True) -> None:
        self.last_save_error = None
        if self.autosave and save:
            try:
                save_session(self._session)
            except OSError as exc:   # the previous file is intact (atomic write); say so and go on
                self.last_save_error = f"{exc.filename}: {exc.strerror or exc}"
            self._disk = _stamp(self._session.path)
        self._changed = True


def _stamp(path) -> tuple[int, int, int] | None:
    """What tells a file's versions apart: (inode, modification time ns, size), None when it does not exist (an
    atomic write replaces the inode, so two versions written within one tick of the clock still differ)."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return None
    return st.st_ino, st.st_mtime_ns, st.st_size


def _inverse(change: tuple) -> tuple:
    """The session change that undoes `change`: an added mirror is removed, a removed one put back, a value swapped."""
    kind, a, b = change
    if kind == "add":
        return ("remove", a, b)
    if kind == "remove":
        return ("add", a, b)
    return (kind, b, a)
