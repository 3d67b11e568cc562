"""The plan served in the browser, without a browser: a drag changes the figures, a layout out of
the room is refused in one line and the mirror stays, the search from the layout can be cancelled,
Save plan writes the plan folder, and Simulate serves the layout as a simulated rig."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from mirrorcore.base.errors import Cancelled, MirrorscanError
from mirrorcore.plan.layout import PER_MIRROR
from mirrorcore.plan.search import SearchSettings, plan_rig
from mirrorcore.plan.setup import PlanRoom, plan_camera
from mirrorscan.plandesk import PlanDesk, quaternion_yaw, yaw_quaternion
from mirrorscan.planapp import PlanApp
from tests.waiting import wait_for

FAST = SearchSettings(coarse_samples=300, fine_samples=400, final_samples=2000, generations=2,
                      population=2)


@pytest.fixture(scope="module")
def result():
    """A quick plan of two mirrors for a sphere of 0.3 m, 1.6 m ahead."""
    return plan_rig("sphere:0.3", 2, (0.8, 1.9), PlanRoom(3.0, 3.6, 2.5, 1.0),
                    plan_camera("kinect_v1"), distance=1.6, settings=FAST)


def test_yaw_quaternions_round_trip():
    for yaw in (-110.0, -30.0, 0.0, 45.0, 119.0):
        assert quaternion_yaw(yaw_quaternion(yaw)) == pytest.approx(yaw)


def test_a_drag_changes_the_figures(result):
    desk = PlanDesk(result)
    position, wxyz = desk.pose(0)
    before = desk.coverage
    # mirror 1 turned 25 degrees away from the subject: it sees less
    yaw = quaternion_yaw(wxyz) + 25.0 * np.sign(position[0])
    after = desk.move(0, position, yaw_quaternion(yaw))
    assert desk.result.x[1 + 2] == pytest.approx(yaw)
    assert after.per_view[1] != pytest.approx(before.per_view[1])
    assert after.per_view[0] == pytest.approx(before.per_view[0])
    # moved on the floor, its height kept
    moved = position + [0.0, 0.5, -0.1]
    desk.move(0, moved, yaw_quaternion(yaw))
    centre = desk.result.glass.centre[0]
    assert centre[[0, 2]] == pytest.approx(moved[[0, 2]])
    assert centre[1] == pytest.approx(position[1])


def test_a_mirror_out_of_the_room_is_refused(result):
    desk = PlanDesk(result)
    position, wxyz = desk.pose(1)
    kept = desk.result.x.copy()
    outside = position.copy()
    outside[0] = 1.45 * np.sign(position[0] or 1.0)
    with pytest.raises(MirrorscanError, match=r"^mirror 2: outside the room by \d+\.\d\d m$"):
        desk.move(1, outside, wxyz)
    assert np.array_equal(desk.result.x, kept)


def test_a_mirror_through_the_subject_is_refused(result):
    desk = PlanDesk(result)
    _, wxyz = desk.pose(0)
    with pytest.raises(MirrorscanError, match="mirror 1: too near the subject"):
        desk.move(0, result.space.subject.centre, wxyz)


def test_the_search_from_the_layout_can_be_cancelled(result):
    desk = PlanDesk(result)
    kept = desk.result
    cancel = threading.Event()
    cancel.set()
    with pytest.raises(Cancelled):
        desk.optimise(cancel=cancel)
    assert desk.result is kept


def test_the_search_starts_from_the_layout(result):
    desk = PlanDesk(result)
    fractions = []
    found = desk.optimise(progress=fractions.append)
    assert fractions and fractions[-1] == pytest.approx(1.0)
    assert desk.result is found
    # the plan is never worse than the layout it started from
    assert found.coverage.coverage >= result.coverage.coverage - 1e-9
    assert found.space.subject.centre[2] == pytest.approx(1.6)


def test_save_writes_the_plan_folder(result, tmp_path):
    desk = PlanDesk(result)
    files = {p.name for p in desk.save(tmp_path / "plan")}
    assert {"plan.json", "scene.json", "drawing.png", "drawing.svg", "report.txt"} <= files


def test_the_app_shows_a_drag_and_refuses_a_bad_one(result, tmp_path):
    app = PlanApp(PlanDesk(result), tmp_path / "plan", port=0)
    try:
        position, wxyz = app.desk.pose(0)
        shown = app.figures.content
        assert app.move(0, position + [0.0, 0.0, -0.15], wxyz)
        assert app.figures.content != shown and app.note.content == ""
        assert app.last_eval_s < 1.0
        assert not app.move(0, position + [5.0, 0.0, 0.0], wxyz)
        assert "outside the room" in app.note.content
        app.optimise()
        app.jobs.cancel("optimise")
        wait_for(lambda: not app.jobs.running("optimise"), 60, "the search to stop")
        wait_for(lambda: "cancelled" in app.note.content.lower(), 10, "the cancel to be told")
        assert not app.optimise_button.disabled and not app.cancel_button.visible
        app.jobs.simulate(app._simulate)
        wait_for(lambda: "open it" in app.simulation.content, 120, "the simulated rig")
        assert (tmp_path / "plan" / "scene.json").is_file()
        wait_for(lambda: app.simulated.last_frame is not None, 60, "its first frame")
    finally:
        app.stop()
