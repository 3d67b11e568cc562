"""The Dense step in headless Chromium at 1400x900 and 1024x600, on the simulated sphere rig
calibrated as the demo is: a carved sphere is drawn in shades that read round, from the front and
orbited (the camera set from the server), lit from above on the left; Run keeps the view the
technician turned; the fused mesh is drawn lit. The screenshots go to
tests/artifacts/dense-<view>-<size>.png."""
from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from mirrorscan.demo import calibrated_session
from mirrorscan.placement import beside_offset
from mirrorscan.server import MirrorscanApp
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import SimulatedSource
from scripts.screenshots import CLOSE_WEBGL_NOTICE
from tests.browser import button, canvas_point, open_tab, step, text
from tests.waiting import wait_for

ARTIFACTS = Path(__file__).resolve().parents[2] / "artifacts"
# software WebGL on 2 cores: keep the stream light while the test drives the page
LIVE_FPS = 5.0
SPHERE_RADIUS = 0.115
VIEW_DISTANCE = 0.7     # metres from the sphere's centre to the camera set from the server


@pytest.fixture(scope="module")
def app():
    source = SimulatedSource(Simulator(paper_scene(object="sphere"), seed=1, fps=LIVE_FPS))
    app = MirrorscanApp(calibrated_session(source, Path("unused")), source, port=0,
                        autosave=False)
    app.start()
    wait_for(lambda: app.last_frame is not None, 60, "the first frame")
    yield app
    app.stop()


def run(page, app) -> None:
    made = app.jobs.dense_result.made if app.jobs.dense_result else 0
    button(page, "Run")
    wait_for(lambda: app.jobs.dense_result and app.jobs.dense_result.made > made, 180,
             f"the carving's end ({text(page)[-300:]!r})")
    wait_for(lambda: not app.jobs.running("dense"), 30, "the dense job's end")
    wait_for(lambda: re.search("surface voxels|faces", text(page)), 30, "the result's line")


def look_from(tab, centre: np.ndarray, direction: np.ndarray) -> None:
    """Set the tab's camera VIEW_DISTANCE from `centre` along `direction`, looking at it, -y up."""
    camera = tab.client.camera
    with tab.client.atomic():
        camera.up_direction = (0.0, -1.0, 0.0)
        camera.position = tuple(centre + VIEW_DISTANCE * direction / np.linalg.norm(direction))
        camera.look_at = tuple(centre)


def sphere_on_page(page, tab, centre: np.ndarray, name: str) -> np.ndarray:
    """A screenshot of the page (kept in ARTIFACTS) cropped to the drawn sphere's inner 80 %, grey
    levels."""
    ARTIFACTS.mkdir(exist_ok=True)
    # the page draws the new view
    wait_for(lambda: np.allclose(tab.client.camera.look_at, centre, atol=1e-3), 30, "the view")
    page.wait_for_timeout(1500)  # software WebGL draws the turned view within a second or two
    shot = page.screenshot(path=ARTIFACTS / name)
    grey = np.asarray(Image.open(io.BytesIO(shot)).convert("L"), float)
    u, v = canvas_point(page, tab.client, centre)
    # the sphere's top, seen with -y up
    edge = canvas_point(page, tab.client, centre + [0.0, -0.8 * SPHERE_RADIUS, 0.0])
    r = int(abs(edge[1] - v))
    return grey[int(v) - r:int(v) + r, int(u) - r:int(u) + r]


@pytest.mark.parametrize("size", [(1400, 900), (1024, 600)])
def test_a_carved_sphere_reads_round_and_run_keeps_the_view(app, browser, size):
    page, tab = open_tab(browser, app, *size)
    try:
        wait_for(lambda: page.evaluate(CLOSE_WEBGL_NOTICE), 30, "viser's notice closed")
        step(page, "Dense")
        run(page, app)
        result = app.jobs.dense_result
        centre = (np.asarray(result.low) + np.asarray(result.high)) / 2 + beside_offset(result)
        label = f"{size[0]}x{size[1]}"
        look_from(tab, centre, np.array([0.0, 0.0, -1.0]))
        front = sphere_on_page(page, tab, centre, f"dense-front-{label}.png")
        half = len(front) // 2
        # lit from above on the left: brighter there than below on the right, shaded throughout
        assert front[:half, :half].mean() > front[half:, half:].mean() + 20
        assert front.std() > 15
        # turned to the right: still shaded, not a flat disc of one colour
        look_from(tab, centre, np.array([1.0, -0.3, -0.4]))
        orbited = sphere_on_page(page, tab, centre, f"dense-orbited-{label}.png")
        assert orbited.std() > 15
        position, target = np.array(tab.client.camera.position), np.array(centre)
        run(page, app)
        page.wait_for_timeout(500)  # a framing after the result would reach the server by now
        assert np.allclose(tab.client.camera.position, position, atol=1e-3)
        assert np.allclose(tab.client.camera.look_at, target, atol=1e-3)
    finally:
        page.close()


def test_the_fused_mesh_is_drawn_lit(app, browser):
    page, tab = open_tab(browser, app, 1400, 900)
    try:
        step(page, "Dense")
        page.get_by_label("Method", exact=True).click()
        page.get_by_role("option", name="TSDF fusion (mesh)", exact=True).click()
        dense = next(p for p in tab.panels if p.TITLE == "Dense")
        wait_for(lambda: dense.method.value.startswith("TSDF"), 30, "the method chosen")
        run(page, app)
        result = app.jobs.dense_result
        assert result.faces is not None
        centre = (np.asarray(result.low) + np.asarray(result.high)) / 2 + beside_offset(result)
        look_from(tab, centre, np.array([0.3, -0.3, -1.0]))
        assert sphere_on_page(page, tab, centre, "dense-mesh-1400x900.png").std() > 15
    finally:
        page.close()
