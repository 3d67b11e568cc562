"""The Mirrors step's clicks on the depth frame: markers (add, pick, move, delete) and outlines
(corners drawn, closed, picked, moved, deleted)."""

from __future__ import annotations

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.calibration.markers import MIN_MARKER_PIXELS, marker_points
from mirrorcore.geometry.polygon import MIN_VERTICES
from mirrorcore.io.session import SessionMirror

from ...context import TabContext
from ...editor import PICK_RADIUS
from ...wording.markers import marker_off_note, no_depth_note


def nearest(points, uv) -> int | None:
    """The index of the point within PICK_RADIUS pixels of `uv`, or None.

    Parameters
    ----------
    points : array_like, shape (n, 2)
        (u, v) pixels.
    uv : array_like, shape (2,)
        Pixels.

    Returns
    -------
    int or None
        The nearest such point's index.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if not len(points):
        return None
    dist = np.hypot(*(points - np.asarray(uv, dtype=float)).T)
    k = int(np.argmin(dist))
    return k if dist[k] <= PICK_RADIUS else None


class MirrorClicks:
    """The clicks of the Mirrors panel (MirrorsPanel mixes it in)."""

    tab: TabContext

    def _id(self) -> int:
        """The selected mirror's id; MirrorscanError when there is none."""
        if self.tab.state.mirror_id is None:
            raise MirrorscanError("add a mirror first (Mirrors › Add a mirror)")
        return self.tab.state.mirror_id

    def _mirror(self) -> SessionMirror:
        """The selected mirror; MirrorscanError when there is none."""
        return self.services.editor.mirror(self._id())

    def _marker_click(self, u: float, v: float) -> None:
        """A click in Markers mode: move the picked marker, pick one near, or add one."""
        editor, state, mirror = self.services.editor, self.tab.state, self._mirror()
        if state.moving_marker and state.picked_marker is not None:
            editor.move_marker(mirror.id, state.picked_marker, (u, v))
            state.moving_marker = False
        else:
            near = nearest(mirror.markers, (u, v))
            if near is not None:
                state.picked_marker = None if near == state.picked_marker else near
            else:
                state.picked_marker = editor.add_marker(mirror.id, (u, v))
                self._warn_if_off(mirror.id, state.picked_marker)
        self.tab.changed()

    def _warn_if_off(self, mirror_id: int, k: int) -> None:
        """Tell at once of a marker just added with no depth under it, or far off its plane.

        No depth on the frames a fit reads; far off: a click on the object seen in the mirror, or
        beside the sticker. The next fit would refuse it, or show it crossed, as a proposal.
        """
        mirror = self.services.editor.mirror(mirror_id)
        frames = self.services.jobs.marker_frames()
        if (
            frames is not None
            and k < len(mirror.markers)
            and len(marker_points(self.services.snapshot.rig.intrinsics, frames, mirror.markers[k]))
            < MIN_MARKER_PIXELS
        ):
            note = no_depth_note()
            self.services.notify(
                self.tab.client,
                f"Marker {mirror.marker_name(k)} has no depth",
                note.plain,
                "warning",
            )
            return
        residuals = self.services.snapshot.marker_residuals.get(mirror_id)
        if residuals is None or k >= len(residuals.grades) or residuals.grades[k] != "poor":
            return
        note = marker_off_note(mirror.name, residuals.signed_mm[k], residuals.sigma_mm[k])
        self.services.notify(
            self.tab.client,
            f"Marker {mirror.marker_name(k)} is off the plane",
            note.plain,
            "warning",
        )

    def _boundary_click(self, u: float, v: float) -> None:
        """A click in Boundary mode: start, extend or close the draft, or pick or move a corner."""
        editor, state, mirror = self.services.editor, self.tab.state, self._mirror()
        draft = state.drafts.get(mirror.id)
        if draft is not None:
            if nearest(draft, (u, v)) == 0 and len(draft) >= MIN_VERTICES:
                self._close_boundary()
                return
            state.drafts[mirror.id] = draft + ((round(u, 2), round(v, 2)),)
        elif state.picked_corner is not None:
            corner, state.picked_corner = state.picked_corner, None
            editor.move_vertex(mirror.id, corner, (u, v))
        elif (near := nearest(mirror.boundary, (u, v))) is not None:
            state.picked_corner = near
        elif mirror.boundary:
            raise MirrorscanError(
                f"{mirror.name} has a boundary: click a corner to pick and move it, or "
                "Clear boundary to draw it again"
            )
        else:
            state.drafts[mirror.id] = ((round(u, 2), round(v, 2)),)
        self.tab.changed()

    def _close_boundary(self) -> None:
        """Make the selected mirror's draft its boundary, then go on to its markers."""
        mirror_id, drafts = self._id(), self.tab.state.drafts
        # out of the drafts first: the tab redrawn on the new outline keeps no draft over it
        draft = drafts.pop(mirror_id, None)
        if not draft:
            raise MirrorscanError("no open boundary to close; click its corners first")
        try:
            self.services.editor.set_boundary(mirror_id, draft)
        except MirrorscanError:
            # kept to be mended or closed again, unless an outline was closed in another tab
            if not self.services.editor.mirror(mirror_id).boundary:
                drafts[mirror_id] = draft
            raise
        self.tab.state.mode = "markers" if len(self._mirror().markers) < 3 else "inspect"
        self.tab.changed()

    def _clear_boundary(self) -> None:
        """Drop the selected mirror's draft, or else clear its boundary."""
        mirror_id = self._id()
        if self.tab.state.drafts.pop(mirror_id, None) is None:
            self.services.editor.clear_boundary(mirror_id)
        self.tab.state.picked_corner = None
        self.tab.changed()

    def _delete_corner(self) -> None:
        """Delete the picked corner of the selected mirror's boundary."""
        self._delete_picked(
            "picked_corner",
            self.services.editor.delete_vertex,
            "pick a corner first: in Boundary mode, click a corner of the closed boundary",
        )

    def _start_move(self) -> None:
        """Move the picked marker to the next click."""
        if self.tab.state.picked_marker is None:
            raise MirrorscanError("pick a marker first: in Markers mode, click it")
        self.tab.state.moving_marker = True
        self.tab.changed()

    def _delete_marker(self) -> None:
        """Delete the picked marker of the selected mirror."""
        self._delete_picked(
            "picked_marker",
            self.services.editor.delete_marker,
            "pick a marker first: in Markers mode, click it",
        )

    def _delete_picked(self, attribute: str, delete, refusal: str) -> None:
        """Delete the picked corner or marker (`attribute` of the tab's state) of the mirror."""
        picked = getattr(self.tab.state, attribute)
        if picked is None:
            raise MirrorscanError(refusal)
        setattr(self.tab.state, attribute, None)
        delete(self._id(), picked)
        self.tab.changed()

    def _outline_buttons(self, shown: bool, closed: bool, drafted: int, picked: int | None) -> None:
        """Boundary mode's buttons, each only where it can act.

        Close boundary while an outline is drawn (greyed, with the corners still needed, below
        MIN_VERTICES), Delete the picked corner once it is closed (greyed until a corner is picked),
        Clear boundary whenever there is something to clear.
        """
        self.close.visible, self.delete_corner.visible = shown and not closed, shown and closed
        self.clear_boundary.visible = shown
        self.close.disabled = drafted < MIN_VERTICES
        self.close.label = (
            "Close boundary"
            if drafted >= MIN_VERTICES
            else f"Close boundary ({drafted} of the {MIN_VERTICES} corners it needs)"
        )
        self.delete_corner.disabled = picked is None
        self.delete_corner.label = (
            "Delete the picked corner" if picked is None else f"Delete corner {picked + 1}"
        )
        self.clear_boundary.disabled = not (closed or drafted)
