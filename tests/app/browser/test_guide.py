"""The link to the guide in a real headless Chromium: a click on *Open the guide* in the header's
folder opens the guide, rendered, in a new tab, on a tool that needs its token, while the tool's
own page stays where it was and connected."""
from __future__ import annotations

import time

import pytest
from mirrorscan.guide import source_root

from tests.waiting import wait_for

pytestmark = pytest.mark.skipif(source_root() is None, reason="an install without the docs")


def test_the_guide_opens_in_a_new_tab_and_the_tool_stays(shared, browser):
    """On a tool that needs its token: the guide's tab carries the token's cookie too."""
    context = browser.new_context(viewport={"width": 1024, "height": 600})
    try:
        page = context.new_page()
        page.goto(shared.guard.url)
        wait_for(lambda: shared.server.get_clients(), 60, "the tool's tab to connect")
        clients = set(shared.server.get_clients())
        page.get_by_text("Playback and view", exact=True).click()
        link = page.get_by_role("link", name="Open the guide")
        link.wait_for(timeout=60_000)
        tool_url = page.url
        with context.expect_page(timeout=30_000) as opened:
            link.click()
        guide = opened.value
        guide.wait_for_load_state()
        assert guide.url.endswith("/guide/docs/browser-tool.md")
        heading = guide.locator("h1").first
        assert heading.inner_text() == "The browser tool"
        # its images are served beside it
        widths = guide.locator("main img").evaluate_all("els => els.map(e => e.naturalWidth)")
        assert widths and min(widths) > 0
        time.sleep(1.0)  # deliberate: a tool's tab that navigated away would disconnect meanwhile
        assert page.url == tool_url
        assert set(shared.server.get_clients()) == clients
        assert page.get_by_role("button", name="Add a mirror").is_visible()
    finally:
        context.close()
