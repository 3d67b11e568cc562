"""End to end in a real headless Chromium: from an empty session on the simulated rig, calibrate both mirrors by
clicking on the depth frame, watch every source fill, fit the sphere, export the cloud through a download."""
from __future__ import annotations

import re
import time
from pathlib import Path

import numpy as np
import pytest

from app.server import MirrorscanApp
from mirrorcore.ply import read_ply
from mirrorcore.session import Session
from mirrorcore.sim.export import session_mirrors
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import SimulatedSource

playwright = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
CHROMIUM = next((p for p in ("/usr/bin/chromium", "/usr/lib/chromium/chromium") if Path(p).exists()), None)
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed")
ARTIFACTS = Path(__file__).parent / "artifacts"
LIVE_FPS = 8.0           # software WebGL on 2 cores: keep the stream light while the test drives the page
CLICK_PAUSE = 0.15       # the browser throttles clicks on scene nodes (~50 ms)


def wait_for(condition, seconds: float = 120.0, what: str = "condition"):
    deadline = time.monotonic() + seconds
    while True:
        value = condition()
        if value:
            return value
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.1)


@pytest.fixture(scope="module")
def rig():
    return Simulator(paper_scene(object="sphere"), seed=0, fps=LIVE_FPS)


@pytest.fixture(scope="module")
def app(rig, tmp_path_factory):
    root = tmp_path_factory.mktemp("browser") / "session"
    app = MirrorscanApp(Session(root, rig.intrinsics), SimulatedSource(rig), port=0,
                        sessions_dir=root.parent)
    app.start()
    yield app
    app.stop()


@pytest.fixture(scope="module")
def page(app):
    with playwright.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=[
            "--no-sandbox", "--disable-background-networking", "--disable-component-update", "--disable-sync",
            "--no-first-run"])
        page = browser.new_page(viewport={"width": 1400, "height": 900})
        page.goto(f"http://127.0.0.1:{app.port}/")
        client = wait_for(lambda: next(iter(app.server.get_clients().values()), None), what="the tab to connect")
        camera_ready = wait_for(lambda: _camera_known(client), what="the tab's camera")
        assert camera_ready
        look_at_the_depth_frame(app, client)
        yield browser, page, client
        browser.close()


def look_at_the_depth_frame(app, client) -> None:
    """Move the tab's view onto the depth frame and wait until the browser reports that view back, steadily (a late
    report of its first view could otherwise overwrite the server's copy of the camera)."""
    position = app.screen.view_pose()[0]
    for _ in range(10):
        app.screen.look_at(client)
        time.sleep(1.5)
        if np.allclose(client.camera.position, position, atol=1e-3):
            time.sleep(1.0)
            if np.allclose(client.camera.position, position, atol=1e-3):
                return
    raise AssertionError(f"the tab's camera stays at {client.camera.position}, not {position}")


def _camera_known(client) -> bool:
    try:
        client.camera.wxyz
        return True
    except Exception:     # viser raises until the browser has reported its camera
        return False


def canvas_point(page, client, world: np.ndarray) -> tuple[float, float]:
    """Where a world point appears on the page (CSS px), from the tab's camera (OpenCV axes, vertical fov)."""
    import viser.transforms as tf
    camera = client.camera
    R = tf.SO3(np.asarray(camera.wxyz)).as_matrix()
    p = R.T @ (np.asarray(world) - np.asarray(camera.position))
    box = page.locator("canvas").first.bounding_box()
    f = (box["height"] / 2) / np.tan(camera.fov / 2)
    return box["x"] + box["width"] / 2 + f * p[0] / p[2], box["y"] + box["height"] / 2 + f * p[1] / p[2]


def click_pixel(page, app, client, uv, registered) -> None:
    """Click pixel uv on the depth screen until registered() holds (a click can be lost on a loaded machine)."""
    for _ in range(3):
        x, y = canvas_point(page, client, app.screen.world_of_pixel(*uv))
        page.mouse.click(x, y)
        time.sleep(CLICK_PAUSE)
        try:
            wait_for(registered, seconds=10, what=f"the click at pixel {uv}")
            return
        except AssertionError:
            continue
    raise AssertionError(f"the click at pixel {uv} never reached the server")


def choose(page, label: str, option: str, handle) -> None:
    """Pick `option` in the dropdown `label` and wait until the server's handle holds it."""
    page.get_by_label(label, exact=True).click()
    page.get_by_role("option", name=option, exact=True).click()
    wait_for(lambda: handle.value == option, what=f"{label} = {option}")


def button(page, name: str) -> None:
    page.get_by_role("button", name=name, exact=True).click()
    time.sleep(0.3)


def test_calibrate_watch_measure_export(app, page, rig):
    browser, page, client = page
    truth = session_mirrors(rig, rig.background().truth)        # where the simulator drew markers and mirrors
    wait_for(lambda: app.last_frame is not None, what="the first live frame")

    for j, mirror in enumerate(truth):
        button(page, "Add a mirror")
        wait_for(lambda: len(app.editor.session.mirrors) == j + 1, what=f"mirror {j + 1}")
        choose(page, "Mirror", f"mirror {j + 1}", app.mirrors_panel.mirror)
        choose(page, "Click to", "markers", app.mirrors_panel.mode)
        for k, uv in enumerate(mirror.markers[:4], start=1):
            click_pixel(page, app, client, uv, lambda: len(app.editor.session.mirrors[j].markers) >= k)
        clicked = wait_for(lambda: len(app.editor.session.mirrors[j].markers) == 4 and app.editor.session.mirrors[j],
                           what=f"mirror {j + 1}'s markers")
        np.testing.assert_allclose(np.array(clicked.markers), np.array(mirror.markers[:4]), atol=1.0)

        choose(page, "Click to", "boundary", app.mirrors_panel.mode)
        corners = np.clip(np.array(mirror.boundary), 1, [rig.intrinsics.width - 2, rig.intrinsics.height - 2])
        for k, uv in enumerate(corners, start=1):
            click_pixel(page, app, client, uv, lambda: len(app.editor.drafts.get(j, ())) >= k)
        button(page, "Close boundary")
        drawn = wait_for(lambda: app.editor.session.mirrors[j].boundary, what=f"mirror {j + 1}'s boundary")
        np.testing.assert_allclose(np.array(drawn), corners, atol=1.0)

    button(page, "Fit all planes")
    wait_for(lambda: all(m.plane is not None for m in app.editor.session.mirrors), what="the planes")
    for fitted, true in zip(app.editor.session.mirrors, rig.planes):
        assert fitted.plane.angle_to(true) < 1.0 and abs(fitted.plane.d - true.d) < 0.01
    shown = page.get_by_text(re.compile(r"mirror 1: RMS [0-9.]+ mm")).inner_text()
    rms = float(re.search(r"RMS ([0-9.]+) mm", shown).group(1))
    assert 0.5 < rms < 15.0                                      # Kinect noise at ~2.5 m: a few mm

    def counts():
        text = page.locator("body").inner_text()
        found = {name: int(n.replace(",", "")) for name, n in re.findall(r"(direct|mirror \d): ([\d,]+) points", text)}
        return found if len(found) == 3 and min(found.values()) > 0 else None
    assert min(wait_for(counts, what="points from every source").values()) > 500

    late = browser.new_page(viewport={"width": 1000, "height": 700})   # a tab that joins now sees the same state
    late.goto(f"http://127.0.0.1:{app.port}/")
    wait_for(lambda: "mirror 2: RMS" in late.locator("body").inner_text(), what="the late tab's calibration report")
    wait_for(lambda: re.search(r"mirror 2: [\d,]+ points", late.locator("body").inner_text()), what="late counts")
    late.close()

    choose(page, "Click to", "inspect", app.mirrors_panel.mode)
    button(page, "Fit to the current cloud")
    report = page.get_by_text(re.compile(r"sphere: radius")).inner_text()
    radius = float(re.search(r"radius ([0-9.]+) mm", report).group(1))
    assert abs(radius - 115.0) < 3.0

    with page.expect_download() as download:
        button(page, "Export cloud as PLY")
    target = ARTIFACTS / "browser-export.ply"
    ARTIFACTS.mkdir(exist_ok=True)
    download.value.save_as(target)
    points, sources = read_ply(target)
    assert len(points) > 1000 and set(np.unique(sources)) == {0, 1, 2}
    saved = Path(app.editor.session.root) / "exports"
    assert len(list(saved.glob("*.ply"))) == 1

    app.view.look_from_home(client)
    time.sleep(2.0)
    page.screenshot(path=ARTIFACTS / "browser-final.png")
