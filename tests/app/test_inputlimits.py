"""What a tab may send: uploads counted by the bytes received (a real `serve` process and a crafted
websocket client, its memory measured), at most a few at once, and GUI values within their inputs'
ranges."""
from __future__ import annotations

import logging
from types import SimpleNamespace

import pytest
from mirrorscan.bench.tabs import HeadlessTab
from mirrorscan.inputlimits import MAX_UPLOADS_PER_TAB, refusal
from mirrorscan.panels.record import RecordPanel
from mirrorscan.server import MirrorscanApp
from viser import _messages

from mirrorcore.io.session import Session, SessionMirror
from mirrorcore.io.sessionfile import save_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import SimulatedSource
from tests.app.crafted import CraftedTab, Served, encode
from tests.waiting import wait_for

MB = 1 << 20


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    served = Served(tmp_path_factory.mktemp("uploads") / "new")
    yield served
    served.stop()


def refusals(tab: CraftedTab) -> list[str]:
    """The upload refusals the tab was told."""
    return [n for n in tab.notes if n.startswith("Upload refused: ")]


def _settled_rss(served: Served) -> int:
    """The server's resident memory once two readings in a row (20 ms apart) agree within 5 MB."""
    readings = [served.rss()]

    def settled() -> bool:
        readings.append(served.rss())
        return abs(readings[-1] - readings[-2]) < 5 * MB

    wait_for(settled, 30, "the server's memory to settle")
    return readings[-1]


def test_uploads_that_declare_little_and_send_much_hold_nothing(served):
    """Uploads declaring 1,000 bytes and sending a 7 MB part each: every part is refused before
    it is stored, the tab told each time, and 40 more leave the server's memory where it was
    (280 MB more otherwise)."""
    tab = CraftedTab(served.port)
    try:
        button = wait_for(lambda: tab.input_uuid("Upload background"), 60, "the upload button")
        part = bytes(7 * MB)

        def send(names: range) -> list[str]:
            for i in names:
                tab.send(_messages.FileTransferStartUpload(button, f"s{i}", "small.png",
                                                           "image/png", 2, 1000))
                tab.send(_messages.FileTransferPart(button, f"s{i}", 0, part))
            return wait_for(lambda: len(refusals(tab)) >= names.stop and refusals(tab), 60,
                            f"{names.stop} refusals")

        # the first parts grow the allocator's free lists, which the next ones reuse
        send(range(8))
        before = _settled_rss(served)
        refused = send(range(8, 48))
        assert len(refused) == 48 and all("more bytes than it declared" in n for n in refused)
        grown = _settled_rss(served) - before
        assert grown < 60 * MB, f"the server grew by {grown / MB:.0f} MB"
    finally:
        tab.close()


def test_uploads_in_flight_are_capped_per_tab_and_in_total(served):
    """A tab may have MAX_UPLOADS_PER_TAB uploads coming at once; all tabs together, 64 MB
    declared."""
    first, second = CraftedTab(served.port), CraftedTab(served.port)
    try:
        buttons = [wait_for(lambda t=t: t.input_uuid("Upload background"), 60, "the button")
                   for t in (first, second)]

        def start(tab: CraftedTab, button: str, name: str, size: int) -> None:
            tab.send(_messages.FileTransferStartUpload(button, name, f"{name}.png", "image/png",
                                                       size // (512 << 10), size))

        for i in range(MAX_UPLOADS_PER_TAB + 1):
            start(first, buttons[0], f"a{i}", 10 * MB)
        wait_for(lambda: refusals(first), 30, "the refusal")
        assert refusals(first) == [f"Upload refused: a{MAX_UPLOADS_PER_TAB}.png: "
                               f"{MAX_UPLOADS_PER_TAB} uploads from this tab are still coming; "
                               "wait for them, then try again"]
        # 40 MB declared so far: 20 more fit, 40 more do not
        start(second, buttons[1], "b0", 20 * MB)
        start(second, buttons[1], "b1", 20 * MB)
        wait_for(lambda: refusals(second), 30, "the refusal")
        assert refusals(second) == ["Upload refused: b1.png: too many uploads at once; try again"]
    finally:
        first.close()
        second.close()


# --------------------------------------------------------------------- GUI values
@pytest.fixture(scope="module")
def app(tmp_path_factory):
    root = tmp_path_factory.mktemp("values") / "scan"
    rig = Simulator(paper_scene(object="sphere"), seed=1, fps=5.0)
    session = Session(root, rig.intrinsics, (SessionMirror("mirror 1"), SessionMirror("mirror 2")))
    save_session(session)
    app = MirrorscanApp(session, SimulatedSource(rig), port=0, sessions_dir=root.parent)
    yield app
    app.stop()


def test_a_crafted_message_cannot_set_a_slider_past_its_max(app, caplog):
    """The worker slider offers 1 to the cores: 40, a NaN, a new max and a string are refused with
    one log line each; a value it offers goes through."""
    caplog.set_level(logging.WARNING, logger="mirrorscan.security")
    with HeadlessTab(app) as headless:
        panel = next(p for p in headless.tab.panels if isinstance(p, RecordPanel))
        slider = panel.workers
        for updates in ({"value": 40}, {"value": float("nan")}, {"max": 64, "value": 2},
                        {"value": "40"}):
            headless.ws.send(encode(_messages.GuiUpdateMessage(slider._impl.uuid, updates)))
        wait_for(lambda: len([r for r in caplog.records if "refused a GUI update" in r.message])
                 == 4, 20, "four refusals")
        assert slider.value == 1 and slider.max == slider._impl.props.max >= 1
        headless.ws.send(encode(_messages.GuiUpdateMessage(slider._impl.uuid,
                                                           {"value": slider.max})))
        wait_for(lambda: slider.value == slider.max, 20, "the value it offers")
    assert "refused a GUI update of 'Worker processes' from a tab: 40 is outside 1" in caplog.text


@pytest.mark.parametrize("props, current, updates, refused", [
    (SimpleNamespace(min=0.0, max=5.0), 1.0, {"value": 5.0}, False),
    (SimpleNamespace(min=0.0, max=5.0), 1.0, {"value": 5.001}, True),
    (SimpleNamespace(min=0.0, max=5.0), 1.0, {"value": -1e-9}, True),
    (SimpleNamespace(min=0.0, max=5.0), 1.0, {"value": float("inf")}, True),
    (SimpleNamespace(min=0.0, max=5.0), 1.0, {"value": True}, True),
    (SimpleNamespace(min=None, max=None), 1.0, {"value": 1e300}, False),
    (SimpleNamespace(min=0.1, max=5.0), (0.5, 2.0), {"value": [0.1, 5.0]}, False),
    (SimpleNamespace(min=0.1, max=5.0), (0.5, 2.0), {"value": [-1e308, 1e308]}, True),
    (SimpleNamespace(min=0.1, max=5.0), (0.5, 2.0), {"value": [0.5]}, True),
    (SimpleNamespace(min=(0, 0, 0), max=(1, 1, 2)), (0, 0, 0), {"value": [1, 1, 2]}, False),
    (SimpleNamespace(min=(0, 0, 0), max=(1, 1, 2)), (0, 0, 0), {"value": [1, 2, 1]}, True),
    (SimpleNamespace(options=("a", "b")), "a", {"value": "b"}, False),
    (SimpleNamespace(options=("a", "b")), "a", {"value": "c"}, True),
    (SimpleNamespace(), "text", {"value": "anything"}, False),
    (SimpleNamespace(), "text", {"value": "x", "removed": True}, True),
    (SimpleNamespace(), "text", {}, True),
])
def test_a_value_is_one_its_input_offers(props, current, updates, refused):
    assert (refusal(props, current, updates) is not None) == refused
