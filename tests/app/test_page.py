"""The page's own scripts (mirrorscan.page): the draw rate read back from the page, the shortcuts
listed for the header and the docs, and a view framed when the page reported its camera before
its tab listened."""
import time
from pathlib import Path
from types import SimpleNamespace

from mirrorscan import page
from mirrorscan.page import DRAWS_KEY, SHORTCUTS, draw_rate, keys_help

from tests.waiting import wait_for

DOCS = Path(__file__).resolve().parents[2] / "docs" / "browser-tool.md"


class Storage:
    def __init__(self, value):
        self.value, self.asked = value, []

    def get_item(self, key, timeout):
        self.asked.append(key)
        if isinstance(self.value, Exception):
            raise self.value
        return self.value


class Client:
    client_id = 7

    def __init__(self, value):
        self.local_storage = Storage(value)


def test_the_draw_rate_is_the_pages_figure_or_none():
    client = Client("11.75")
    assert draw_rate(client) == 11.75
    assert client.local_storage.asked == [f"{DRAWS_KEY}-7"]
    for value in (None, "", "n/a", TimeoutError(), RuntimeError()):
        assert draw_rate(Client(value)) is None


def test_every_shortcut_is_in_the_header_and_in_the_docs():
    docs = DOCS.read_text()
    for keys, what, pressed in SHORTCUTS:
        assert f"**{keys}** {what}" in keys_help()
        assert keys in docs and pressed in docs


def test_a_view_reported_before_the_tab_listened_is_framed_late(monkeypatch):
    """A page that reported its camera is framed LATE_VIEW_S on; one that reports it later is
    framed when it does; one that never reports is given up."""
    monkeypatch.setattr(page, "LATE_VIEW_S", 0.01)
    monkeypatch.setattr(page, "LATE_VIEW_GIVE_UP_S", 0.1)
    framed = []

    class Camera:
        def __init__(self, known):
            self.known = known

        @property
        def wxyz(self):
            assert self.known, "not reported yet"
            return (1.0, 0.0, 0.0, 0.0)

    early, late, never = Camera(True), Camera(False), Camera(False)
    for camera, name in ((early, "early"), (late, "late"), (never, "never")):
        page.frame_late(SimpleNamespace(camera=camera), lambda _, name=name: framed.append(name))
    wait_for(lambda: framed == ["early"], 5, "the view reported early framed")
    late.known = True
    wait_for(lambda: framed == ["early", "late"], 5, "the view reported late framed")
    time.sleep(0.3)  # deliberate: the page that never reported has been given up meanwhile
    never.known = True
    time.sleep(0.1)  # deliberate: no timer is left to frame it
    assert framed == ["early", "late"]
