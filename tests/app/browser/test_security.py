"""The browser tool's guard in a real browser (headless Chromium): the page opened with ?token=
connects (the cookie it gets is what its websocket carries), the page without it is told what to
open, and a page of another site that opens a websocket to the tool is refused."""
from __future__ import annotations

import functools
import http.server
import threading
import time

import pytest
import viser
from mirrorscan.server import MirrorscanApp

from mirrorcore.io.session import Session, SessionMirror
from mirrorcore.io.sessionfile import load_session, save_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import SimulatedSource
from tests.waiting import wait_for

EVIL_PAGE = """<html><body><script>
const ws = new WebSocket("ws://127.0.0.1:%d/", ["viser-v%s"]);
ws.onopen = () => { document.title = "opened"; };
ws.onclose = () => { if (document.title !== "opened") document.title = "refused"; };
</script></body></html>"""


@pytest.fixture(scope="module")
def app(shared):
    return shared


def test_the_page_with_its_token_connects_and_without_it_is_told_what_to_open(app, browser):
    stranger = browser.new_context()
    page = stranger.new_page()
    response = page.goto(f"http://127.0.0.1:{app.port}/")
    assert response.status == 403 and "needs its token" in page.content()
    time.sleep(1)  # deliberate: a websocket let in by mistake would connect meanwhile
    assert not app.server.get_clients()

    user = browser.new_context()
    page = user.new_page()
    # the address the server printed
    page.goto(app.guard.url)
    wait_for(lambda: app.server.get_clients(), 60, "the tab with the token to connect")
    cookies = {c["name"]: c for c in user.cookies()}
    assert cookies[f"mirrorscan-token-{app.port}"]["httpOnly"]
    # the GUI arrived over the websocket
    page.get_by_role("button", name="Add a mirror").wait_for(timeout=60_000)
    user.close()
    stranger.close()


def test_another_sites_page_cannot_open_the_tools_websocket(app, browser, tmp_path):
    evil = tmp_path / "evil"
    evil.mkdir()
    (evil / "index.html").write_text(EVIL_PAGE % (app.port, viser.__version__))
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(evil))
    site = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=site.serve_forever, daemon=True).start()
    try:
        context = browser.new_context()
        page = context.new_page()
        # the user's own tab has the cookie
        page.goto(app.guard.url)
        wait_for(lambda: app.server.get_clients(), 60, "the user's tab to connect")
        clients = len(app.server.get_clients())
        other = context.new_page()
        # and another site opens the websocket
        other.goto(f"http://127.0.0.1:{site.server_port}/")
        wait_for(lambda: other.title() in ("opened", "refused"), 30, "the other site's answer")
        assert other.title() == "refused"
        assert len(app.server.get_clients()) == clients
        context.close()
    finally:
        site.shutdown()
    names = [m.name for m in load_session(app.editor.session.root).mirrors]
    assert names == ["mirror 1", "mirror 2"]


EVIL_NAME = '<img src=x onerror="window.__pwned=(window.__pwned||0)+1">'


def test_a_name_from_a_session_file_is_shown_as_text_never_run(browser, tmp_path):
    """viser renders Markdown and HTML unsanitised: a mirror named with an HTML tag in a shared
    session file is shown as text, its script never run, in the next-step line, the legend, the
    Remove question and the greyed-out line."""
    rig = Simulator(paper_scene(object="sphere"), seed=0, fps=5.0)
    mirrors = (SessionMirror(EVIL_NAME), SessionMirror("mirror 2"))
    session = Session(tmp_path / "scan", rig.intrinsics, mirrors)
    save_session(session)
    app = MirrorscanApp(load_session(session.root), SimulatedSource(rig), port=0,
                        sessions_dir=tmp_path)
    app.start()
    try:
        page = browser.new_page(viewport={"width": 1400, "height": 900})
        page.goto(f"http://127.0.0.1:{app.port}/")
        page.get_by_role("button", name="Add a mirror").wait_for(timeout=60_000)
        # the legend names the sources
        page.get_by_text("direct").first.wait_for(timeout=30_000)
        page.get_by_text("Rename, glass, remove, clear").click()
        page.get_by_role("button", name="Remove this mirror…").click()
        # the question is up
        page.get_by_role("button", name="Keep it").wait_for(timeout=10_000)
        time.sleep(1.0)  # deliberate: an injected script would run meanwhile
        assert page.evaluate("window.__pwned || 0") == 0
        hint = (EVIL_NAME + ": choose Boundary and click its corners; click the first corner to "
                "close.")
        # shown as text: the next step,
        assert page.get_by_text(hint).count() == 1
        # the legend,
        assert page.get_by_text(f"{EVIL_NAME} and mirror 2: no plane yet").count() == 1
        # the question,
        assert page.get_by_text(f"{EVIL_NAME} leaves the session").count() == 1
        # the greyed-out line
        assert page.get_by_text(f"{EVIL_NAME} has 0 of the 3 markers it needs").count() == 1
        page.close()
    finally:
        app.stop()
