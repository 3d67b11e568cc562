"""Step 1, "Mirrors": add and select mirrors, click their boundaries and markers on the depth frame, fit their planes.
Every marker is listed and coloured by its distance to the plane against the depth noise; a single marker can be
picked, moved or deleted; a fit that would move a calibrated plane a lot, or that markers disagree with, is a
proposal shown beside the plane it would replace and applied only on confirmation, and so is a markers fit that
would replace a plane found from the object (by a refinement or a search). Undo and redo are per mirror."""
from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np

from mirrorcore.calibration.fit import calibrate_session
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.polygon import MIN_VERTICES
from mirrorcore.calibration.markers import MIN_MARKER_PIXELS, marker_points, review_fit
from mirrorcore.io.session import MAX_MARKER_OFFSET, Session, SessionMirror
from mirrorcore.base.words import listed

from ..context import TabContext
from ..editor import PARTIAL, PICK_RADIUS, SESSION_SCOPE, SessionEditor, fit_inputs
from ..events import JobProgress
from ..jobs import (AGREEMENT, CANCELLED, FAILED, FOUND_CHECK, GLASS_ADVICE, NOT_DONE, NOT_FOUND, NOT_FOUND_HEAD,
                   REFINE, UNCHANGED, UNDO_FOUND, UNDO_NOTE, planes_key)
from ..markup import escape, markdown
from ..overlays import QUALITY_COLOURS

TITLE = "Mirrors"
NO_MIRROR = "(no mirror yet)"
CLICK_MODES = {"Inspect": "inspect", "Markers": "markers", "Boundary": "boundary"}
HELP = {           # the click mode in force, named (the buttons do not show it), and the mirror the clicks go to
                   # (a click on another mirror's glass was taken for one off the mirror: a helper)
    "inspect": "**Inspect** mode: a click on the depth frame reads the pixel.",
    "markers": "**Markers** mode: click a marker's centre on **{name}** to add it; click an existing one to pick it.",
    "boundary": "**Boundary** mode: click the corners of **{name}** in order; click the first again to close.",
    "region": "**Region** mode: drawing the region of interest (Object step).",
}
CLOSED_HELP = ("**Boundary** mode: the outline of **{name}** is closed: click a corner to pick it, click again to "
               "move it, or *Clear boundary* to draw it again.")
NO_GLASS_NOTE = ("Markers stuck on an ordinary mirror's glass stand 3 to 6 mm in front of its silver, and a plane on "
                 "their faces is that much too near: **Refine from the object** measures the glass and moves the "
                 "plane behind it.")
PROPOSAL_HEAD = ("**Proposal, not applied**: look at it below{crossed}, then apply or discard it (the calibration "
                 "from the object waits for that).")
CROSSED = " and at the crossed markers"   # said only when a marker is crossed (a helper looked for crosses in vain)
GRADE_CSS = {grade: f"rgb{colour}" for grade, colour in QUALITY_COLOURS.items()}
NOTE_CHARS = 200           # a refusal longer than this is shortened in its notification (_refusal_note)
FIT_MARKERS = 3            # the markers a plane's fit needs
SMALL_TEXT = "font-size:0.8em;line-height:1.45;padding:0 12px"   # small print (the marker list, greyed_out),
                                                               # inset as the panel's text (raw HTML is not)


class MirrorsPanel:
    TITLE = TITLE

    def __init__(self, tab: TabContext):
        gui, self.tab, self.services = tab.gui, tab, tab.services
        self._proposal: dict[int, tuple] | None = None   # mirror id -> (plane, mirror as fitted, review)
        self._result_note = None            # the notification of the last calibration from the object, while it holds
        self._proposal_note = None          # ... and of the fit waiting for Apply or Discard, while it waits
        self._ready: dict[int, tuple] = {}  # the fits applied at once beside the last proposal (its report's too)
        self._flagged = ""                  # the agreement lines last warned of in a notification
        self.mirror = gui.add_dropdown("Mirror", (NO_MIRROR,))
        self.status = gui.add_markdown("")                      # the selected mirror's plane, glass and markers
        # a proposal comes first and its details below its own buttons: at 1024x600 Apply stays in view (under the
        # click modes, it showed as a sliver at the window's bottom edge: a helper)
        self.proposal_head = gui.add_markdown("", visible=False)
        self.apply = gui.add_button("Apply the new plane(s)", color="orange", visible=False)
        self.discard = gui.add_button("Discard the proposal", visible=False)
        self.review = gui.add_markdown("", visible=False)
        self.add = gui.add_button("Add a mirror")
        self.mode = gui.add_button_group("Click to", tuple(CLICK_MODES))
        self.help = gui.add_markdown(HELP["inspect"])
        self.fit = gui.add_button("Fit plane", color="blue")
        self.fit_all = gui.add_button("Fit all planes")
        self.scene = gui.add_button("Find the planes from the object (no markers)", visible=False)   # above Refine:
        self.refine = gui.add_button("Refine from the object")   # in view at 1024x600 where no plane is set (a helper)
        self.refine_cancel = gui.add_button("Cancel", visible=False)
        self.refine_progress = gui.add_progress_bar(0.0, visible=False)
        self.greyed = gui.add_html("", visible=False)   # why the buttons above are greyed out (viser 1.1 shows no
                                                        # hint on a button: a greyed Find said nothing, a helper)
        self.undo = gui.add_button("Undo", disabled=True)    # above the reports: in view at 1024x600 after them
        self.redo = gui.add_button("Redo", disabled=True)
        # a fit's or refinement's report, under the buttons that made it; a tab opened (or reloaded) later shows the
        # report of the refinement or fit that left the planes as they are
        self._result_planes = planes_key(self.services.editor.session)     # the planes `result` describes
        self._result_text, self._gone = self.services.jobs.report(self._result_planes), ()
        self._names = {m.id: m.name for m in self.services.editor.session.mirrors}   # as the last refresh saw them
        self.result = gui.add_markdown(markdown(self._result_text))
        self.agreement = gui.add_markdown(markdown(self.services.jobs.agreement))
        self.move = gui.add_button("Move the picked marker", visible=False)
        self.delete = gui.add_button("Delete the picked marker", visible=False)
        self.close = gui.add_button("Close boundary", visible=False)
        self.delete_corner = gui.add_button("Delete the picked corner", visible=False)
        self.clear_boundary = gui.add_button("Clear boundary", visible=False)
        self.markers = gui.add_html("")
        with gui.add_folder("Rename, glass, remove, clear", expand_by_default=False):
            self.name = gui.add_text("Name", "")
            self.rename = gui.add_button("Rename")
            self.glass = gui.add_number("Glass (mm)", initial_value=0.0, min=0.0,    # as every message calls it
                                        max=MAX_MARKER_OFFSET * 1e3, step=0.1,       # (a helper)
                                        hint="how far the markers stand in front of the silver (the glass they "
                                        "are stuck on): a fit from the markers puts the plane this far behind them")
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
    def proposal(self) -> dict[int, tuple] | None:
        """The fit waiting for Apply or Discard: {mirror id: (calibration, the mirror as fitted, review)}."""
        return self._proposal

    @proposal.setter
    def proposal(self, fits: dict[int, tuple] | None) -> None:
        self._proposal = fits
        self.tab.state.proposal_for = tuple(mirror.name for _, mirror, _ in fits.values()) if fits else ()
        if self._proposal_note is not None:    # "... waits, not applied" holds no longer (it had stayed up after
            self._proposal_note.remove()       # Apply, over the figure at 1024x600: a helper)
            self._proposal_note = None

    def detach(self) -> None:
        """Stop listening to the app (the tab closed)."""
        self._unsubscribe()

    def _on_job(self, event: JobProgress) -> None:
        """The refinement's progress and report, and the views' agreement after a fit."""
        if event.job == REFINE:
            running = event.fraction is not None
            self.refine.disabled, self.refine_cancel.visible = running, running
            self.scene.disabled = self.undo.disabled = self.redo.disabled = running
            self.greyed.visible = self.greyed.visible and not running
            if running:                                         # after it, refresh() says what is offered
                self.fit.disabled = self.fit_all.disabled = True
                self.refine_progress.value = event.percent
            self.refine_progress.visible = running
            self._report(self._cancelled() if event.status == CANCELLED else event.status)
            if not running and event.status != CANCELLED:       # its end, in view whatever the panel's scroll,
                refused = event.status.startswith((NOT_DONE, FAILED))
                headline = event.status.split("\n\n")[0]
                self._result_note = self.services.notify(          # until the planes change again (_report)
                    self.tab.client, "Calibration from the object",
                    _refusal_note(headline) if refused else _result_note(event.status),
                    "error" if refused else "warning" if _not_found(headline) else "info", stay=True, logged=False)
            if not running:
                self.refresh()                      # Undo and Redo as they now stand (a refusal changes nothing)
        elif event.job == AGREEMENT:
            self.agreement.content = markdown(event.status)
            if event.fraction is None:
                self._warn_disagreement(event.status)

    def _cancelled(self) -> str:
        """A calibration from the object cancelled: the planes are as they were, and so is their report (a bare
        'cancelled' had replaced it: a helper)."""
        before = self.services.jobs.report(planes_key(self.services.editor.session))
        return "Cancelled: the planes are as they were." + (f"\n\n{before}" if before else "")

    def _warn_disagreement(self, lines: str) -> None:
        """A notification naming the mirrors the agreement lines flag (⚠), not again for the same lines: they may be
        out of view (at 1024x600 two screens down, and the fit's note had said only "Applied": a helper)."""
        flagged = [line.split(":")[0] for line in lines.split("\n\n") if "⚠" in line]
        if flagged and lines != self._flagged:
            views = "its view disagrees" if len(flagged) == 1 else "their views disagree"
            self.services.notify(self.tab.client, "The views disagree",
                                 f"{listed(flagged)}: ⚠ {views} with the others beyond the depth noise; why and "
                                 "what to do are under Mirrors, below the buttons.", "warning", logged=False)
        self._flagged = lines if flagged else ""

    def _wire(self) -> None:
        editor, act = self.services.editor, self.tab.act
        self.mirror.on_update(lambda e: e.client is not None and self._select(self.mirror.value))
        self.mode.on_click(lambda e: self._set_mode(CLICK_MODES[e.target.value]))
        self.add.on_click(lambda _: act(self._add))
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
        self.rename.on_click(lambda _: act(lambda: editor.rename_mirror(self._id(), self.name.value)))
        self.glass.on_update(lambda e: e.client is not None and act(self._set_glass))
        self.refine.on_click(lambda _: act(lambda: self._from_object(self.services.jobs.start_refine)))
        self.scene.on_click(lambda _: act(lambda: self._from_object(self.services.jobs.start_scene)))
        self.refine_cancel.on_click(lambda _: self.services.jobs.cancel(REFINE))
        self.clear_markers.on_click(lambda _: act(lambda: editor.clear_markers(self._id())))
        self.remove.on_click(lambda _: act(self._confirm_remove))
        self.restore.on_click(lambda _: act(lambda: self._travel_mirrors(lambda: editor.undo(SESSION_SCOPE))))

    # ------------------------------------------------------------------ the selected mirror
    def _id(self) -> int:
        """The selected mirror's id; MirrorscanError when there is none."""
        if self.tab.state.mirror_id is None:
            raise MirrorscanError("add a mirror first (Mirrors › Add a mirror)")
        return self.tab.state.mirror_id

    def _mirror(self) -> SessionMirror:
        return self.services.editor.mirror(self._id())

    def _select(self, name: str) -> None:
        mirror = next((m for m in self.services.editor.session.mirrors if m.name == name), None)
        state = self.tab.state
        state.mirror_id = None if mirror is None else mirror.id
        state.picked_marker = state.picked_corner = None
        state.moving_marker = False
        if state.mode in ("markers", "boundary"):     # a mode is chosen for a mirror, not carried to the next
            state.mode = "inspect"
        self.tab.changed()

    def _set_mode(self, mode: str) -> None:
        state = self.tab.state
        state.mode, state.picked_marker, state.picked_corner, state.moving_marker = mode, None, None, False
        if mode != "inspect" and state.view != "depth":
            self.tab.look("depth")
        self.tab.changed()

    def _add(self) -> None:
        mirror_id = self.services.editor.add_mirror()
        self.tab.state.mirror_id = mirror_id
        self._set_mode("boundary")

    # ------------------------------------------------------------------ clicks on the depth frame
    def _marker_click(self, u: float, v: float) -> None:
        editor, state, mirror = self.services.editor, self.tab.state, self._mirror()
        if state.moving_marker and state.picked_marker is not None:
            editor.move_marker(mirror.id, state.picked_marker, (u, v))
            state.moving_marker = False
        else:
            near = _nearest(mirror.markers, (u, v))
            if near is not None:
                state.picked_marker = None if near == state.picked_marker else near
            else:
                state.picked_marker = editor.add_marker(mirror.id, (u, v))
                self._warn_if_off(mirror.id, state.picked_marker)
        self.tab.changed()

    def _warn_if_off(self, mirror_id: int, k: int) -> None:
        """A marker just added with no depth under it, or far off its mirror's plane (a click on the object seen in
        the mirror, or beside the sticker), is told at once, where the click was made; the next fit would refuse it,
        or show it crossed, as a proposal. The depth is looked for on the frames a fit reads, with or without a plane
        (on a mirror with none, four clicks on glass that read nothing were told only by the fit: a helper)."""
        mirror = self.services.editor.mirror(mirror_id)
        frames = self.services.jobs.marker_frames()
        if frames is not None and k < len(mirror.markers) and len(marker_points(
                self.services.snapshot.rig.intrinsics, frames, mirror.markers[k])) < MIN_MARKER_PIXELS:
            self.services.notify(self.tab.client, f"Marker {mirror.marker_name(k)} has no depth",
                                 "the camera reads nothing there in the recent frames: a fit cannot use it (click "
                                 "the sticker's centre; Undo takes it back)", "warning")
            return
        residuals = self.services.snapshot.marker_residuals.get(mirror_id)
        if residuals is None or k >= len(residuals.grades) or residuals.grades[k] != "poor":
            return
        d, s = residuals.signed_mm[k], residuals.sigma_mm[k]
        where = "behind something in front of the mirror" if d > 0 else "off the glass (on the object seen in it?)"
        self.services.notify(self.tab.client, f"Marker {mirror.marker_name(k)} is off the plane",
                             f"{abs(d):.0f} mm ({abs(d) / s:.0f}σ) from {mirror.name}'s plane: {where}. Undo "
                             "takes it back; a fit would leave it out and ask first.", "warning")

    def _boundary_click(self, u: float, v: float) -> None:
        editor, state, mirror = self.services.editor, self.tab.state, self._mirror()
        draft = state.drafts.get(mirror.id)
        if draft is not None:
            if _nearest(draft, (u, v)) == 0 and len(draft) >= MIN_VERTICES:
                self._close_boundary()
                return
            state.drafts[mirror.id] = draft + ((round(u, 2), round(v, 2)),)
        elif state.picked_corner is not None:
            corner, state.picked_corner = state.picked_corner, None
            editor.move_vertex(mirror.id, corner, (u, v))
        elif (near := _nearest(mirror.boundary, (u, v))) is not None:
            state.picked_corner = near
        elif mirror.boundary:
            raise MirrorscanError(f"{mirror.name} has a boundary: click a corner to pick and move it, or "
                                  "Clear boundary to draw it again")
        else:
            state.drafts[mirror.id] = ((round(u, 2), round(v, 2)),)
        self.tab.changed()

    def _close_boundary(self) -> None:
        mirror_id = self._id()
        draft = self.tab.state.drafts.get(mirror_id)
        if not draft:
            raise MirrorscanError("no open boundary to close; click its corners first")
        self.services.editor.set_boundary(mirror_id, draft)
        del self.tab.state.drafts[mirror_id]
        self.tab.state.mode = "markers" if len(self._mirror().markers) < 3 else "inspect"
        self.tab.changed()

    def _clear_boundary(self) -> None:
        mirror_id = self._id()
        if self.tab.state.drafts.pop(mirror_id, None) is None:
            self.services.editor.clear_boundary(mirror_id)
        self.tab.state.picked_corner = None
        self.tab.changed()

    def _delete_corner(self) -> None:
        self._delete_picked("picked_corner", self.services.editor.delete_vertex,
                            "pick a corner first: in Boundary mode, click a corner of the closed boundary")

    def _start_move(self) -> None:
        if self.tab.state.picked_marker is None:
            raise MirrorscanError("pick a marker first: in Markers mode, click it")
        self.tab.state.moving_marker = True
        self.tab.changed()

    def _delete_marker(self) -> None:
        self._delete_picked("picked_marker", self.services.editor.delete_marker,
                            "pick a marker first: in Markers mode, click it")

    def _delete_picked(self, attribute: str, delete, refusal: str) -> None:
        """Delete the picked corner or marker (the tab state's `attribute`) of the selected mirror."""
        picked = getattr(self.tab.state, attribute)
        if picked is None:
            raise MirrorscanError(refusal)
        setattr(self.tab.state, attribute, None)
        delete(self._id(), picked)
        self.tab.changed()

    def _travel(self, move) -> None:
        """Undo or redo in the selected mirror's scope, or in the session's when that holds the newer step
        (SessionEditor.travel_scope); undo while an outline is drawn takes its last corner back (it removed the
        mirror being drawn: a helper)."""
        editor = self.services.editor
        draft = self.tab.state.drafts.get(self.tab.state.mirror_id)
        if move == editor.undo and draft:
            if len(draft) > 1:
                self.tab.state.drafts[self.tab.state.mirror_id] = draft[:-1]
            else:
                del self.tab.state.drafts[self.tab.state.mirror_id]
            self.tab.changed()
            return
        before = planes_key(editor.session)
        label = move(editor.travel_scope(self.tab.state.mirror_id, redo=move == editor.redo))
        self.tab.state.picked_marker = self.tab.state.picked_corner = None
        self._report(self._report_after_travel(before, planes_key(editor.session), label, move == editor.undo))
        self._check_agreement()                    # the views' agreement with the planes now
        self.tab.changed()

    def _report(self, text: str, gone: tuple[str, ...] = ()) -> None:
        """Show a fit's or refinement's report, for the planes as they are now, and the mirrors it names that were
        removed since; the notification of the last calibration from the object goes (it stays a while: one told
        after it would stack under it)."""
        self._result_planes, self._result_text, self._gone = planes_key(self.services.editor.session), text, gone
        self.result.content = markdown(text + (f"\n\n*{listed(gone)} {'was' if len(gone) == 1 else 'were'} removed "
                                               "since.*" if gone else ""))
        if self._result_note is not None:
            self._result_note.remove()
            self._result_note = None

    def _follow_planes(self, session: Session) -> None:
        """The planes changed other than by this panel: the report of the refinement or fit that left them so, else
        the report shown while it still describes every plane (mirrors only added without a plane, or removed: a
        Find's report had gone with a mirror removed after it, a helper), naming those removed, else none."""
        key = planes_key(session)
        known = self.services.jobs.report(key)
        if known:
            self._report(known)
            return
        before, now = dict(self._result_planes), dict(key)
        if any(before[i] != now[i] for i in before.keys() & now.keys()) or \
                any(now[i] is not None for i in now.keys() - before.keys()) or not self._result_text:
            self._report("")
            return
        gone = tuple(self._names.get(i, f"mirror {i}") for i in before.keys() - now.keys())
        self._report(self._result_text, self._gone + gone)

    def _report_after_travel(self, before: tuple, after: tuple, label: str, undone: bool) -> str:
        """After an undo or redo (of the step `label`): the report of the refinement whose planes are back, or the
        headline of the one undone (or a line naming the step, or its part: the others changed since), then the
        report of the markers fit whose planes are back; nothing when the planes stayed (the last fit's report no
        longer describes the mirrors)."""
        refinements, verb = self.services.jobs.refinements, "Undone" if undone else "Redone"
        if after in refinements:
            return refinements[after]
        if before == after:
            return ""
        if PARTIAL in label or refinements.get(before, UNCHANGED).startswith(UNCHANGED):
            step = f"{verb}: {label}."    # no report of these planes (a mirror removed since), or one of a
                                          # refinement that changed nothing (it read "Undone: Nothing changed" with
                                          # both planes gone, or nothing: helpers)
        else:
            headline = refinements[before].split("\n\n")[0].removesuffix(f" {UNDO_NOTE}").removesuffix(f" {UNDO_FOUND}")
            step = f"{verb}: " + headline.replace(FOUND_CHECK, "", 1)    # its advice was for the planes undone
        fit = self.services.jobs.fits.get(after)
        return f"{step}\n\n{fit}" if fit else step

    def _confirm_remove(self) -> None:
        mirror = self._mirror()
        self.tab.ask(f"Remove {mirror.name}?", removal_question(mirror), f"Remove {mirror.name}",
                     lambda: self._travel_mirrors(lambda: self.services.editor.remove_mirror(mirror.id)), "Keep it")

    def _travel_mirrors(self, change: Callable[[], object]) -> None:
        """A mirror removed, or brought back (its Undo): then how the views agree (the lines had kept the removed
        mirror's figures: a helper)."""
        change()
        self._check_agreement()

    # ------------------------------------------------------------------ plane fitting
    def _from_object(self, start: Callable[[SessionEditor], object]) -> None:
        """Start a calibration from the object (Jobs.start_refine or start_scene), but not over a proposal: it would
        refine the planes the proposal replaces, and the proposal would go unsaid (a helper)."""
        if self.proposal is not None:
            raise MirrorscanError("a fit from the markers waits: apply or discard it first")
        start(self.services.editor)

    def fit_all_planes(self) -> None:
        """Fit every mirror that has markers (fit_planes); those without are left as they are and named in the note
        (Fit all had refused the lot for one mirror without markers, which the start hint had not counted: a
        helper, three mirrors around a person)."""
        mirrors = self.services.editor.session.mirrors
        if not any(m.markers for m in mirrors):
            raise MirrorscanError("no mirror has markers: click 3 or more on each in Markers mode, or use Find the "
                                  "planes from the object (no markers)")
        self.fit_planes([m.id for m in mirrors if m.markers], tuple(m.name for m in mirrors if not m.markers))

    def fit_planes(self, mirror_ids: list[int], without_markers: tuple[str, ...] = ()) -> None:
        """Calibrate the given mirrors from their markers (on Jobs.marker_frames), all or nothing. A fit
        that needs a look (mirrorcore.calibration.markers.review_fit) becomes a proposal; the others are applied at once.
        Refused while a calibration from the object runs: it applies what it computed on the planes as they were.
        without_markers : the names of the mirrors Fit all left out, for the note."""
        if self.services.jobs.running(REFINE):
            raise MirrorscanError("a calibration from the object runs: wait for it, or cancel it, then fit")
        depth = self.services.jobs.marker_frames()
        if depth is None:
            raise MirrorscanError("no frame yet to calibrate from")
        session = self.services.editor.session
        indices = [session.mirror_index(i) for i in mirror_ids]
        bare = next((session.mirrors[i] for i in indices if not session.mirrors[i].markers), None)
        if bare is not None and bare.boundary and bare.plane is None:
            raise MirrorscanError(f"{bare.name} has no markers: click 3 or more in Markers mode, or use Find the "
                                  "planes from the object (no markers)")
        _, results = calibrate_session(session, depth, np.random.default_rng(0), indices)
        fits = {}
        for i, calibration in results:
            mirror = session.mirrors[i]
            review = review_fit(mirror.plane, calibration.plane, calibration.markers, np.asarray(calibration.centre),
                                mirror.marker_names, self.services.editor.fitted_on_its_markers(mirror.id))
            if self.services.jobs.from_object(mirror.id, mirror.plane):
                review = replace(review, concerns=review.concerns + (
                    "it replaces the plane found from the object: the markers alone are less accurate (the "
                    f"refinement moved it{_glass_source(mirror)}); refine again after applying",))
            fits[mirror.id] = (calibration, mirror, review)
        waiting = {i: fit for i, fit in fits.items() if fit[2].needs_confirmation}   # the others are applied (all
        ready = {i: fit for i, fit in fits.items() if i not in waiting}             # had waited for one: a helper)
        if ready:
            self._apply_fits(ready, _fit_report(ready.values()))
        self.proposal, self._ready = waiting or None, ready
        if not ready:
            self._report("")
        self.tab.state.flagged_markers = _flags(fits)
        look = waiting or without_markers or any(r.poor for _, _, r in fits.values())
        note = self.services.notify(self.tab.client, "Fit from the markers",
                                    fit_note(ready.values(), waiting.values(), without_markers),
                                    "warning" if look else "info")
        if waiting:
            self._proposal_note = note
        self.tab.changed()

    def _set_glass(self) -> None:
        """The glass typed in for the selected mirror; refused (not 0 to 50 mm), the field shows the mirror's glass
        again (it had kept '-5' beside a line that said 1.7 mm: a helper)."""
        editor = self.services.editor
        try:
            editor.set_marker_offset(self._id(), self.glass.value / 1e3)
        except MirrorscanError:
            self.glass.value = round(editor.mirror(self._id()).marker_offset * 1e3, 2)
            raise

    def _check_agreement(self) -> None:
        """After new planes: how the views agree on the last frames (a worker fills it in)."""
        self.services.jobs.start_agreement()

    def _apply(self) -> None:
        """The proposal applied; the report names the planes of the same fit applied at once too."""
        fits, self.proposal = self.proposal, None
        self.tab.state.flagged_markers = ()
        if fits:
            self._apply_fits(fits, _fit_report([*self._ready.values(), *fits.values()], confirmed=tuple(fits)))
        self.tab.changed()

    def _apply_fits(self, fits: dict, report: str) -> None:
        """Markers fits' planes ({mirror id: (Calibration, SessionMirror, FitReview)}) into the session, their report
        shown and kept by the planes they leave (Jobs.fits: an undo brings it back), the views' agreement checked."""
        editor = self.services.editor
        editor.set_planes({mirror_id: (c.plane, m) for mirror_id, (c, m, _) in fits.items()})
        self.services.jobs.fits[planes_key(editor.session)] = report
        self._report(report)
        self._check_agreement()

    def _discard(self) -> None:
        """The proposal discarded; the planes of the same fit applied at once stay, and their report."""
        waiting = [m.name for _, m, _ in (self.proposal or {}).values()]
        self.proposal = None
        self.tab.state.flagged_markers = ()
        self._report(f"{_fit_report(self._ready.values())}\n\n{listed(waiting)}: the proposed "
                     f"plane{'s' if len(waiting) > 1 else ''} discarded, as before." if self._ready else
                     "The proposed plane(s) were discarded; nothing changed.")
        self.tab.changed()

    # ------------------------------------------------------------------ what the panel shows
    def refresh(self) -> None:
        """Follow the session and the tab's state: the mirror list, the mode, the buttons, the markers."""
        session, state, editor = self.services.editor.session, self.tab.state, self.services.editor
        names = tuple(m.name for m in session.mirrors) or (NO_MIRROR,)
        selected = next((m for m in session.mirrors if m.id == state.mirror_id), None)
        if self.mirror.options != names:
            self.mirror.options = names
        self.mirror.value = selected.name if selected else names[0]
        if selected and self.name.value != selected.name:
            self.name.value = selected.name
        if selected:
            self.glass.value = round(selected.marker_offset * 1e3, 2)
        from_object = selected is not None and self.services.jobs.from_object(selected.id, selected.plane)
        self.status.content = mirror_status(selected, from_object,
                                            selected is not None and editor.glass_unused(selected.id))
        if planes_key(session) != self._result_planes:       # the planes changed otherwise (calibrate in a
            self._follow_planes(session)                      # terminal, a mirror added or removed)
        self._names = {m.id: m.name for m in session.mirrors}
        refining = self.services.jobs.running(REFINE)
        self.refine.disabled = refining or not any(m.plane is not None for m in session.mirrors)
        bare = [m.id for m in session.mirrors if m.boundary and m.plane is None]
        self.scene.visible = bool(bare)                       # not again while every mirror it would search was
        refused = self.services.jobs.refusals(session)        # refused as it now is (it gave the same refusal: a
        self.scene.disabled = refining or all(refused.get(i) == "scene" for i in bare)      # helper)
        has = selected is not None
        for button in (self.rename, self.remove):
            button.disabled = not has
        # the fits offered only when they can fit ("0 usable marker(s) of 0"; Fit all with no marker anywhere said
        # "not done": helpers); not while a refinement runs, which applies what it computed on the planes it started
        # from
        self.fit.disabled = refining or not has or len(selected.markers) < FIT_MARKERS
        self.fit_all.disabled = refining or not any(len(m.markers) >= FIT_MARKERS for m in session.mirrors)
        self.clear_markers.disabled = not has or not selected.markers
        closed = state.mode == "boundary" and selected is not None and bool(selected.boundary)
        name = selected.name if selected is not None else "the mirror"
        self.help.content = (CLOSED_HELP if closed else HELP[state.mode]).format(name=name) + (
            " Now click where it goes." if state.moving_marker else "")
        markers, boundary = state.mode == "markers", state.mode == "boundary"
        picked = state.picked_marker is not None and has
        self.move.visible = self.delete.visible = markers
        self.move.disabled = self.delete.disabled = not picked
        which = f"marker {selected.id}.{state.picked_marker + 1}" if picked else "the picked marker"
        self.move.label, self.delete.label = f"Move {which}", f"Delete {which}"
        self._outline_buttons(boundary and has, has and bool(selected.boundary),
                              len(state.drafts.get(state.mirror_id, ())), state.picked_corner)
        scope = state.mirror_id or SESSION_SCOPE
        draft = state.drafts.get(scope)
        self._label(self.undo, "Undo", f"corner {len(draft)} of the outline" if draft else
                    editor.undo_label(editor.travel_scope(state.mirror_id)))
        self._label(self.redo, "Redo", editor.redo_label(editor.travel_scope(state.mirror_id, redo=True)))
        if refining:                  # what a refinement applies is computed on the planes as they were
            self.undo.disabled = self.redo.disabled = True
        elsewhere = () if not self.undo.disabled else tuple(
            m.name for m in session.mirrors if m.id != scope and editor.undo_label(m.id))
        why = "" if refining or self.proposal is not None else greyed_out(session, selected, refused, elsewhere)
        self.greyed.content, self.greyed.visible = why, bool(why)
        restore = editor.undo_label(SESSION_SCOPE)
        self.restore.visible = bool(restore and restore.startswith("remove "))
        if self.restore.visible:           # named apart from the main Undo, which offers it too (travel_scope)
            self.restore.label = f"Bring back {restore.removeprefix('remove ')}"
        self._drop_stale_proposal()
        self._show_proposal()
        self.markers.content = self._marker_list(selected)

    def _outline_buttons(self, shown: bool, closed: bool, drafted: int, picked: int | None) -> None:
        """Boundary mode's buttons, each only where it can act: Close boundary while an outline is drawn (greyed,
        with the corners still needed, below 3), Delete the picked corner once it is closed (greyed, as Move the
        picked marker, until a corner is picked: the help says how); Clear boundary whenever there is something to
        clear. (Both had stood greyed, with no reason given, where they could never act.)"""
        self.close.visible, self.delete_corner.visible = shown and not closed, shown and closed
        self.clear_boundary.visible = shown
        self.close.disabled = drafted < MIN_VERTICES
        self.close.label = ("Close boundary" if drafted >= MIN_VERTICES else
                            f"Close boundary ({drafted} of the {MIN_VERTICES} corners it needs)")
        self.delete_corner.disabled = picked is None
        self.delete_corner.label = "Delete the picked corner" if picked is None else f"Delete corner {picked + 1}"
        self.clear_boundary.disabled = not (closed or drafted)

    @staticmethod
    def _label(button, verb: str, what: str | None) -> None:
        button.disabled = what is None
        button.label = f"{verb}: {what}" if what else verb

    def _drop_stale_proposal(self) -> None:
        """A proposal for a mirror whose markers, boundary, glass or plane changed since the fit (a marker the
        proposal flagged deleted, say) could no longer be applied: drop it, so that Fit plane is offered again."""
        if self.proposal is None:
            return
        current = {m.id: m for m in self.services.editor.session.mirrors}
        stale = [fitted.name for _, fitted, _ in self.proposal.values()
                 if fit_inputs(current.get(fitted.id)) != fit_inputs(fitted)]
        if stale:
            again = "**Fit all planes**" if len(self.proposal) > 1 else "**Fit plane**"    # as it was fitted (a
            self.proposal, self.tab.state.flagged_markers = None, ()                   # helper, told to Fit plane
            self._report(f"The proposal was dropped: {', '.join(stale)} changed since it was fitted. {again} "
                         "again.")                                                    # after Fit all planes)
            self.tab.changed()                        # its crossed-out markers leave the depth frame

    def _show_proposal(self) -> None:
        fits = self.proposal
        for handle in (self.proposal_head, self.review, self.apply, self.discard):
            handle.visible = fits is not None
        self.fit.disabled = self.fit.disabled or fits is not None
        self.fit_all.disabled = self.fit_all.disabled or fits is not None
        self.refine.disabled = self.refine.disabled or fits is not None   # it would refine the planes the proposal
        self.scene.disabled = self.scene.disabled or fits is not None     # replaces, and drop it unsaid
        if fits is None:
            return
        self.proposal_head.content = PROPOSAL_HEAD.format(crossed=CROSSED if _flags(fits) else "")
        lines = []
        for calibration, mirror, review in fits.values():
            old = "uncalibrated" if mirror.plane is None else (f"turned {review.tilt_deg:.2f}°, moved "
                                                               f"{review.shift_mm:.1f} mm")
            lines.append(f"- **{mirror.name}**: {old}; {calibration.summary(mirror.marker_names)}")
            lines += [f"  - ⚠ {concern}" for concern in review.concerns]
        self.review.content = markdown("\n".join(lines))

    def _marker_list(self, mirror: SessionMirror | None) -> str:
        """Every marker of the mirror with its distance to the plane and the noise there, in its grade's colour (the
        colour of its centre on the depth frame); a poor one says which way it is off."""
        if mirror is None or not mirror.markers:
            return ""
        residuals = self.services.snapshot.marker_residuals.get(mirror.id)
        rows = []
        for k, (u, v) in enumerate(mirror.markers):
            name = mirror.marker_name(k)
            if k == self.tab.state.picked_marker:
                name = f"<b>{name}</b>"
            if residuals is None:
                rows.append(_dot("unknown") + f"{name} ({u:.0f}, {v:.0f})")
                continue
            grade, d, s = residuals.grades[k], residuals.signed_mm[k], residuals.sigma_mm[k]
            text = "no depth" if not np.isfinite(d) else f"{abs(d):.1f} mm ({abs(d) / s:.1f}σ)"
            if grade == "poor":
                text += " (hidden by something in front?)" if d > 0 else " (off the glass?)"
            rows.append(_dot(grade) + f"{name} {text}")
        legend = "" if residuals is None else (f"{_dot('good')}within 2σ of the plane {_dot('fair')}3σ "
                                               f"{_dot('poor')}beyond (σ: the depth noise at the marker)")
        return (f'<div style="{SMALL_TEXT}">{legend}<br>'
                + " · ".join(f'<span style="white-space:nowrap">{r}</span>' for r in rows) + "</div>")


def _flags(fits: dict[int, tuple]) -> tuple[tuple[int, tuple[float, float]], ...]:
    """(mirror id, marker's pixel (u, v)) of every poor marker of the fits ({id: (Calibration, SessionMirror,
    FitReview)}): crossed on the depth frame whichever mirror is selected (the note names them all; a helper saw
    mirror 2's crossed only once it was selected), until that marker is moved or deleted."""
    return tuple((mirror.id, mirror.markers[k]) for _, mirror, review in fits.values() for k in review.poor)


def _dot(grade: str) -> str:
    return (f'<span style="display:inline-block;width:0.7em;height:0.7em;border-radius:50%;margin:0 0.25em;'
            f'background:{GRADE_CSS[grade]}"></span>')


def _nearest(points, uv) -> int | None:
    """The index of the point (u, v) within PICK_RADIUS pixels of uv, or None."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if not len(points):
        return None
    dist = np.hypot(*(points - np.asarray(uv, dtype=float)).T)
    k = int(np.argmin(dist))
    return k if dist[k] <= PICK_RADIUS else None


def _refusal_note(refusal: str) -> str:
    """A refusal for a notification: up to NOTE_CHARS whole, beyond that the words before its first parenthesis and
    where the rest is (one of 400 characters had the notification's title cut off: a helper)."""
    if len(refusal) <= NOTE_CHARS or " (" not in refusal:
        return refusal
    return f"{refusal[:refusal.index(' (')]}; why and what to do are under Mirrors."


def _result_note(report: str) -> str:
    """A calibration's report for its notification: its headline's first sentence (the planes' changes and glass)
    and where the rest is (with the advice on the glass, it had run past the notification's height: a helper); then
    the mirrors not found, with the first one's why (NOT_FOUND in its details), shortened as a refusal's is (at
    1024x600 the report's line is a long scroll down: a helper)."""
    headline = report.split("\n\n")[0]
    first = headline.split(". ")[0].removesuffix(".").removesuffix(FOUND_CHECK)    # nothing is below a note
    glass = "; the glass: type it in if you know it" if GLASS_ADVICE in headline else ""
    note = f"{first}. Under Mirrors: the report{glass}."
    missing = _not_found(headline)
    if not missing:
        return note
    why = next((line.split(NOT_FOUND, 1)[1] for line in report.split("\n\n") if NOT_FOUND in line), "")
    return f"{note} ⚠ {missing} not found: {_refusal_note(why) if why else 'why is in the report.'}"


def _not_found(headline: str) -> str:
    """'mirror 2' (the names) from a headline that names mirrors a search could not find (jobs.found_headline),
    else ''."""
    return headline.split(" ⚠ ", 1)[1].split(NOT_FOUND_HEAD)[0] if NOT_FOUND_HEAD in headline else ""


def fit_note(applied, waiting, without_markers: tuple[str, ...] = ()) -> str:
    """A markers fit in a notification's plain words (it is in view whatever the panel's scroll, where the report may
    be below the window): the planes applied with their RMS, and the glass when none is set, the poor markers of a
    plane applied anyway (a refit of markers taken before: FitReview.refit); then the proposal waiting; then the
    mirrors left out for want of markers. applied, waiting : (Calibration, SessionMirror, FitReview) each."""
    applied, waiting = list(applied), list(waiting)
    parts = []
    if applied:
        rms = ", ".join(f"{m.name} {c.rms_mm:.1f} mm RMS" for c, m, _ in applied)
        glass = ("; glass 0 mm: Refine from the object measures it" if any(not m.glass_set for _, m, _ in applied)
                 else "")
        poor = " ".join(f"⚠ {m.name}: the same markers as before, and marker(s) "
                        f"{', '.join(m.marker_names[i] for i in r.poor)} lie off it beyond the depth noise: delete "
                        "them (crossed on the depth frame) and fit again." for _, m, r in applied if r.poor)
        parts.append(f"Applied: {rms}{glass}. {poor + ' ' if poor else ''}The report is under Mirrors.")
    if waiting:
        crossed = " (the crossed markers)" if any(r.poor for _, _, r in waiting) else ""
        parts.append(f"A new plane for {listed(m.name for _, m, _ in waiting)} waits, not applied: look at it under "
                     f"Mirrors{crossed}, then Apply or Discard it.")
    if without_markers:
        them = "it is" if len(without_markers) == 1 else "they are"
        parts.append(f"{listed(without_markers)}: no markers, left as {them} (click 3 or more, or Find the planes "
                     "from the object).")
    return " ".join(parts)


def _fit_report(fits, confirmed: tuple[int, ...] = ()) -> str:
    """The report of markers fits ((Calibration, SessionMirror, FitReview) each): a line per mirror (those whose ids
    are `confirmed` applied on confirmation), then, when a mirror has no glass set, how to get it."""
    lines = [f"**{m.name}**: {c.summary(m.marker_names)}{' (applied on confirmation)' if m.id in confirmed else ''}"
             + "".join(f"\n  - ⚠ {concern}" for concern in (r.concerns if r else ())) for c, m, r in fits]
    if any(not m.glass_set for _, m, _ in fits):
        lines.append(NO_GLASS_NOTE)
    return "\n\n".join(lines)


def mirror_status(mirror: SessionMirror | None, from_object: bool, glass_unused: bool = False) -> str:
    """One line on a mirror: where its plane stands (none yet, calibrated, or from the object: a refinement or
    search of this app), its markers' glass (mm in front of the silver: typed in, or measured by a refinement with
    its 1 sigma, 0 included; none without markers; glass_unused: typed in after the plane was set, which it does not
    move: a plane from the markers until the next fit, one from the object not at all) and how many markers it
    has."""
    if mirror is None:
        return ""
    plane = "no plane yet" if mirror.plane is None else (
        "plane from the object" if from_object else "plane calibrated")
    if mirror.marker_offset_std is not None:
        glass = (f"glass {mirror.marker_offset * 1e3:.1f} ± {mirror.marker_offset_std * 1e3:.1f} mm measured (type it "
                 "in if you know it)")
    elif mirror.glass_typed:
        glass = f"glass {mirror.marker_offset * 1e3:.1f} mm typed in"
    else:
        glass = "glass not measured" if from_object else "no glass set"    # "glass 0.0 mm" beside one marker on
                                                                            # a plane found (a helper)
    if glass_unused:
        glass += (": the next markers fit uses it, this plane does not depend on it" if from_object else
                  ", not in the plane yet: **Fit plane** moves it behind the glass")
    count = len(mirror.markers)
    return markdown(" · ".join([plane, *([glass] if count else []), f"{count} marker{'s' if count != 1 else ''}"]))


def removal_question(mirror: SessionMirror) -> str:
    """What removing a mirror takes out of the session, as much as it has (it said "its 0 markers, boundary and
    plane" of a mirror with none: a helper), and how to bring it back."""
    count = len(mirror.markers)
    has = (([f"{count} marker{'s' if count != 1 else ''}"] if count else []) + (["boundary"] if mirror.boundary else [])
           + (["plane"] if mirror.plane is not None else []))
    what = f"{mirror.name} and its {listed(has)} leave" if has else f"{mirror.name} leaves"
    shows = (" What it shows then counts as seen directly: take the mirror out of the camera's view too, or what is "
             "seen in it stands in the cloud as an object of its own." if mirror.boundary else "")
    return f"{what} the session.{shows} *Undo*, or *Bring back* below the Remove button, brings it back."


def greyed_out(session: Session, selected: SessionMirror | None, refused: dict[int, str],
               undo_elsewhere: tuple[str, ...] = ()) -> str:
    """Why Fit plane, Fit all planes, Refine from the object, Find and Undo are greyed out, as small print (HTML,
    names escaped), '' when none is (the fits only while a plane is missing: after Find with no markers it had
    stood there for good); `refused` as Jobs.refusals; undo_elsewhere: the other mirrors with a change to
    undo while the selected mirror has none (undo goes by mirror: after a Find that found one mirror of two, the
    one not found was selected). Not while a calibration runs or a proposal waits: their progress bar, and Apply
    and Discard, say so."""
    if not session.mirrors:
        return ""                                        # nothing but Add a mirror, which the start hint names
    reasons = []                    # the fits' only while a plane is missing (planes found from the object need
    if selected is not None and selected.plane is None and len(selected.markers) < FIT_MARKERS:     # no markers)
        reasons.append(f"<b>Fit plane</b>: {escape(selected.name)} has {len(selected.markers)} of the "
                       f"{FIT_MARKERS} markers it needs")
    missing = any(m.plane is None for m in session.mirrors)
    if missing and not any(len(m.markers) >= FIT_MARKERS for m in session.mirrors):
        reasons.append(f"<b>Fit all planes</b>: no mirror has {FIT_MARKERS} markers")
    if all(m.plane is None for m in session.mirrors):
        reasons.append("<b>Refine</b>: no mirror has a plane yet")
    bare = [m for m in session.mirrors if m.boundary and m.plane is None]
    if bare and all(refused.get(m.id) == "scene" for m in bare):
        names = escape(listed([m.name for m in bare]))
        reasons.append(f"<b>Find</b>: {names} not found as {'it is' if len(bare) == 1 else 'they are'} (why: in "
                       "the report below); offered again once an outline or a marker changes")
    if undo_elsewhere and selected is not None:
        reasons.append(f"<b>Undo</b>: nothing to take back on {escape(selected.name)}; select "
                       f"{escape(listed(undo_elsewhere, 'or'))} for {'its' if len(undo_elsewhere) == 1 else 'their'} "
                       "changes")
    if not reasons:
        return ""
    return (f'<div style="{SMALL_TEXT};color:#666;padding-bottom:0.4em">Greyed out: '   # clear of Undo under it
            + " · ".join(reasons) + "</div>")


def _glass_source(mirror: SessionMirror) -> str:
    """What the refinement did to the glass a markers fit uses, for the proposal that replaces its plane: ', and set
    the glass the markers fit now uses' only when it measured it (a helper had typed it in)."""
    if mirror.glass_typed:
        return "; the markers fit uses the glass typed in"
    return ", and set the glass the markers fit now uses" if mirror.glass_set else ""
