"""Helpers shared by the panels' tests: a panel of a tab, a click on its depth frame, both mirrors
calibrated by clicking, the background captured."""
import time

from mirrorscan.events import JobProgress
from mirrorscan.panels.mirrors import MirrorsPanel
from mirrorscan.panels.object import ObjectPanel

from mirrorcore.sim.export import session_mirrors
from tests.waiting import wait_for


def panel(tab, kind):
    """The tab's panel of class `kind`."""
    return next(p for p in tab.panels if isinstance(p, kind))


def click(tab, uv) -> None:
    """A click on the tab's depth frame at pixel uv (as the screen reports it)."""
    tab._clicked(float(uv[0]), float(uv[1]))


def calibrate_by_clicking(app, tab, fit: bool = True) -> None:
    """Add both mirrors and click their outlines and markers where the simulator shows them, then
    fit all (`fit`)."""
    mirrors = panel(tab, MirrorsPanel)
    rig = app.source.rig
    for truth in session_mirrors(rig, rig.background().truth):
        mirrors._add()  # Add a mirror: selects it, boundary mode
        assert tab.state.mode == "boundary" and tab.state.view == "depth"
        for uv in truth.boundary:
            click(tab, uv)
        click(tab, truth.boundary[0])  # the first corner again closes it
        assert tab.state.mode == "markers"
        for uv in truth.markers:
            click(tab, uv)
    time.sleep(0.5)  # a few frames for the median
    if fit:
        mirrors.fit_planes([m.id for m in app.editor.session.mirrors])


def capture_background(app, headless, objects_in_view: bool) -> None:
    """Capture the background from the Object step, the simulated objects in view or not."""
    app.source.objects_in_view = objects_in_view
    ended: list[str] = []  # the capture's last status, told once the job is over
    unsubscribe = app.bus.subscribe(
        JobProgress,
        lambda e: e.job == "background" and e.fraction is None and ended.append(e.status),
    )
    try:
        panel(headless.tab, ObjectPanel)._capture()
        wait_for(lambda: ended, what="the capture")
    finally:
        unsubscribe()
        app.source.objects_in_view = True
