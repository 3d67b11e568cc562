"""The page's own scripts (mirrorscan.page): the draw rate read back from the page, and the
shortcuts listed for the header and the docs."""
from pathlib import Path

from mirrorscan.page import DRAWS_KEY, SHORTCUTS, draw_rate, keys_help

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
