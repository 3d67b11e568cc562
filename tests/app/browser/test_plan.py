"""The plan in a real headless Chromium, as a technician uses it: the page shows the figures, a
mirror's handle dragged with the mouse changes them, Optimise runs with its progress bar and can
be cancelled, Save plan writes the plan folder; at 1024x600 every button is in view with the
figures open."""

from __future__ import annotations

import time

import numpy as np
import pytest

from mirrorcore.plan.search import SearchSettings, plan_rig
from mirrorcore.plan.setup import PlanRoom, plan_camera
from mirrorscan.planapp import HANDLE_SCALE, PlanApp
from mirrorscan.plandesk import PlanDesk
from tests.browser import button, camera_known, canvas_point, text
from tests.waiting import wait_for

pytestmark = pytest.mark.steps("app")
FAST = SearchSettings(coarse_samples=300, fine_samples=400, final_samples=4000, generations=2,
                      population=2)


def open_plan(browser, app, width: int, height: int):
    """A page on the plan at width x height, and its viser client once its camera is known."""
    page = browser.new_page(viewport={"width": width, "height": height})
    page.goto(f"http://127.0.0.1:{app.port}/")
    client = wait_for(lambda: next(iter(app.server.get_clients().values()), None), 60,
                      "the tab to connect")
    wait_for(lambda: camera_known(client), 60, "the tab's camera")
    return page, client


def drag_mirror(page, client, app, j: int, metres: float) -> None:
    """Drag mirror j's handle by its x arrow, `metres` along its x axis."""
    position, _ = app.desk.pose(j)
    turn = np.asarray(app.handles[j].wxyz)
    w, y = turn[0], turn[2]
    axis = np.array([w * w - y * y, 0.0, -2 * w * y])
    grab = canvas_point(page, client, position + 0.7 * HANDLE_SCALE * axis)
    to = canvas_point(page, client, position + (0.7 * HANDLE_SCALE + metres) * axis)
    page.mouse.move(*grab)
    page.mouse.down()
    for k in range(1, 11):
        page.mouse.move(grab[0] + (to[0] - grab[0]) * k / 10, grab[1] + (to[1] - grab[1]) * k / 10)
        time.sleep(0.05)  # deliberate: the page sends a pose per animation frame
    page.mouse.up()


def test_the_plan_in_the_browser(browser, tmp_path):
    result = plan_rig("person:1.75", 2, (0.8, 1.9), PlanRoom(3.0, 3.6, 2.5, 1.0),
                      plan_camera("kinect_v1"), distance=1.6, settings=FAST)
    app = PlanApp(PlanDesk(result), tmp_path / "plan", port=0)
    try:
        page, client = open_plan(browser, app, 1400, 900)
        wait_for(lambda: "of the subject seen" in text(page), 30, "the figures")
        assert "3+ views" in text(page)
        x = app.desk.result.x.copy()
        drag_mirror(page, client, app, 0, -0.2)
        wait_for(lambda: not np.array_equal(app.desk.result.x, x), 30, "the drag to move it")
        assert app.last_eval_s < 1.0
        button(page, "Optimise")
        wait_for(lambda: app.cancel_button.visible, 10, "the search to start")
        button(page, "Cancel")
        wait_for(lambda: "cancelled" in text(page).lower(), 60, "the cancel")
        button(page, "Save plan")
        wait_for(lambda: (tmp_path / "plan" / "drawing.png").is_file(), 60, "the plan folder")
        wait_for(lambda: "Plan saved" in text(page), 30, "the saved line")
        page.close()
        small = browser.new_page(viewport={"width": 1024, "height": 600})
        small.goto(f"http://127.0.0.1:{app.port}/")
        wait_for(lambda: "of the subject seen" in text(small), 30, "the figures at 1024x600")
        small.get_by_text("Details").first.click()
        for name in ("Optimise", "Save plan", "Simulate"):
            box = small.get_by_role("button", name=name, exact=True).bounding_box()
            assert box["y"] + box["height"] <= 600, name
    finally:
        app.stop()
