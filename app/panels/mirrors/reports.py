"""The Mirrors step's reports: the report of what left the planes as they are, undo and redo with
what they took back, and mirrors removed and brought back."""

from __future__ import annotations

from typing import Callable

from mirrorcore.base.words import listed
from mirrorcore.io.session import Session, SessionMirror

from ...editor import PARTIAL
from ...jobs import planes_key
from ...wording import Message, joined
from ...wording import refinement as words
from ...wording.mirrors import (
    fit_report,
    redo_removal_title,
    removal_question,
    removed_note,
    report_markdown,
)


class MirrorReports:
    """The reports, undo and redo of the Mirrors panel (MirrorsPanel mixes it in)."""

    def _travel(self, move) -> None:
        """Undo or redo in the selected mirror's scope, or the session's if it holds the newer step.

        See SessionEditor.travel_scope; undo while an outline is drawn takes its last corner back.
        One that removes a mirror asks first, as Remove does: a redo always, an undo (of an Add)
        when the mirror holds anything.
        """
        editor, state = self.services.editor, self.tab.state
        draft = state.drafts.get(state.mirror_id)
        if move == editor.undo and draft:
            if len(draft) > 1:
                state.drafts[state.mirror_id] = draft[:-1]
            else:
                del state.drafts[state.mirror_id]
            self.tab.changed()
            return
        redo = move == editor.redo
        scope = editor.travel_scope(state.mirror_id, redo=redo)
        mirror = editor.removal(scope, redo)
        if mirror is None or not (redo or holds_work(mirror)):
            self._move(move, scope)
            return
        self.tab.ask(
            redo_removal_title(mirror.name, redo),
            removal_question(mirror),
            f"Remove {mirror.name}",
            lambda: self._move(move, scope),
            "Keep it",
        )

    def _move(self, move, scope: int) -> None:
        """Undo or redo in `scope` (travel_scope), its report, and every tab told of a removal."""
        editor, state = self.services.editor, self.tab.state
        before, mirrors = planes_key(editor.session), editor.session.mirrors
        label = move(scope)
        state.picked_marker = state.picked_corner = None
        self._report(
            self._report_after_travel(
                before, planes_key(editor.session), label, move == editor.undo
            )
        )
        self._tell_removed(mirrors)
        self._check_agreement()  # the views' agreement with the planes now
        self.tab.changed()

    def _tell_removed(self, before: tuple[SessionMirror, ...]) -> None:
        """Tell every tab of the mirrors of `before` that an action of this tab removed."""
        ids = {m.id for m in self.services.editor.session.mirrors}
        for mirror in before:
            if mirror.id not in ids:
                self.services.notify(None, *removed_note(mirror.name), kind="warning")

    def _report(self, text: str, gone: tuple[str, ...] = ()) -> None:
        """Show a report (Markdown) for the planes as they are, and the mirrors since removed.

        It names the mirrors of the report that were removed since. The notification of the last
        calibration from the object goes (one told after it would stack under it).
        """
        self._result_planes, self._result_text, self._gone = (
            planes_key(self.services.editor.session),
            text,
            gone,
        )
        self.result.content = text + (
            f"\n\n*{listed(gone)} {'was' if len(gone) == 1 else 'were'} removed since.*"
            if gone
            else ""
        )
        if self._result_note is not None:
            self._result_note.remove()
            self._result_note = None

    def _follow_planes(self, session: Session) -> None:
        """The planes changed other than by this panel.

        The report of the calibration or fit that left them so, else the report shown while it still
        describes every plane (mirrors only added without a plane, or removed), naming those
        removed, else none.
        """
        key = planes_key(session)
        known = self.services.jobs.report(key)
        if known is not None:
            self._report(report_markdown(known))
            return
        before, now = dict(self._result_planes), dict(key)
        if (
            any(before[i] != now[i] for i in before.keys() & now.keys())
            or any(now[i] is not None for i in now.keys() - before.keys())
            or not self._result_text
        ):
            self._report("")
            return
        gone = tuple(self._names.get(i, f"mirror {i}") for i in before.keys() - now.keys())
        self._report(self._result_text, self._gone + gone)

    def _report_after_travel(self, before: tuple, after: tuple, label: str, undone: bool) -> str:
        """The report to show after an undo or redo of the step `label`.

        The report of the calibration whose planes are back, or what was undone (the step's label
        when no calibration changed these planes, or only a part of the step was taken back), then
        the report of the markers fit whose planes are back; nothing when the planes stayed.
        """
        jobs, verb = self.services.jobs, "Undone" if undone else "Redone"
        if after in jobs.refinements:
            return report_markdown(jobs.refinements[after])
        if before == after:
            return ""
        prior = jobs.refinements.get(before)
        step = (
            Message(f"{verb}: {label}.")
            if PARTIAL in label or prior is None or not prior.changed
            else words.undone(prior, verb)
        )
        fit = jobs.fits.get(after)
        return joined([step, *(fit_report(fit) if fit else [])])

    def _confirm_remove(self) -> None:
        """Ask before removing the selected mirror."""
        mirror = self._mirror()
        self.tab.ask(
            f"Remove {mirror.name}?",
            removal_question(mirror),
            f"Remove {mirror.name}",
            lambda: self._travel_mirrors(lambda: self.services.editor.remove_mirror(mirror.id)),
            "Keep it",
        )

    def _travel_mirrors(self, change: Callable[[], object]) -> None:
        """A mirror removed (every tab told), or brought back (its Undo): then how the views
        agree."""
        before = self.services.editor.session.mirrors
        change()
        self._tell_removed(before)
        self._check_agreement()


def holds_work(mirror: SessionMirror) -> bool:
    """Whether removing the mirror loses anything: markers, an outline or a plane.

    Parameters
    ----------
    mirror : SessionMirror

    Returns
    -------
    bool
    """
    return bool(mirror.markers or mirror.boundary or mirror.plane is not None)
