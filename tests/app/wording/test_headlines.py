"""Every message of the wording leads with a short headline; progress in tenths of a percent."""


from mirrorscan.events import JobProgress
from mirrorscan.results import CalibrationReport, FramesUsed, NotFound
from mirrorscan.wording import HEADLINE_WORDS, words
from mirrorscan.wording import agreement as agreement_words
from mirrorscan.wording import refinement as calibration_words

from mirrorcore.calibration.residuals import ViewAgreement
from tests.app.support import line, refined


def test_a_progress_bar_is_given_tenths_of_a_percent():
    assert (
        JobProgress("refine", 0.55, "").percent == 55.0
        and JobProgress("refine", 0.12345, "").percent == 12.3
    )
    assert JobProgress("refine", None, "done").percent == 0.0


def test_every_message_of_the_wording_has_a_short_headline():
    """Every agreement line above, the refinement's report and the next-step hints lead with a
    headline of at most HEADLINE_WORDS words."""
    figures = [
        ViewAgreement(1.234, -0.16, 1200, 1.3),
        ViewAgreement(float("nan"), float("nan"), 0, float("nan")),
        ViewAgreement(30.0, -9.0, 150, 11.7, 30.0, -9.0, 9.0, 26, frames=5),
        ViewAgreement(12.0, 3.0, 900, 11.7, 8.0, -4.0, 9.0, 800),
        ViewAgreement(10.1, -4.0, 900, 11.7, 5.0, 0.5, 9.0, 800),
        ViewAgreement(15.2, 0.4, 900, 11.7),
    ]
    messages = [line("mirror 12", f, by) for f in figures for by in (True, False)]
    mirrors = (
        refined("mirror 1"),
        refined("mirror 2", 1, agreement_after_mm=2.0),
        refined("mirror 3", 2),
    )
    for search in (False, True):
        for changed in (False, True):
            report = CalibrationReport(
                mirrors,
                search,
                "surfaces",
                changed,
                FramesUsed((0, 3, 6, 9), 10),
                (NotFound("mirror 4", "its image spills over the outline"),),
            )
            messages += [
                *calibration_words.report(report),
                calibration_words.note(report),
                calibration_words.undone(report, "Undone"),
            ]
    messages.append(agreement_words.disagreement_note(("mirror 1", "mirror 2", "mirror 3")))
    for message in messages:
        assert words(message.headline) <= HEADLINE_WORDS, message.headline
