"""Driving the browser tool in headless Chromium as a technician would: open a tab at a window size,
find the app's Tab for it, look at the depth frame, click pixels of it, press buttons, pick tabs of
the side panel, and read in the page when the depth frame it shows changed (a hook on the page's
websocket worker timestamps every depth-frame image and decodes it, so a test can tell when a click
was drawn, measured in the page)."""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import viser.transforms as tf

from tests.waiting import wait_for

CHROMIUM = next((p for p in ("/usr/bin/chromium", "/usr/lib/chromium/chromium")
                 if Path(p).exists()), None)
ARGS = ["--no-sandbox", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run"]
CLICK_PAUSE = 0.15       # seconds: the browser throttles clicks on scene nodes (~50 ms)
SETTLE = 0.3             # seconds for the server to handle a button or a step opened
STEADY = 0.5             # seconds the view must stay put to count as steady

# Every depth-frame image the page receives, decoded, in window.__depth: [arrival ms, ms when the
# next animation frame ran, the image as an ImageBitmap] (the last 64); window.__patch(bitmap, u, v)
# reads the RGBA of its 21x21 pixels around (u, v), flat.
DEPTH_HOOK = """
window.__depth = [];
window.__patch = (bitmap, u, v) => {
  const context = new OffscreenCanvas(21, 21).getContext("2d");
  context.drawImage(bitmap, u - 10, v - 10, 21, 21, 0, 0, 21, 21);
  return Array.from(context.getImageData(0, 0, 21, 21).data);
};
const Base = window.Worker;
window.Worker = class extends Base {
  constructor(...args) {
    super(...args);
    this.addEventListener("message", (event) => {
      const data = event.data;
      if (!data || data.type !== "message_batch") return;
      for (const m of data.messages) {
        if (m.type !== "SceneNodeUpdateMessage" || m.name !== "/depth_frame"
            || !m.updates._data) continue;
        const arrived = performance.now();
        const jpeg = new Blob([new Uint8Array(m.updates._data)], {type: "image/jpeg"});
        createImageBitmap(jpeg).then((bitmap) => {
          requestAnimationFrame(() => {
            window.__depth.push([arrived, performance.now(), bitmap]);
            if (window.__depth.length > 64) window.__depth.shift().close();
          });
        });
      }
    });
  }
};
"""


def open_tab(browser, app, width: int, height: int):
    """A new page at width x height on the app, with the depth hook; returns (page, the app's Tab
    for it)."""
    before = set(app.tabs)
    page = browser.new_page(viewport={"width": width, "height": height})
    page.add_init_script(DEPTH_HOOK)
    page.goto(f"http://127.0.0.1:{app.port}/")
    new = wait_for(lambda: set(app.tabs) - before, 60, "the tab to connect")
    tab = app.tabs[new.pop()]
    wait_for(lambda: camera_known(tab.client), 60, "the tab's camera")
    return page, tab


def camera_known(client) -> bool:
    """Whether the browser has reported the tab's camera (viser asserts until it has)."""
    try:
        client.camera.wxyz
        client.camera.image_width
        return True
    except AssertionError:
        return False


def button(page, name: str) -> None:
    """Press a button of the side panel by its name."""
    page.get_by_role("button", name=name, exact=True).click()
    time.sleep(SETTLE)  # deliberate: no general sign that the server has handled any button


def step(page, title: str) -> None:
    """Open a step of the side panel (a tab of its tab group)."""
    page.get_by_role("tab", name=title, exact=True).click()
    time.sleep(SETTLE)  # deliberate: no general sign that the page has drawn the step


def look_at_the_depth_frame(page, tab, press: bool = True) -> None:
    """Press 'Depth frame' (or not, when the server already switched the tab) and wait until the
    browser reports the view back, steadily (a late report of the previous view could otherwise
    overwrite the server's copy of the camera)."""
    if press:
        button(page, "Depth frame")
    wait_for(lambda: tab.state.view == "depth", 30, "the depth view")
    for _ in range(10):
        aspect = tab.client.camera.image_width / tab.client.camera.image_height
        position = tab.screen.view_pose(aspect)[0]

        def there() -> bool:
            return np.allclose(tab.client.camera.position, position, atol=1e-3)
        try:
            wait_for(there, 1.0, "the depth view reported")
        except AssertionError:
            tab.screen.look_at()
            continue
        time.sleep(STEADY)  # deliberate: a late report of the previous view would come meanwhile
        if there():
            return
        tab.screen.look_at()
    raise AssertionError(f"the tab's camera stays at {tab.client.camera.position}, not {position}")


# The 3D scene's canvas: the largest one of the page (a plot of the side panel has its own, which
# may come first).
SCENE_CANVAS = ("[...document.querySelectorAll('canvas')]"
                ".reduce((a, b) => a.clientWidth * a.clientHeight >= b.clientWidth * b.clientHeight"
                " ? a : b)")


def scene_canvas_box(page) -> dict:
    """The scene canvas's box on the page (CSS px): x, y, width, height."""
    return page.evaluate(f"(() => {{ const r = ({SCENE_CANVAS}).getBoundingClientRect(); "
                         "return {x: r.x, y: r.y, width: r.width, height: r.height}; })()")


def canvas_point(page, client, world: np.ndarray) -> tuple[float, float]:
    """Where a world point appears on the page (CSS px), from the tab's camera (OpenCV axes,
    vertical fov)."""
    camera = client.camera
    R = tf.SO3(np.asarray(camera.wxyz)).as_matrix()
    p = R.T @ (np.asarray(world) - np.asarray(camera.position))
    box = scene_canvas_box(page)
    f = (box["height"] / 2) / np.tan(camera.fov / 2)
    return (box["x"] + box["width"] / 2 + f * p[0] / p[2],
            box["y"] + box["height"] / 2 + f * p[1] / p[2])


def click_pixel(page, tab, uv, registered=None, tries: int = 3) -> None:
    """Click pixel uv of the tab's depth frame, until registered() holds when given (a click can be
    lost on a loaded machine)."""
    for _ in range(tries):
        page.mouse.click(*canvas_point(page, tab.client, tab.screen.world_of_pixel(*uv)))
        time.sleep(CLICK_PAUSE)  # deliberate: the browser throttles clicks on scene nodes
        if registered is None:
            return
        try:
            wait_for(registered, 10, f"the click at pixel {uv}")
            return
        except AssertionError:
            continue
    raise AssertionError(f"the click at pixel {uv} never reached the server")


def text(page) -> str:
    """The page's visible text."""
    return page.locator("body").inner_text()
