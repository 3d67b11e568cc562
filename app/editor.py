"""Editing the session from the browser: mirrors, markers, boundaries, planes, the object selection
and the background, every edit naming its mirror by its stable id.

Undo and redo are kept per mirror, and for the session's own changes (adding or removing a mirror,
the selection, the background), each step named for the button (see `mirrorscan.undo`). Pure logic
over mirrorcore.io.session; thread-safe; autosaved after every change (see `mirrorscan.editing`).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.base.words import listed
from mirrorcore.depth.selection import Selection
from mirrorcore.geometry.plane import Plane
from mirrorcore.geometry.polygon import validate_polygon
from mirrorcore.io.session import MAX_MARKER_OFFSET, Pixels, SessionMirror
from mirrorcore.io.sessionfile import check_session
from mirrorcore.io.sessionfile import MAX_MIRRORS
from mirrorcore.rig.model import check_bounces

from .editing import EditorCore, edits
from .guards import (ON_EDGE, StaleEdit, check_drawn, fit_inputs, has_marker, has_vertex, made_on,
                     on_mirror, pixel, planes_to_set, unused_name)
from .undo import PARTIAL, SESSION_SCOPE, UNDO_DEPTH

__all__ = ["ON_EDGE", "PARTIAL", "PICK_RADIUS", "SESSION_SCOPE", "UNDO_DEPTH", "SessionEditor",
           "StaleEdit", "fit_inputs", "made_on"]

PICK_RADIUS = 8.0        # pixels: a click this close to a vertex or a marker picks it


class SessionEditor(EditorCore):
    """The session being edited, shared by every tab.

    Every change validates its input (MirrorscanError with a one-line message on refusal, nothing
    changed), records an undo step in its scope (the mirror's id, or SESSION_SCOPE), saves the
    session when `autosave` is on, and calls the listeners with the new session. A mirror is named
    by its id everywhere: an edit meant for a mirror that was removed meanwhile is refused, never
    applied to another one.
    """

    # ------------------------------------------------------------------ mirrors
    @edits
    def add_mirror(self, name: str | None = None) -> int:
        """Append a mirror.

        Parameters
        ----------
        name : str, optional
            Its name; 'mirror N' by default, N its id.

        Returns
        -------
        int
            Its id.

        Raises
        ------
        MirrorscanError
            When the session holds MAX_MIRRORS already, or the name is not valid or taken.
        """
        mirrors = self._session.mirrors
        if len(mirrors) >= MAX_MIRRORS:
            raise MirrorscanError(f"a session holds at most {MAX_MIRRORS} mirrors; remove one to "
                                  "add another")
        mirror_id = max([m.id for m in mirrors] + [0]) + 1
        names = {m.name for m in mirrors}
        name = (name or "").strip() or next(f"mirror {k}"
                                             for k in range(mirror_id, mirror_id + 1000)
                                             if f"mirror {k}" not in names)
        unused_name(self._session, name, None)
        mirror = SessionMirror(name, id=mirror_id)
        self._change(f"add {name}", ("add", len(mirrors), mirror),
                     replace(self._session, mirrors=mirrors + (mirror,)))
        return mirror_id

    @edits
    def rename_mirror(self, mirror_id: int, name: str) -> None:
        """Rename a mirror.

        Parameters
        ----------
        mirror_id : int
            The mirror's id.
        name : str
            The new name, stripped of surrounding spaces.

        Raises
        ------
        MirrorscanError
            When the name is not valid or another mirror holds it.
        """
        name = name.strip()
        unused_name(self._session, name, mirror_id)
        self._set_mirror(mirror_id, f"name of {self.mirror(mirror_id).name}", name=name)

    @edits
    def remove_mirror(self, mirror_id: int) -> None:
        """Remove a mirror.

        Undo (in the session's scope) puts it back where it was, with its id and history.

        Parameters
        ----------
        mirror_id : int
            The mirror's id.
        """
        index = self._index(mirror_id)
        mirror = self._session.mirrors[index]
        mirrors = self._session.mirrors[:index] + self._session.mirrors[index + 1:]
        self._change(f"remove {mirror.name}", ("remove", index, mirror),
                     replace(self._session, mirrors=mirrors))

    # ------------------------------------------------------------------ markers
    @edits
    def add_marker(self, mirror_id: int, uv: tuple[float, float]) -> int:
        """Add a marker at pixel `uv`.

        Refused outside the image and, once the mirror has a boundary, outside it: a stray click
        under the panel or on another mirror must not reach the fit.

        Parameters
        ----------
        mirror_id : int
            The mirror's id.
        uv : tuple of float
            (u, v), pixels.

        Returns
        -------
        int
            The marker's index (0-based).
        """
        mirror = self.mirror(mirror_id)
        uv = on_mirror(self._session, mirror, uv)
        self._set_mirror(mirror_id, f"marker {mirror.marker_name(len(mirror.markers))}",
                         markers=mirror.markers + (uv,))
        return len(mirror.markers)

    @edits
    def move_marker(self, mirror_id: int, k: int, uv: tuple[float, float]) -> None:
        """Move marker `k` to pixel `uv`, refused where add_marker refuses it.

        Parameters
        ----------
        mirror_id : int
            The mirror's id.
        k : int
            The marker's index (0-based).
        uv : tuple of float
            (u, v), pixels.
        """
        mirror = self.mirror(mirror_id)
        has_marker(mirror, k)
        uv = on_mirror(self._session, mirror, uv)
        self._set_mirror(mirror_id, f"move marker {mirror.marker_name(k)}",
                         markers=mirror.markers[:k] + (uv,) + mirror.markers[k + 1:])

    @edits
    def delete_marker(self, mirror_id: int, k: int) -> None:
        """Delete marker `k`.

        Parameters
        ----------
        mirror_id : int
            The mirror's id.
        k : int
            The marker's index (0-based).
        """
        mirror = self.mirror(mirror_id)
        has_marker(mirror, k)
        self._set_mirror(mirror_id, f"delete marker {mirror.marker_name(k)}",
                         markers=mirror.markers[:k] + mirror.markers[k + 1:])

    @edits
    def clear_markers(self, mirror_id: int) -> None:
        """Delete every marker of the mirror (refused when it has none).

        Parameters
        ----------
        mirror_id : int
            The mirror's id.
        """
        self._clear(mirror_id, "markers")

    # ------------------------------------------------------------------ boundaries
    @edits
    def set_boundary(self, mirror_id: int, vertices: Pixels) -> None:
        """Make a drawn polygon the mirror's boundary.

        Parameters
        ----------
        mirror_id : int
            The mirror's id.
        vertices : sequence of (float, float)
            At least 3 vertices (pixels) in the image, not crossing itself.
        """
        mirror = self.mirror(mirror_id)
        vertices = tuple(pixel(self._session.camera, uv) for uv in vertices)
        validate_polygon(vertices, self._session.camera.shape, f"{mirror.name}: boundary")
        self._set_mirror(mirror_id, f"boundary of {mirror.name}", boundary=vertices)

    @edits
    def move_vertex(self, mirror_id: int, vertex: int, uv: tuple[float, float]) -> None:
        """Move a corner of the mirror's boundary; the polygon must stay valid.

        Parameters
        ----------
        mirror_id : int
            The mirror's id.
        vertex : int
            The corner's index (0-based).
        uv : tuple of float
            (u, v), pixels.
        """
        mirror = self.mirror(mirror_id)
        has_vertex(mirror, vertex)
        moved = pixel(self._session.camera, uv)
        edited = mirror.boundary[:vertex] + (moved,) + mirror.boundary[vertex + 1:]
        validate_polygon(edited, self._session.camera.shape, f"{mirror.name}: boundary")
        self._set_mirror(mirror_id, f"move corner {vertex + 1} of {mirror.name}", boundary=edited)

    @edits
    def delete_vertex(self, mirror_id: int, vertex: int) -> None:
        """Delete a corner of the mirror's boundary; the polygon must stay valid.

        Parameters
        ----------
        mirror_id : int
            The mirror's id.
        vertex : int
            The corner's index (0-based).
        """
        mirror = self.mirror(mirror_id)
        has_vertex(mirror, vertex)
        edited = mirror.boundary[:vertex] + mirror.boundary[vertex + 1:]
        validate_polygon(edited, self._session.camera.shape, f"{mirror.name}: boundary")
        self._set_mirror(mirror_id, f"delete corner {vertex + 1} of {mirror.name}", boundary=edited)

    @edits
    def clear_boundary(self, mirror_id: int) -> None:
        """Delete the mirror's boundary (refused when it has none).

        Parameters
        ----------
        mirror_id : int
            The mirror's id.
        """
        self._clear(mirror_id, "boundary")

    # ------------------------------------------------------------------ calibration, selection,
    # background
    @edits
    def set_planes(self, planes: dict[int, tuple[Plane | None, SessionMirror]],
                   glass: dict[int, tuple[float, float | None]] | None = None,
                   what: str = "plane",
                   gains: dict[int, tuple[float, float, float]] | None = None) -> bool:
        """Set the planes of several mirrors, their glass and colour gains, all or nothing.

        Each mirror's change is an undo step in its own scope; the steps of several mirrors are
        undone together ('{what}s of NAME and NAME', 'colour gains of ...' when only gains
        change). A mirror whose plane, glass and gain stay as they are is left out: a fit of the
        same frames again is no undo step.

        Parameters
        ----------
        planes : dict of int to (Plane or None, SessionMirror)
            By mirror id: the plane, and the mirror as it was when the plane was computed.
        glass : dict of int to (float, float or None), optional
            By mirror id: (marker_offset, marker_offset_std), metres, when measured (a refinement).
        what : str
            What the change is ('plane', 'refined plane', 'found plane'): names the undo step.
        gains : dict of int to (float, float, float), optional
            By mirror id: the colour gain measured with the planes (a refinement on frames with
            colour); the others keep theirs.

        Returns
        -------
        bool
            Whether anything changed.

        Raises
        ------
        MirrorscanError
            When a mirror is gone or changed since (`guards.planes_to_set`).
        """
        mirrors = {i: self.mirror(i) for i in {*planes, *(gains or {})}}
        changes = planes_to_set(mirrors, planes, glass or {}, what)
        gains = {i: g for i, g in (gains or {}).items() if g != mirrors[i].colour_gain}
        if not changes and not gains:
            return False
        what = what if changes else "colour gain"
        for i in gains.keys() - changes.keys():
            changes[i] = (mirrors[i].plane, mirrors[i].marker_offset, mirrors[i].marker_offset_std)
        # all or none: a refusal after the first mirror's step would leave only some
        check_drawn(self._session, changes)
        final = self._session
        for mirror_id, (plane, offset, std) in changes.items():
            index = self._index(mirror_id)
            final = final.with_mirror(index, replace(
                final.mirrors[index], plane=plane, marker_offset=offset, marker_offset_std=std,
                colour_gain=gains.get(mirror_id, final.mirrors[index].colour_gain)))
        check_session(final, self._session)
        names = [mirrors[mirror_id].name for mirror_id in changes]
        label = f"{what}{'s' if len(names) > 1 else ''} of {listed(names)}"
        group = self._history.new_group() if len(names) > 1 else 0
        # Saved once, with all of them: a file with only some would become the backup.
        for k, (mirror_id, (plane, offset, std)) in enumerate(changes.items()):
            self._set_mirror(mirror_id, label, group, what, save=k == len(changes) - 1, plane=plane,
                             marker_offset=offset, marker_offset_std=std,
                             colour_gain=gains.get(mirror_id, mirrors[mirror_id].colour_gain))
        return True

    @edits
    def set_marker_offset(self, mirror_id: int, metres: float) -> None:
        """Set how far the mirror's markers stand in front of its reflecting surface (the glass).

        The plane stays where it is until the next fit (see `glass_unused`).

        Parameters
        ----------
        mirror_id : int
            The mirror's id.
        metres : float
            0 to MAX_MARKER_OFFSET, as typed in.
        """
        mirror = self.mirror(mirror_id)
        if not (np.isfinite(metres) and 0 <= metres <= MAX_MARKER_OFFSET):
            raise MirrorscanError(f"{mirror.name}: the glass in front of the silver must be 0 to "
                                  f"{MAX_MARKER_OFFSET * 1e3:g} mm, got {metres * 1e3:g} mm")
        self._set_mirror(mirror_id, f"glass of {mirror.name}", marker_offset=float(metres),
                         marker_offset_std=None)

    @edits
    def set_selection(self, selection: Selection) -> None:
        """Set the object selection (a step of the session's scope).

        Parameters
        ----------
        selection : Selection
        """
        self._change("object selection", ("selection", self._session.selection, selection),
                     replace(self._session, selection=selection))

    @edits
    def set_bounces(self, bounces: int) -> None:
        """Set how many mirrors in turn a camera ray is followed through (mirrorcore.rig.model).

        Parameters
        ----------
        bounces : int
            1 to 3.
        """
        self._change("mirrors followed in turn",
                     ("bounces", self._session.bounces, check_bounces(bounces)),
                     replace(self._session, bounces=check_bounces(bounces)))

    @edits
    def set_background(self, relative_path: str | None) -> None:
        """Set the session's background file.

        Parameters
        ----------
        relative_path : str or None
            Relative to the session's folder; None for no background.
        """
        self._change("background", ("background", self._session.background, relative_path),
                     replace(self._session, background=relative_path))

    # ------------------------------------------------------------------ internals
    def _clear(self, mirror_id: int, field: str) -> None:
        """Empty a mirror's markers or boundary (refused when there is nothing to clear)."""
        mirror = self.mirror(mirror_id)
        if not getattr(mirror, field):
            raise MirrorscanError(f"{mirror.name}: no {field} to clear")
        self._set_mirror(mirror_id, f"clear the {field} of {mirror.name}", **{field: ()})
