"""The Mirrors step's reports: the report of what left the planes as they are, undo and redo with
what they took back, and mirrors removed and brought back."""

from __future__ import annotations

from typing import Callable

from mirrorcore.base.words import listed
from mirrorcore.io.session import Session

from ...editor import PARTIAL
from ...jobs import planes_key
from ...wording import Message, joined
from ...wording import refinement as words
from ...wording.mirrors import fit_report, removal_question, report_markdown


class MirrorReports:
    """The reports, undo and redo of the Mirrors panel (MirrorsPanel mixes it in)."""

    def _travel(self, move) -> None:
        """Undo or redo in the selected mirror's scope, or the session's if it holds the newer step.

        See SessionEditor.travel_scope; undo while an outline is drawn takes its last corner back.
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
        before = planes_key(editor.session)
        label = move(editor.travel_scope(state.mirror_id, redo=move == editor.redo))
        state.picked_marker = state.picked_corner = None
        self._report(
            self._report_after_travel(
                before, planes_key(editor.session), label, move == editor.undo
            )
        )
        self._check_agreement()  # the views' agreement with the planes now
        self.tab.changed()

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
        """A mirror removed, or brought back (its Undo): then how the views agree."""
        change()
        self._check_agreement()
