"""End to end in a real headless Chromium, as a technician works: from an empty session on the
simulated rig, add both mirrors, click their outlines and markers on the depth frame, fit the
planes; a stray marker is refused, a bad fit is a proposal, a single marker is deleted, undo is per
mirror, removal asks and can be undone, two tabs keep their own modes; the layout fits 1024x600; the
dense result has its own layer; exports never overwrite; a hidden tab stops receiving the cloud.
(How fast a click is drawn: test_latency.py.)"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from mirrorscan.panels.mirrors import MirrorsPanel

from mirrorcore.io.ply import read_ply
from mirrorcore.sim.export import session_mirrors
from tests.browser import (
    button,
    canvas_point,
    click_pixel,
    look_at_the_depth_frame,
    open_tab,
    scene_canvas_box,
    step,
    text,
)
from tests.conftest import sphere_app
from tests.waiting import wait_for

ARTIFACTS = Path(__file__).resolve().parents[2] / "artifacts"
LIVE_FPS = 8.0  # software WebGL on 2 cores: keep the stream light while the test drives the page

pytestmark = pytest.mark.steps("app")


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    app = sphere_app(tmp_path_factory.mktemp("browser") / "session", fps=LIVE_FPS)
    app.start()
    yield app
    app.stop()


@pytest.fixture(scope="module")
def tab(app, browser):
    page, tab = open_tab(browser, app, 1400, 900)
    yield page, tab
    page.close()


def test_first_minute_on_an_empty_session(app, tab):
    page, _ = tab
    wait_for(lambda: "Start here" in text(page), 60, "the Start here line")
    assert "Add a mirror" in text(page)
    assert page.get_by_role("button", name="Undo", exact=True).is_disabled()  # nothing to undo yet
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=ARTIFACTS / "browser-first-minute.png")


def test_calibrate_both_mirrors_by_clicking(app, tab):
    page, server_tab = tab
    rig = app.source.rig
    truth = session_mirrors(
        rig, rig.background().truth
    )  # where the simulator drew markers and mirrors
    for j, mirror in enumerate(truth, start=1):
        button(page, "Add a mirror")  # selects it, boundary mode, the depth frame
        wait_for(
            lambda: len(app.editor.session.mirrors) == j and server_tab.state.mode == "boundary"
        )
        if j == 1:
            look_at_the_depth_frame(page, server_tab)
        corners = np.clip(
            np.array(mirror.boundary), 1, [rig.intrinsics.width - 2, rig.intrinsics.height - 2]
        )
        for k, uv in enumerate(corners, start=1):
            click_pixel(page, server_tab, uv, lambda: len(server_tab.state.drafts.get(j, ())) >= k)
        # the first corner again closes it
        click_pixel(page, server_tab, corners[0], lambda: app.editor.mirror(j).boundary)
        np.testing.assert_allclose(np.array(app.editor.mirror(j).boundary), corners, atol=1.0)
        wait_for(lambda: server_tab.state.mode == "markers", what="markers mode after the boundary")
        for k, uv in enumerate(mirror.markers, start=1):
            click_pixel(page, server_tab, uv, lambda: len(app.editor.mirror(j).markers) >= k)
        np.testing.assert_allclose(
            np.array(app.editor.mirror(j).markers), np.array(mirror.markers), atol=1.0
        )
        button(page, "Fit plane")
        wait_for(lambda: app.editor.mirror(j).plane is not None, what=f"mirror {j}'s plane")
        wait_for(lambda: f"mirror {j}: plane fitted" in text(page), what="the fit's report")
    for fitted, true in zip(app.editor.session.mirrors, rig.planes):
        assert fitted.plane.angle_to(true) < 1.0 and abs(fitted.plane.d - true.d) < 0.01
    report = re.search(r"mirror 2: plane fitted, ([0-9.]+) mm RMS; markers: (\d+) good", text(page))
    assert 0.5 < float(report.group(1)) < 15.0 and int(report.group(2)) == len(truth[1].markers)
    page.screenshot(path=ARTIFACTS / "browser-calibrated.png")


def test_a_stray_marker_is_refused_and_a_bad_fit_waits_for_confirmation(app, tab):
    page, server_tab = tab
    before = app.editor.mirror(2)
    assert server_tab.state.mirror_id == 2 and server_tab.state.mode == "markers"
    click_pixel(page, server_tab, (630, 470))  # off mirror 2, beside the panel
    wait_for(lambda: "outside its boundary" in text(page), what="the refusal")
    assert app.editor.mirror(2).markers == before.markers
    bottom = max(before.boundary, key=lambda p: p[1])  # the floor seen through the glass
    click_pixel(
        page,
        server_tab,
        (bottom[0] - 10, bottom[1] - 6),
        lambda: len(app.editor.mirror(2).markers) == len(before.markers) + 1,
    )
    button(page, "Fit plane")
    wait_for(lambda: "Proposal, not applied" in text(page), what="the proposal")
    assert app.editor.mirror(2).plane == before.plane  # not applied
    assert page.get_by_role("button", name="Apply the new plane(s)").is_visible()
    button(page, "Discard the proposal")
    wait_for(lambda: "discarded" in text(page))
    assert app.editor.mirror(2).plane == before.plane
    # the stray marker is still picked: delete just that one
    button(page, f"Delete marker 2.{len(before.markers) + 1}")
    wait_for(lambda: app.editor.mirror(2).markers == before.markers, what="the marker deleted")


def test_undo_is_per_mirror_and_named(app, tab):
    page, server_tab = tab
    mirror1 = app.editor.mirror(1)
    click_pixel(
        page, server_tab, mirror1.markers[0], lambda: server_tab.state.mirror_id == 2
    )  # not mirror 1's
    page.get_by_label("Mirror", exact=True).click()
    page.get_by_role("option", name="mirror 1", exact=True).click()
    wait_for(lambda: server_tab.state.mirror_id == 1, what="mirror 1 selected")
    wait_for(
        lambda: page.get_by_role("button", name="Undo: plane of mirror 1").is_visible(),
        what="undo label",
    )
    button(page, "Undo: plane of mirror 1")
    wait_for(lambda: app.editor.mirror(1).plane is None, what="mirror 1's plane undone")
    assert app.editor.mirror(2).plane is not None  # mirror 2 untouched
    button(page, "Redo: plane of mirror 1")
    wait_for(lambda: app.editor.mirror(1).plane is not None, what="redone")


def test_removing_asks_and_can_be_undone(app, tab):
    page, server_tab = tab
    page.get_by_text("Rename, glass, remove, clear").click()
    button(page, "Remove this mirror…")
    wait_for(
        lambda: page.get_by_role("button", name="Keep it").is_visible(), what="the confirmation"
    )
    button(page, "Keep it")
    assert len(app.editor.session.mirrors) == 2
    button(page, "Remove this mirror…")
    button(page, "Remove mirror 1")
    wait_for(lambda: [m.id for m in app.editor.session.mirrors] == [2], what="the removal")
    wait_for(
        lambda: page.get_by_role("button", name="Bring back mirror 1").is_visible(),
        what="its own button",
    )
    # the main Undo offers it too, and brings mirror 1 back with its own plane
    button(page, "Undo: remove mirror 1")
    wait_for(
        lambda: [m.id for m in app.editor.session.mirrors] == [1, 2], what="mirror 1 back"
    )
    assert app.editor.mirror(1).plane is not None


def test_two_tabs_keep_their_own_mode(app, browser, tab):
    page, server_tab = tab
    server_tab.state.mode = "markers"
    other, other_tab = open_tab(browser, app, 1000, 700)
    other_tab.look("depth")  # a light page: no cloud to draw in software while it is driven
    try:
        button(other, "Boundary")
        wait_for(lambda: other_tab.state.mode == "boundary", what="the other tab's mode")
        assert server_tab.state.mode == "markers"
    finally:
        other.close()


def test_measure_the_sphere(app, tab):
    page, _ = tab
    button(page, "3D scene")
    step(page, "Measure")
    button(page, "Fit to the current cloud")
    report = wait_for(lambda: re.search(r"radius ([0-9.]+) mm", text(page)), what="the fit")
    assert abs(float(report.group(1)) - 115.0) < 3.0


def test_dense_result_has_its_own_layer(app, tab):
    page, server_tab = tab
    step(page, "Dense")
    dense = next(p for p in server_tab.panels if p.TITLE == "Dense")
    button(page, "Run")
    try:  # any end of the job: a refusal or a bug says so at once, with the state
        ended = wait_for(
            lambda: re.search(r"surface voxels|not done|failed|cancelled", text(page)),
            180,
            "the end",
        )
    except AssertionError:
        page.screenshot(path=ARTIFACTS / "browser-dense-timeout.png")
        raise AssertionError(
            f"the carving never ended: status {dense.status.content!r}, running "
            f"{app.jobs.running('dense')}, run disabled {dense.run.disabled}"
        ) from None
    assert ended.group(0) == "surface voxels", dense.status.content
    wait_for(lambda: server_tab.scene._dense, what="the dense layer")
    assert server_tab.scene._box is not None
    page.get_by_label("Show the dense result").click()
    wait_for(
        lambda: (nodes := server_tab.scene._dense) and not nodes[0].visible, what="the layer hidden"
    )
    page.get_by_label("Show the dense result").click()
    page.screenshot(path=ARTIFACTS / "browser-dense.png")


def test_exports_never_overwrite(app, tab, tmp_path):
    page, _ = tab
    step(page, "Session")
    names = []
    for _ in range(2):
        with page.expect_download() as download:
            button(page, "Export the cloud as PLY")
        names.append(download.value.suggested_filename)
        download.value.save_as(
            tmp_path / names[-1]
        )  # as the browser saves it (not kept: every run has two)
    assert names[0] != names[1]
    points, sources = read_ply(tmp_path / names[0])
    assert len(points) > 1000 and set(np.unique(sources)) == {0, 1, 2}
    assert len(list((Path(app.editor.session.root) / "exports").glob("frame-*.ply"))) == 2


def test_the_layout_fits_1024x600(app, browser):
    page, server_tab = open_tab(browser, app, 1024, 600)
    try:
        fit = page.get_by_role("button", name="Fit plane", exact=True).bounding_box()
        assert fit["y"] + fit["height"] <= 600, fit  # visible without scrolling
        look_at_the_depth_frame(page, server_tab)
        canvas = scene_canvas_box(page)
        panel_left = page.get_by_role("button", name="Fit plane", exact=True).bounding_box()["x"]
        right, bottom = canvas_point(
            page, server_tab.client, server_tab.screen.world_of_pixel(639.5, 479.5)
        )
        left, top = canvas_point(
            page, server_tab.client, server_tab.screen.world_of_pixel(-0.5, -0.5)
        )
        # never under the panel
        assert canvas["x"] - 1 <= left and right <= panel_left and bottom <= 600 and top >= 0
        page.screenshot(path=ARTIFACTS / "browser-1024x600.png")
        # a proposal: its Apply in view
        mirrors = next(p for p in server_tab.panels if isinstance(p, MirrorsPanel))
        server_tab.state.mirror_id = 2
        floor = max(app.editor.mirror(2).boundary, key=lambda p: p[1])
        app.editor.add_marker(2, (floor[0] - 10, floor[1] - 6))
        mirrors.fit_planes([2])
        apply = page.get_by_role("button", name="Apply the new plane(s)")
        wait_for(lambda: apply.is_visible(), what="the proposal")
        box = apply.bounding_box()
        assert box["y"] + box["height"] <= 600, box
        page.screenshot(path=ARTIFACTS / "browser-1024x600-proposal.png")
        mirrors._discard()
        app.editor.undo(2)
    finally:
        page.close()


HIDE = """Object.defineProperty(document, "hidden", {value: %s, configurable: true});
document.dispatchEvent(new Event("visibilitychange"));"""


def test_a_hidden_tab_gets_no_cloud(app, browser):
    page, server_tab = open_tab(browser, app, 1000, 700)
    try:
        wait_for(lambda: server_tab.scene._clouds, what="the cloud")
        page.evaluate(HIDE % "true")
        wait_for(lambda: server_tab.hidden, 10, "the server to know the tab is hidden")
        page.evaluate(HIDE % "false")
        wait_for(lambda: not server_tab.hidden, 10, "the tab back")
    finally:
        page.close()
