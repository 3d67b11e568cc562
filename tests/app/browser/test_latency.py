"""How fast a click on the depth frame shows in a real headless Chromium with the demo running (its
simulator and live loop at 30 fps): measured in the page, from the pointer going down to the first
animation frame after the depth frame with the new marker was decoded. In a module of its own, so
that no other app or page shares the cores."""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
from mirrorscan.demo import calibrated_session, demo_source
from mirrorscan.server import MirrorscanApp

from tests.browser import click_pixel, look_at_the_depth_frame, open_tab
from tests.waiting import wait_for

ARTIFACTS = Path(__file__).resolve().parents[2] / "artifacts"

# ms: the figure this test is for. Headless Chromium draws with SwiftShader on the machine's two
# cores, which the demo's simulator and live loop share; the bound leaves room for a loaded 2-core
# machine. The server's part is `click_ms` in `mirrorscan bench`.
PAGE_CLICK_MS = 1500
CLICKS_APART = 0.5  # seconds between two clicks, as a technician's
# mean |RGB difference| to the marker's ring under which the page shows it (JPEG blurs it)
RING_DRAWN = 30


def marker_ring(overlay: np.ndarray, uv: tuple[int, int]) -> list[list[int]]:
    """The pixels of the marker at `uv` that do not depend on its grade (5 to 7.5 px from its
    centre: its halo and the mirror's colour), as the 21x21 patch around it in the tab's overlay has
    them: [[index in the patch, r, g, b]...], or [] while the overlay has no marker there."""
    u, v = uv
    patch = overlay[v - 10:v + 11, u - 10:u + 11]
    dv, du = np.mgrid[-10:11, -10:11]
    ring = (np.hypot(du, dv) >= 5) & (np.hypot(du, dv) <= 7.5) & (patch[..., 3] > 0)
    # not drawn yet
    if ring.sum() < 50:
        return []
    return [[int(i), *map(int, patch.reshape(-1, 4)[i, :3])] for i in np.flatnonzero(ring)]


# In the page: [the last depth frame before the click's distance to the marker's ring, ms from the
# click until the first depth frame within `limit` of it was shown (or null), [ms, distance] of
# every frame since the click, ms from the click until that frame arrived].
FIRST_DRAWN = """([ring, limit, u, v]) => {
  const c = window.__clicked;
  if (c === null) return [null, null, []];
  const distance = (bitmap) => {
    const patch = window.__patch(bitmap, u, v);
    let d = 0;
    for (const [i, r, g, b] of ring)
      d += Math.abs(patch[4 * i] - r) + Math.abs(patch[4 * i + 1] - g)
        + Math.abs(patch[4 * i + 2] - b);
    return d / (3 * ring.length);
  };
  const last = window.__depth.filter(f => f[0] < c).at(-1);
  const drawn = window.__depth.find(f => f[0] >= c && distance(f[2]) < limit);
  const since = window.__depth.filter(f => f[0] >= c).map(f => [f[1] - c, distance(f[2])]);
  return [last ? distance(last[2]) : null, drawn ? drawn[1] - c : null, since,
          drawn ? drawn[0] - c : null];
}"""


def test_a_click_is_drawn_in_the_page_quickly_with_the_demo_running(browser, tmp_path):
    source = demo_source()
    demo = MirrorscanApp(calibrated_session(source, tmp_path / "demo"), source, port=0,
                         autosave=False)
    demo.start()
    try:
        # a laptop's screen
        page, server_tab = open_tab(browser, demo, 1024, 600)
        page.evaluate("document.addEventListener('pointerdown', "
                      "() => { window.__clicked = performance.now(); }, {capture: true});")
        # at once: the demo's cloud at 30 fps would load the page first
        server_tab.look("depth")
        look_at_the_depth_frame(page, server_tab, press=False)
        server_tab.state.mirror_id, server_tab.state.mode = 1, "markers"
        mirror = demo.editor.mirror(1)
        # on the glass, away from the figure
        u, v = np.mean(np.array(mirror.boundary), axis=0) + [0, -60]
        latencies, arrivals = [], []
        for k in range(3):
            time.sleep(CLICKS_APART)  # deliberate: clicks apart, as a technician's
            # the listener keeps the last pointer down (a retried click)
            page.evaluate("window.__clicked = null;")
            count = len(mirror.markers) + k + 1
            click_pixel(page, server_tab, (u, v + 40 * k),
                        lambda: len(demo.editor.mirror(1).markers) == count)
            # where the click landed
            uv = tuple(int(round(c)) for c in demo.editor.mirror(1).markers[-1])
            ring = wait_for(lambda: marker_ring(server_tab.overlay.image, uv), 10,
                            "the marker in the tab's overlay")

            def drawn_in_page():
                found = page.evaluate(FIRST_DRAWN, [ring, RING_DRAWN, *uv])
                return found if found[1] is not None else None
            before, drawn, _, arrived = wait_for(drawn_in_page, 10, "the marker drawn in the page")
            assert before is not None and before > RING_DRAWN, \
                f"the marker was there before the click: {before}"
            latencies.append(drawn)
            arrivals.append(arrived)
        ARTIFACTS.mkdir(exist_ok=True)
        figures = {"shown_ms": latencies, "arrived_ms": arrivals}
        (ARTIFACTS / "click-latency.json").write_text(json.dumps(figures))
        assert max(latencies) < PAGE_CLICK_MS, \
            f"shown after {latencies} ms, arrived after {arrivals} ms"
        page.close()
    finally:
        demo.stop()
