"""Shared fixtures: the browser tool on the simulated sphere rig (an empty session in a temporary
folder, frames at 15 fps) and on the built-in demo (calibrated, kept in memory), each with a
headless tab connected; the notifications a test's actions raise; a headless Chromium per test
module (skipped without Playwright or Chromium); and the `steps(fixture)` mark of a module whose
tests on that module-scoped fixture are the steps of one session, in order: after a step fails, the
later steps are reported as not run because of it (xfail naming it), not as failures of their own;
and the server's own warning filter in every test."""
from __future__ import annotations

import logging
from pathlib import Path
from types import SimpleNamespace

import pytest

from mirrorscan.demo import calibrated_session, demo_source
from mirrorscan.server import MirrorscanApp, quiet_closed_connections
from mirrorscan.bench.tabs import HeadlessTab
from tests.waiting import wait_for
from mirrorcore.io.session import Session
from mirrorcore.io.sessionfile import save_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import SimulatedSource


def sphere_app(root: Path, fps: float = 15.0) -> MirrorscanApp:
    """The browser tool on the simulated paper rig (sphere at 2 m, mirrors at 120 deg, seed 1),
    editing a new empty session saved in `root`, its sessions folder the one above; not started."""
    rig = Simulator(paper_scene(object="sphere"), seed=1, fps=fps)
    session = Session(root, rig.intrinsics)
    save_session(session)
    return MirrorscanApp(session, SimulatedSource(rig), port=0, sessions_dir=root.parent)


@pytest.fixture(autouse=True)
def servers_warning_filter():
    """mirrorscan.server silences viser's warning for messages to a tab that has gone, once on
    import; pytest restores the warning filters around every test, so each test gets it again (a
    module's server outlives the test that made it)."""
    quiet_closed_connections()


def pytest_configure(config) -> None:
    config.addinivalue_line("markers", "steps(fixture): the module's tests on this module-scoped "
                                       "fixture are the "
                                       "steps of one session, each needing those before it")


def is_step(item) -> bool:
    """Whether a test is a step of its module's session (it uses the fixture its module's `steps`
    mark names)."""
    mark = item.get_closest_marker("steps")
    return mark is not None and mark.args[0] in item.fixturenames


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Remember the first step of a session that failed (in its setup or its test)."""
    report = (yield).get_result()
    if report.failed and is_step(item) and not hasattr(item.module, "failed_step"):
        item.module.failed_step = item.name


def pytest_runtest_setup(item) -> None:
    failed = getattr(item.module, "failed_step", None)
    if failed is not None and is_step(item):
        pytest.xfail(f"not run: the step before failed ({failed})")


@pytest.fixture(scope="module")
def sphere(tmp_path_factory):
    """(app, HeadlessTab) on the simulated sphere rig, the live loop running, a frame already
    processed."""
    app = sphere_app(tmp_path_factory.mktemp("sphere") / "scan")
    app.start()
    wait_for(lambda: app.last_frame is not None, what="the first frame")
    with HeadlessTab(app) as tab:
        yield app, tab
    app.stop()


@pytest.fixture(scope="session")
def demo_calibration():
    """The built-in demo's calibrated session (planes and colour gains), made once: it is the same
    for every demo source."""
    return calibrated_session(demo_source(), Path("unused"))


@pytest.fixture(scope="module")
def demo(demo_calibration):
    """(app, HeadlessTab) on the built-in demo (calibrated, not saved), the live loop not
    started."""
    source = demo_source()
    app = MirrorscanApp(demo_calibration, source, port=0, autosave=False)
    with HeadlessTab(app) as tab:
        yield app, tab
    app.stop()


@pytest.fixture
def notes(monkeypatch):
    """A function that starts recording the notifications of an app: notes(app) -> the list their
    messages land in, notes(app, kinds) also each one's (kind, stay) in `kinds`, notes(app, kinds,
    shown) each one (a SimpleNamespace whose `removed` says whether the app took it away) in
    `shown`."""
    def record(app, kinds: list | None = None, shown: list | None = None) -> list[str]:
        said: list[str] = []

        def notify(client, title, message, kind="error", stay=False, logged=True):
            said.append(message)
            if logged:                                             # as the app's does
                logging.getLogger("mirrorscan").info("%s: %s", title, message)
            if kinds is not None:
                kinds.append((kind, stay))
            note = SimpleNamespace(removed=False)
            note.remove = lambda: setattr(note, "removed", True)
            if shown is not None:
                shown.append(note)
            return note
        monkeypatch.setattr(app, "notify", notify)
        return said
    return record


@pytest.fixture(scope="module")
def browser():
    """Debian's Chromium, headless, through Playwright, for one test module."""
    playwright = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
    from tests.browser import ARGS, CHROMIUM
    if CHROMIUM is None:
        pytest.skip("Debian's chromium is not installed")
    with playwright.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
        yield browser
        browser.close()
