"""The Mirrors step's jobs: a calibration from the object's progress, report and notification,
and the views' agreement after a fit."""

from __future__ import annotations

from ...events import JobProgress
from ...jobs import AGREEMENT, REFINE, planes_key
from ...results import AgreementReport, CalibrationReport, Cancelled
from ...wording import agreement as agreement_words
from ...wording import refinement as words
from ...wording.jobs import say
from ...wording.mirrors import report_markdown


class MirrorJobs:
    """The calibration's and the agreement's progress in the Mirrors panel (MirrorsPanel mixes it
    in)."""

    def _on_job(self, event: JobProgress) -> None:
        """The calibration's progress and report, and the views' agreement after a fit."""
        if event.job == REFINE:
            self._on_calibration(event)
        elif event.job == AGREEMENT:
            self.agreement.content = event.status
            if isinstance(event.result, AgreementReport):
                self._warn_disagreement(event.result, event.status)

    def _on_calibration(self, event: JobProgress) -> None:
        """A calibration from the object moved on or ended.

        The buttons, its progress, its report; its end in a notification (in view whatever the
        panel's scroll) until the planes change again.
        """
        running, result = event.fraction is not None, event.result
        self.refine.disabled, self.refine_cancel.visible = running, running
        self.scene.disabled = self.undo.disabled = self.redo.disabled = running
        self.greyed.visible = self.greyed.visible and not running
        # after it, refresh() says what is offered
        if running:
            self.fit.disabled = self.fit_all.disabled = True
            self.refine_progress.value = event.percent
        self.refine_progress.visible = running
        cancelled = isinstance(result, Cancelled)
        self._report(self._cancelled() if cancelled else event.status)
        if not running and not cancelled:
            if isinstance(result, CalibrationReport):
                note, kind = words.note(result), "warning" if result.not_found else "info"
            else:
                note, kind = say(result)[0], "error"
            self._result_note = self.services.notify(
                self.tab.client,
                "Calibration from the object",
                note.plain,
                kind,
                stay=True,
                logged=False,
            )
        if not running:
            # Undo and Redo as they now stand (a refusal changes nothing)
            self.refresh()

    def _cancelled(self) -> str:
        """A calibration from the object cancelled.

        The planes are as they were, and so is their report.
        """
        before = report_markdown(
            self.services.jobs.report(planes_key(self.services.editor.session))
        )
        return words.CANCELLED.markdown() + (f"\n\n{before}" if before else "")

    def _warn_disagreement(self, report: AgreementReport, lines: str) -> None:
        """Notify of the mirrors the agreement lines flag (they may be out of view).

        Not again for the same lines.
        """
        flagged = tuple(m.name for m in report.mirrors if agreement_words.disagrees(m.found))
        if flagged and lines != self._flagged:
            self.services.notify(
                self.tab.client,
                "The views disagree",
                agreement_words.disagreement_note(flagged).plain,
                "warning",
                logged=False,
            )
        self._flagged = lines if flagged else ""
