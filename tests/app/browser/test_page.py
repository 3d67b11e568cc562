"""The page around the work, in a real headless Chromium: notifications stack over the side panel,
clear of the depth frame, older ones collapsed; the header's draw rate is the one the page counts;
the keyboard shortcuts press the buttons they name, and keys typed in a field stay the field's."""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from mirrorscan.page import DRAWS_KEY
from tests.browser import (
    button,
    canvas_point,
    click_pixel,
    look_at_the_depth_frame,
    open_tab,
)
from tests.conftest import sphere_app
from tests.waiting import wait_for

ARTIFACTS = Path(__file__).resolve().parents[2] / "artifacts"
LIVE_FPS = 8.0  # software WebGL on 2 cores: keep the stream light while the test drives the page

pytestmark = pytest.mark.steps("app")

# The test's own count of the frames the page draws: every WebGL context's draw calls, wrapped at
# the prototype before the page loads; each animation frame that had one is timed.
COUNT_DRAWS = """
window.__drawn = [];
let drewNow = false;
for (const Context of [WebGLRenderingContext, WebGL2RenderingContext]) {
  for (const name of ["drawArrays", "drawElements", "drawArraysInstanced",
                      "drawElementsInstanced"]) {
    const draw = Context.prototype[name];
    if (!draw) continue;
    Context.prototype[name] = function (...args) { drewNow = true; return draw.apply(this, args); };
  }
}
const tick = (now) => {
  if (drewNow) window.__drawn.push(now);
  drewNow = false;
  requestAnimationFrame(tick);
};
requestAnimationFrame(tick);
"""
# [the test's count of frames drawn over the last 2 s, per second; the page's own figure]
BOTH_RATES = """(key) => {
  const now = performance.now();
  return [window.__drawn.filter((t) => now - t <= 2000).length / 2,
          Number(localStorage.getItem("viser-user:" + key))];
}"""
NOTES = ".mantine-Notification-root"


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    app = sphere_app(tmp_path_factory.mktemp("page") / "session", fps=LIVE_FPS)
    app.start()
    yield app
    app.stop()


def overlap(a: dict, b: tuple[float, float, float, float]) -> float:
    """The area (CSS px) where box a (x, y, width, height) and b (left, top, right, bottom) meet."""
    width = min(a["x"] + a["width"], b[2]) - max(a["x"], b[0])
    height = min(a["y"] + a["height"], b[3]) - max(a["y"], b[1])
    return max(width, 0) * max(height, 0)


def enabled(page, label: str) -> bool:
    """Whether a button whose label starts with `label` is in view and not greyed out."""
    found = page.locator("button:visible", has_text=label)
    return found.count() > 0 and found.first.is_enabled()


@pytest.mark.parametrize("size", [(1400, 900), (1024, 600)])
def test_notifications_stack_over_the_panel_clear_of_the_depth_frame(app, browser, size):
    width, height = size
    page, tab = open_tab(browser, app, width, height)
    try:
        look_at_the_depth_frame(page, tab)
        long = ("Marker 1.3 is 12.4 mm (5.1σ) off the plane fitted through the others: move it "
                "onto the glass or delete it; the fit of the plane waits until then, and the "
                "report under Mirrors gives every marker's distance")
        # kept up while the test looks at them (a note closes after 8 s otherwise)
        for k in range(3):
            app.notify(tab.client, f"Note {k}", long, "warning", stay=True)
        ours = page.locator(NOTES).filter(has_text="Note ")
        wait_for(lambda: ours.count() == 3, 30, "three notifications")
        time.sleep(1.0)  # deliberate: the notifications' entry animation ends
        ARTIFACTS.mkdir(exist_ok=True)
        page.screenshot(path=ARTIFACTS / f"notifications-{width}x{height}.png")
        left, top = canvas_point(page, tab.client, tab.screen.world_of_pixel(-0.5, -0.5))
        right, bottom = canvas_point(page, tab.client, tab.screen.world_of_pixel(639.5, 479.5))
        panel = page.get_by_role("tab", name="Mirrors", exact=True).bounding_box()["x"]
        for k in range(3):
            box = ours.nth(k).bounding_box()
            assert overlap(box, (left, top, right, bottom)) == 0, box
            assert box["x"] >= panel and box["y"] + box["height"] <= height, box
        # each no longer than its headline; the newest whole, the older ones their titles alone
        descriptions = ours.locator(".mantine-Notification-description")
        assert descriptions.nth(2).is_visible()
        assert not descriptions.nth(0).is_visible() and not descriptions.nth(1).is_visible()
        shown = descriptions.nth(2).inner_text()
        assert shown.startswith("Marker 1.3 is 12.4 mm") and len(shown.split()) <= 25
        assert ours.nth(0).bounding_box()["height"] < 0.7 * ours.nth(2).bounding_box()["height"]
    finally:
        page.close()


def test_the_header_shows_the_draw_rate_the_page_counts(app, browser):
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    page.add_init_script(COUNT_DRAWS)
    before = set(app.tabs)
    page.goto(f"http://127.0.0.1:{app.port}/")
    tab = app.tabs[wait_for(lambda: set(app.tabs) - before, 60, "the tab").pop()]
    try:
        key = f"{DRAWS_KEY}-{tab.client.client_id}"
        wait_for(lambda: (tab.header.draws or 0) > 0, 60, "a draw rate")
        time.sleep(2.5)  # deliberate: both counts fill their 2 s window
        samples = []
        for _ in range(6):
            samples.append(page.evaluate(BOTH_RATES, key))
            time.sleep(0.5)  # deliberate: the page writes its figure every 0.5 s
        counted, told = np.array(samples).T
        print(f"server {app.fps():.1f} fps; page draws, the test's count {counted}, "
              f"the page's {told}")
        # the page refreshes its figure every 0.5 s: within a frame a second or 20 %
        assert np.median(np.abs(counted - told)) <= max(1.0, 0.2 * np.median(counted))
        assert np.median(counted) > 1.0
        wait_for(lambda: "page draws" in tab.header.rate.content, 10, "the rate in the header")
        # the header's figure is the page's, read by the server
        assert tab.header.draws <= 1.5 * max(told) + 1.0
    finally:
        page.close()


def test_keyboard_shortcuts_press_the_buttons_they_name(app, browser):
    page, tab = open_tab(browser, app, 1400, 900)
    try:
        selected = page.locator("[role=tab][aria-selected=true]")
        page.get_by_role("tab", name="Object", exact=True).wait_for(timeout=60_000)
        page.keyboard.press("2")
        wait_for(lambda: selected.inner_text() == "Object", 10, "key 2: the Object step")
        page.keyboard.press("1")
        wait_for(lambda: selected.inner_text() == "Mirrors", 10, "key 1: the Mirrors step")
        count = len(app.editor.session.mirrors)
        button(page, "Add a mirror")
        wait_for(lambda: len(app.editor.session.mirrors) == count + 1, 10, "the mirror added")
        # a shortcut presses its button as the page shows it: not while greyed out
        wait_for(lambda: enabled(page, "Undo:"), 10, "Undo offered")
        page.keyboard.press("Control+z")
        wait_for(lambda: len(app.editor.session.mirrors) == count, 10, "Ctrl+Z: undone")
        wait_for(lambda: enabled(page, "Redo:"), 10, "Redo offered")
        page.keyboard.press("Control+Shift+z")
        wait_for(lambda: len(app.editor.session.mirrors) == count + 1, 10, "Ctrl+Shift+Z: redone")
        mirror = app.editor.session.mirrors[-1].id
        wait_for(lambda: tab.state.mode == "boundary" and tab.state.mirror_id == mirror, 10,
                 "boundary mode")
        look_at_the_depth_frame(page, tab)
        # Esc: the outline being drawn is dropped
        for k, uv in enumerate(((100, 100), (300, 100)), start=1):
            click_pixel(page, tab, uv, lambda: len(tab.state.drafts.get(mirror, ())) >= k)
        page.keyboard.press("Escape")
        wait_for(lambda: not tab.state.drafts.get(mirror), 10, "Esc: the draft dropped")
        # Delete: the picked marker, and only once one is picked
        app.editor.set_boundary(mirror, ((50, 50), (400, 50), (400, 400), (50, 400)))
        app.editor.add_marker(mirror, (200.0, 200.0))
        button(page, "Markers")
        wait_for(lambda: tab.state.mode == "markers", 10, "markers mode")
        assert page.get_by_role("button", name="Delete the picked marker").count() == 0
        assert not page.get_by_role("button", name="Move the picked marker").is_visible()
        click_pixel(page, tab, (200, 200), lambda: tab.state.picked_marker == 0)
        # keys typed in a field are the field's
        page.get_by_text("Rename, glass, remove, clear", exact=True).click()
        field = page.locator("xpath=//*[text()='Name']/following::input[1]")
        field.click()
        page.keyboard.press("Backspace")
        time.sleep(0.5)  # deliberate: a wrong delete would reach the server meanwhile
        assert len(app.editor.mirror(mirror).markers) == 1
        field.blur()
        page.keyboard.press("Delete")
        wait_for(lambda: not app.editor.mirror(mirror).markers, 10, "Delete: the marker deleted")
    finally:
        page.close()


def test_save_the_view_as_png(app, browser):
    page, tab = open_tab(browser, app, 1024, 600)
    try:
        page.get_by_text("Playback and view", exact=True).click()
        with page.expect_download(timeout=90_000) as download:
            button(page, "Save the view as PNG")
        path = download.value.path()
        image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        assert download.value.suggested_filename == "mirrorscan-view.png"
        assert image.shape[:2] == (tab.client.camera.image_height, tab.client.camera.image_width)
        # the scene drawn, not a blank
        assert image[..., :3].std() > 5
    finally:
        page.close()
