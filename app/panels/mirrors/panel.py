"""The Mirrors panel: its widgets, the selected mirror, the reports of the fits and of the
calibration from the object, undo and redo, and what the buttons offer."""

from __future__ import annotations

import asyncio
import time
from typing import Callable

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.session import MAX_MARKER_OFFSET

from ...context import TabContext
from ...editor import SESSION_SCOPE, SessionEditor
from ...events import JobProgress
from ...jobs import REFINE, planes_key
from ...overlays import QUALITY_COLOURS
from ...results import Fit
from ...wording import joined
from ...wording import agreement as agreement_words
from ...wording.greyed import greyed_out
from ...wording.markers import marker_list
from ...wording.mirrors import (
    CLICK_HINT,
    CLOSED_HELP,
    FIT_MARKERS,
    HELP,
    mirror_status,
    report_markdown,
)
from .clicks import MirrorClicks
from .fits import MirrorFits
from .jobs import MirrorJobs
from .reports import MirrorReports

TITLE = "Mirrors"
NO_MIRROR = "(no mirror yet)"
CLICK_MODES = {"Inspect": "inspect", "Markers": "markers", "Boundary": "boundary"}
GRADE_CSS = {grade: f"rgb{colour}" for grade, colour in QUALITY_COLOURS.items()}
# seconds: two clicks on Add a mirror this close are a double click (a desktop's usual setting)
DOUBLE_CLICK_S = 0.5


class MirrorsPanel(MirrorClicks, MirrorFits, MirrorJobs, MirrorReports):
    """Step 1: add and select mirrors, click their boundaries and markers, fit and calibrate them.

    Their boundaries and markers are clicked on the depth frame, their planes fitted to the
    markers or calibrated from the object; undo and redo go per mirror.

    Parameters
    ----------
    tab : TabContext
        The tab it is built in.
    """

    TITLE = TITLE

    def __init__(self, tab: TabContext):
        gui, self.tab, self.services = tab.gui, tab, tab.services
        jobs = self.services.jobs
        # mirror id -> the fit waiting for Apply or Discard
        self._proposal: dict[int, Fit] | None = None
        # the notification of the last calibration from the object, while it holds
        self._result_note = None
        # ... and of the fit waiting for Apply or Discard, while it waits
        self._proposal_note = None
        self._ready: dict[int, Fit] = {}  # the fits applied at once beside the last proposal
        self._flagged = ""  # the agreement lines last warned of in a notification
        # (time.monotonic(), the session it was made on) of the last click on Add a mirror that
        # was not the second of a double click
        self._last_add = (float("-inf"), tab.seen)
        self.mirror = gui.add_dropdown("Mirror", (NO_MIRROR,))
        # the selected mirror's plane, glass and markers
        self.status = gui.add_markdown("")
        # a proposal first, its details below its own buttons: Apply stays in view at 1024x600
        self.proposal_head = gui.add_markdown("", visible=False)
        self.apply = gui.add_button("Apply the new plane(s)", color="orange", visible=False)
        self.discard = gui.add_button("Discard the proposal", visible=False)
        self.review = gui.add_markdown("", visible=False)
        self.add = gui.add_button("Add a mirror")
        self.mode = gui.add_button_group("Click to", tuple(CLICK_MODES), hint=CLICK_HINT)
        # the mode's line, but in Inspect mode (the Redo button in view at 1024x600)
        self.help = gui.add_markdown("", visible=False)
        self.fit = gui.add_button("Fit plane", color="blue")
        self.fit_all = gui.add_button("Fit all planes")
        # Find above Refine: in view at 1024x600 where no plane is set
        self.scene = gui.add_button("Find the planes from the object (no markers)", visible=False)
        self.refine = gui.add_button("Refine from the object")
        self.refine_cancel = gui.add_button("Cancel", visible=False)
        self.refine_progress = gui.add_progress_bar(0.0, visible=False)
        self.greyed = gui.add_html("", visible=False)  # why the buttons above are greyed out
        # above the reports: in view at 1024x600
        self.undo = gui.add_button("Undo", disabled=True)
        self.redo = gui.add_button("Redo", disabled=True)
        # the report of what left the planes as they are, under the buttons that made it
        # the planes `result` describes
        self._result_planes = planes_key(self.services.editor.session)
        self._result_text, self._gone = report_markdown(jobs.report(self._result_planes)), ()
        self._names = {m.id: m.name for m in self.services.editor.session.mirrors}
        self.result = gui.add_markdown(self._result_text)
        self.agreement = gui.add_markdown(
            "" if jobs.agreement is None else joined(agreement_words.agreement(jobs.agreement))
        )
        self.move = gui.add_button("Move the picked marker", visible=False)
        self.delete = gui.add_button("Delete the picked marker", visible=False)
        self.close = gui.add_button("Close boundary", visible=False)
        self.delete_corner = gui.add_button("Delete the picked corner", visible=False)
        self.clear_boundary = gui.add_button("Clear boundary", visible=False)
        self.markers = gui.add_html("")
        with gui.add_folder("Rename, glass, remove, clear", expand_by_default=False):
            self.name = gui.add_text("Name", "")
            self.rename = gui.add_button("Rename")
            self.glass = gui.add_number(
                "Glass (mm)",
                initial_value=0.0,
                min=0.0,
                max=MAX_MARKER_OFFSET * 1e3,
                step=0.1,
                hint="how far the markers stand in front of the silver (the glass they "
                "are stuck on): a fit from the markers puts the plane this far behind them",
            )
            self.clear_markers = gui.add_button("Clear markers")
            self.remove = gui.add_button("Remove this mirror…", color="red")
            self.restore = gui.add_button("Undo", visible=False)
        self._wire()
        tab.on_click("markers", self._marker_click)
        tab.on_click("boundary", self._boundary_click)
        tab.on_state(lambda _: self.refresh())
        self._unsubscribe = self.services.bus.subscribe(JobProgress, self._on_job)
        self.refresh()

    @property
    def proposal(self) -> dict[int, Fit] | None:
        """The fits waiting for Apply or Discard, by mirror id."""
        return self._proposal

    @proposal.setter
    def proposal(self, fits: dict[int, Fit] | None) -> None:
        """Set the fits waiting; the tab's proposal_for follows and the waiting note goes.

        Parameters
        ----------
        fits : dict of int to Fit or None
            By mirror id; None when nothing waits.
        """
        self._proposal = fits
        self.tab.state.proposal_for = tuple(f.mirror.name for f in fits.values()) if fits else ()
        if self._proposal_note is not None:  # its "... waits, not applied" is over
            self._proposal_note.remove()
            self._proposal_note = None

    def detach(self) -> None:
        """Stop listening to the app (the tab closed)."""
        self._unsubscribe()

    def _wire(self) -> None:
        """Connect the panel's controls to their actions."""
        editor, act, jobs = self.services.editor, self.tab.act, self.services.jobs
        self.mirror.on_update(lambda e: e.client is not None and self._select(self.mirror.value))
        self.mode.on_click(lambda e: self._set_mode(CLICK_MODES[e.target.value]))
        self.add.on_click(self._add_clicked)
        self.fit.on_click(lambda _: act(lambda: self.fit_planes([self._id()])))
        self.fit_all.on_click(lambda _: act(self.fit_all_planes))
        self.apply.on_click(lambda _: act(self._apply))
        self.discard.on_click(lambda _: act(self._discard))
        self.undo.on_click(lambda _: act(lambda: self._travel(editor.undo)))
        self.redo.on_click(lambda _: act(lambda: self._travel(editor.redo)))
        self.move.on_click(lambda _: act(self._start_move))
        self.delete.on_click(lambda _: act(self._delete_marker))
        self.close.on_click(lambda _: act(self._close_boundary))
        self.delete_corner.on_click(lambda _: act(self._delete_corner))
        self.clear_boundary.on_click(lambda _: act(lambda: self._clear_boundary()))
        self.rename.on_click(
            lambda _: act(lambda: editor.rename_mirror(self._id(), self.name.value))
        )
        self.glass.on_update(lambda e: e.client is not None and act(self._set_glass))
        self.refine.on_click(lambda _: act(lambda: self._from_object(jobs.start_refine)))
        self.scene.on_click(lambda _: act(lambda: self._from_object(jobs.start_scene)))
        self.refine_cancel.on_click(lambda _: jobs.cancel(REFINE))
        self.clear_markers.on_click(lambda _: act(lambda: editor.clear_markers(self._id())))
        self.remove.on_click(lambda _: act(self._confirm_remove))
        self.restore.on_click(
            lambda _: act(lambda: self._travel_mirrors(lambda: editor.undo(SESSION_SCOPE)))
        )

    # ------------------------------------------------------------------ the selected mirror
    def _select(self, name: str) -> None:
        """Select the mirror named `name` (none when no mirror has it), dropping the picks."""
        mirror = next((m for m in self.services.editor.session.mirrors if m.name == name), None)
        state = self.tab.state
        state.mirror_id = None if mirror is None else mirror.id
        state.picked_marker = state.picked_corner = None
        state.moving_marker = False
        # a mode is chosen for a mirror, not carried to the next
        if state.mode in ("markers", "boundary"):
            state.mode = "inspect"
        self.tab.changed()

    def _set_mode(self, mode: str) -> None:
        """Set the click mode, dropping the picks; a mode of clicks shows the depth frame."""
        state = self.tab.state
        state.mode, state.picked_marker, state.picked_corner, state.moving_marker = (
            mode,
            None,
            None,
            False,
        )
        if mode != "inspect" and state.view != "depth":
            self.tab.look("depth")
        self.tab.changed()

    async def _add_clicked(self, _) -> None:
        """Add a mirror on the session the page had when the click came (the tab's `seen`).

        Taken in on viser's event loop, in the order the page's messages came. A click within
        DOUBLE_CLICK_S of the one before is the second of a double click: made on the same session
        as the first, it is refused once the first has added its mirror.
        """
        now = time.monotonic()
        if now - self._last_add[0] > DOUBLE_CLICK_S:
            self._last_add = (now, self.tab.seen)
        drawn = self._last_add[1]
        asyncio.get_running_loop().run_in_executor(None, self.tab.act, self._add, drawn)

    def _add(self) -> None:
        """Add a mirror, select it and start its boundary."""
        mirror_id = self.services.editor.add_mirror()
        self.tab.state.mirror_id = mirror_id
        self._set_mode("boundary")

    def _set_glass(self) -> None:
        """The glass typed in for the selected mirror.

        Refused (not 0 to 50 mm), the field shows the mirror's glass again.
        """
        editor = self.services.editor
        try:
            editor.set_marker_offset(self._id(), self.glass.value / 1e3)
        except MirrorscanError:
            self.glass.value = round(editor.mirror(self._id()).marker_offset * 1e3, 2)
            raise

    def _from_object(self, start: Callable[[SessionEditor], object]) -> None:
        """Start a calibration from the object (start_refine or start_scene), not over a proposal.

        It would refine the planes the proposal replaces.
        """
        if self.proposal is not None:
            raise MirrorscanError("a fit from the markers waits: apply or discard it first")
        start(self.services.editor)

    def _check_agreement(self) -> None:
        """After new planes: how the views agree on the last frames (a worker fills it in)."""
        self.services.jobs.start_agreement()

    # ------------------------------------------------------------------ what the panel shows
    def refresh(self) -> None:
        """Follow the session and the tab's state.

        The mirror list, the mode, the buttons, the markers.
        """
        session, state, editor = self.services.editor.session, self.tab.state, self.services.editor
        jobs = self.services.jobs
        names = tuple(m.name for m in session.mirrors) or (NO_MIRROR,)
        selected = next((m for m in session.mirrors if m.id == state.mirror_id), None)
        if self.mirror.options != names:
            self.mirror.options = names
        self.mirror.value = selected.name if selected else names[0]
        if selected and self.name.value != selected.name:
            self.name.value = selected.name
        if selected:
            self.glass.value = round(selected.marker_offset * 1e3, 2)
        from_object = selected is not None and jobs.from_object(selected.id, selected.plane)
        self.status.content = mirror_status(
            selected, from_object, selected is not None and editor.glass_unused(selected.id)
        )
        # the planes changed otherwise (calibrate in a
        if planes_key(session) != self._result_planes:
            self._follow_planes(session)  # terminal, a mirror added or removed)
        self._names = {m.id: m.name for m in session.mirrors}
        refining = jobs.running(REFINE)
        self.refine.disabled = refining or not any(m.plane is not None for m in session.mirrors)
        bare = [m.id for m in session.mirrors if m.boundary and m.plane is None]
        self.scene.visible = bool(bare)
        # not again while every mirror it would search was refused as it now is
        refused = jobs.refusals(session)
        self.scene.disabled = refining or all(refused.get(i) == "scene" for i in bare)
        has = selected is not None
        for button in (self.rename, self.remove):
            button.disabled = not has
        # the fits only where they can fit, and not while a refinement runs (it applies what it
        # computed on
        # the planes it started from)
        self.fit.disabled = refining or not has or len(selected.markers) < FIT_MARKERS
        self.fit_all.disabled = refining or not any(
            len(m.markers) >= FIT_MARKERS for m in session.mirrors
        )
        self.clear_markers.disabled = not has or not selected.markers
        self._mode_help(selected)
        scope = state.mirror_id or SESSION_SCOPE
        draft = state.drafts.get(scope)
        self._label(
            self.undo,
            "Undo",
            f"corner {len(draft)} of the outline"
            if draft
            else editor.undo_label(editor.travel_scope(state.mirror_id)),
        )
        self._label(
            self.redo, "Redo", editor.redo_label(editor.travel_scope(state.mirror_id, redo=True))
        )
        # what a refinement applies is computed on the planes as they were
        if refining:
            self.undo.disabled = self.redo.disabled = True
        elsewhere = (
            ()
            if not self.undo.disabled
            else tuple(m.name for m in session.mirrors if m.id != scope and editor.undo_label(m.id))
        )
        why = (
            ""
            if refining or self.proposal is not None
            else greyed_out(session, selected, refused, elsewhere)
        )
        self.greyed.content, self.greyed.visible = why, bool(why)
        restore = editor.undo_label(SESSION_SCOPE)
        self.restore.visible = bool(restore and restore.startswith("remove "))
        # named apart from the main Undo, which offers it too (travel_scope)
        if self.restore.visible:
            self.restore.label = f"Bring back {restore.removeprefix('remove ')}"
        self._drop_stale_proposal()
        self._show_proposal()
        residuals = (
            None if selected is None else self.services.snapshot.marker_residuals.get(selected.id)
        )
        self.markers.content = marker_list(selected, residuals, state.picked_marker, GRADE_CSS)

    def _mode_help(self, selected) -> None:
        """Show the click mode's help and its buttons.

        Markers: move, delete; boundary: close, delete, clear.
        """
        state = self.tab.state
        closed = state.mode == "boundary" and selected is not None and bool(selected.boundary)
        name = selected.name if selected is not None else "the mirror"
        self.help.content = (CLOSED_HELP if closed else HELP[state.mode]).format(name=name) + (
            " Now click where it goes." if state.moving_marker else ""
        )
        self.help.visible = bool(self.help.content)
        has = selected is not None
        picked = state.picked_marker is not None and has
        # only once a marker is picked: nothing to say before
        self.move.visible = self.delete.visible = state.mode == "markers" and picked
        if picked:
            which = f"marker {selected.id}.{state.picked_marker + 1}"
            self.move.label, self.delete.label = f"Move {which}", f"Delete {which}"
        self._outline_buttons(
            state.mode == "boundary" and has,
            has and bool(selected.boundary),
            len(state.drafts.get(state.mirror_id, ())),
            state.picked_corner,
        )

    @staticmethod
    def _label(button, verb: str, what: str | None) -> None:
        """Label an undo or redo button with what it does; grey it out when nothing."""
        button.disabled = what is None
        button.label = f"{verb}: {what}" if what else verb
