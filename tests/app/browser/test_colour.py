"""The colour control in a real headless Chromium on the demo: two clicks (the control, then the
choice) switch the live cloud between true colour, the sources' colours and the heat map; the
View's Colour image shows the colour image on the depth frame's screen."""

from __future__ import annotations

from pathlib import Path

import pytest
from mirrorscan.demo import calibrated_session
from mirrorscan.server import MirrorscanApp

from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import SimulatedSource
from tests.browser import button, open_tab
from tests.waiting import wait_for

LIVE_FPS = 8.0  # software WebGL on 2 cores: keep the stream light while the test drives the page

pytestmark = pytest.mark.steps("app")


@pytest.fixture(scope="module")
def app():
    source = SimulatedSource(Simulator(paper_scene(object="figure", distance=3.0), seed=0,
                                       fps=LIVE_FPS), "simulated rig")
    app = MirrorscanApp(calibrated_session(source, Path("unused")), source, port=0,
                        autosave=False)
    app.start()
    yield app
    app.stop()


def nodes_coloured(tab, per_point: bool) -> bool:
    """Whether every cloud node carries its points' colours (per_point) or one colour."""
    nodes = list(tab.scene._clouds.values())
    return bool(nodes) and all(
        (h.colors.shape == (len(h.points), 3)) if per_point else h.colors.shape == (3,)
        for h in nodes
    )


def pick(page, choice: str) -> None:
    """Open the Colour control and pick a choice: two clicks."""
    page.get_by_label("Colour", exact=True).click()
    page.get_by_role("option", name=choice, exact=True).click()


def test_two_clicks_switch_the_cloud_between_true_colour_source_and_heat_map(app, browser):
    page, tab = open_tab(browser, app, 1024, 600)
    try:
        wait_for(lambda: nodes_coloured(tab, True), 60, "the cloud in true colour")
        page.get_by_text("Playback and view", exact=True).click()
        assert page.get_by_label("Colour", exact=True).input_value() == "true colour"
        pick(page, "source")
        wait_for(lambda: not tab.true_colour and nodes_coloured(tab, False), 30,
                 "the sources' colours")
        pick(page, "heat map")
        wait_for(lambda: tab.heat, 30, "the heat map")
        wait_for(lambda: "/heat" in tab.client.scene._handle_from_node_name, 60,
                 "the heat map drawn")
        wait_for(lambda: page.get_by_text("on the direct surface").is_visible(), 30,
                 "the heat map's key")
        pick(page, "true colour")
        wait_for(lambda: not tab.heat and tab.true_colour and nodes_coloured(tab, True), 30,
                 "true colour again")
        wait_for(lambda: page.get_by_text("True colour", exact=True).is_visible(), 30,
                 "the true-colour legend")
    finally:
        page.close()


def test_the_colour_image_is_one_click_of_the_view(app, browser):
    page, tab = open_tab(browser, app, 1400, 900)
    try:
        button(page, "Colour image")
        wait_for(lambda: tab.state.view == "depth" and tab.state.colour_image, 30,
                 "the colour image")
        button(page, "Depth frame")
        wait_for(lambda: tab.state.view == "depth" and not tab.state.colour_image, 30,
                 "the depth frame")
        button(page, "3D scene")
        wait_for(lambda: tab.state.view == "3d", 30, "the 3D scene")
    finally:
        page.close()
