"""Notifications (mirrorscan.notices): each no longer than its headline, the whole message in the
log; the style sheet that places them over the side panel is given to the page."""
import json
import logging
from types import SimpleNamespace

from mirrorscan import notices
from mirrorscan.notices import NOTE_WIDTH, NOTES_CSS, Notifier, place_notes
from mirrorscan.server import PANEL_WIDTH
from mirrorscan.wording import HEADLINE_WORDS, words


class Client:
    """A tab that keeps its notifications and the scripts it was given."""

    def __init__(self):
        self.notes, self.scripts = [], []

    def add_notification(self, title, body, **options):
        self.notes.append((title, body, options))
        return len(self.notes)


def test_a_notification_is_no_longer_than_its_headline_and_the_log_keeps_it_whole(caplog):
    client = Client()
    app = Notifier()
    app.server = SimpleNamespace(get_clients=lambda: {1: client})
    reason = ("the boundary of mirror 2 has 2 corners (it needs 3 or more); click more corners on "
              "the depth frame, then close it by clicking the first one again, or clear it and "
              "start again from the Mirrors step of the side panel")
    with caplog.at_level(logging.INFO, logger="mirrorscan"):
        app.notify(None, "Not done", reason)
    (title, body, options), = client.notes
    assert body.startswith("the boundary of mirror 2 has 2 corners")
    assert words(body) <= HEADLINE_WORDS and options["color"] == "red"
    assert reason in caplog.text
    # a short one is shown as it is
    app.notify(None, "Not done", "pick a marker first")
    assert client.notes[-1][1] == "pick a marker first"


def test_the_notes_are_placed_within_the_side_panel(monkeypatch):
    given = []
    monkeypatch.setattr(notices, "run_js", lambda client, source: given.append(source))
    place_notes(Client())
    (script,) = given
    css = NOTES_CSS.format(margin=notices.NOTE_MARGIN, width=NOTE_WIDTH)
    assert json.dumps(css) in script
    assert NOTE_WIDTH + notices.NOTE_MARGIN < PANEL_WIDTH
