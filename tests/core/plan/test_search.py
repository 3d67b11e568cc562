"""The layout's limits (inside the room, clear of the subject, facing the camera, not crossing),
the hand-made layouts, and the search: never worse than the best hand-made layout, cancellable."""
import threading

import numpy as np
import pytest

from mirrorcore.base.errors import Cancelled, MirrorscanError
from mirrorcore.plan.layout import LayoutSpace
from mirrorcore.plan.search import SearchSettings, plan_rig, score, subject_distances
from mirrorcore.plan.setup import parse_room, plan_camera
from mirrorcore.plan.subject import make_subject

ROOM = parse_room("3.0,3.6", 1.0)
CAMERA = plan_camera("kinect_v1")
QUICK = SearchSettings(coarse_samples=400, fine_samples=600, final_samples=3000, generations=3,
                       population=3)


@pytest.fixture(scope="module")
def space():
    return LayoutSpace(2, (0.8, 1.9), ROOM, make_subject("person:1.75", 2.0, ROOM.floor_y),
                       CAMERA)


def test_symmetric_v_keeps_every_limit(space):
    x = space.hand_made(0.0, 120.0, 0.9, 0.0)
    glass = space.glass(x)
    assert space.violation(x) == 0.0
    # mirror images of each other across x = 0, 120 degrees between their faces
    assert np.allclose(glass.centre[0] * [-1, 1, 1], glass.centre[1])
    assert np.degrees(np.arccos(-glass.normal[0] @ glass.normal[1])) == pytest.approx(120.0)
    # standing on the floor, full size
    assert glass.corners()[..., 1].max() == pytest.approx(ROOM.floor_y)
    assert np.allclose(glass.half, [[0.4, 0.95]] * 2)


def test_limits_refuse_a_mirror_outside_the_room_or_through_the_subject(space):
    x = space.hand_made(0.0, 120.0, 0.9, 0.0)
    outside = x.copy()
    outside[1] = -1.6        # mirror 1's centre 1.6 m left: its edge beyond the 1.5 m wall
    assert space.violation(outside) > 0
    through = x.copy()
    through[1:3] = space.subject.centre[[0, 2]]
    assert space.violation(through) > 0
    away = x.copy()
    away[3] = 180.0 - away[3]   # turned to face away from the camera
    assert space.violation(away) > 0
    beside = x.copy()
    beside[1:3] = [1.3, 0.3]    # beside the camera: partly behind it and out of the image
    assert space.violation(beside) >= 1.0
    crossing = x.copy()
    crossing[8:10] = crossing[1:3] + [0.1, 0.0]
    crossing[10] = -crossing[3]
    assert space.violation(crossing) >= 1.0


def test_room_that_cannot_hold_the_subject_is_refused():
    with pytest.raises(MirrorscanError, match=r"^--room: 1 x 1.2 x 2.5 m cannot hold"):
        subject_distances("person:1.75", parse_room("1,1.2", 1.0), CAMERA, None)
    with pytest.raises(MirrorscanError, match="^--distance: the subject fits"):
        subject_distances("sphere:0.1", ROOM, CAMERA, 3.5)


def test_search_beats_or_keeps_the_hand_made_layout_and_holds_the_limits():
    result = plan_rig("sphere:0.15", 2, (0.6, 1.0), ROOM, CAMERA, distance=2.0, settings=QUICK)
    assert result.space.violation(result.x) == 0.0
    assert score(result.coverage) >= score(result.hand_made_coverage)
    corners = result.glass.corners()
    assert np.all(np.abs(corners[..., 0]) <= 1.5) and np.all(corners[..., 2] <= 3.6)
    assert result.coverage.coverage > result.coverage.per_view[0]


def test_search_is_cancellable():
    event = threading.Event()
    event.set()
    with pytest.raises(Cancelled):
        plan_rig("sphere:0.15", 2, (0.6, 1.0), ROOM, CAMERA, distance=2.0, settings=QUICK,
                 cancel=event)


def test_search_stops_between_generations_when_asked():
    calls = []

    def cancel():
        calls.append(1)
        # the hand-made layouts ask 7 times; the 8th is the evolution's first generation
        return len(calls) >= 8

    with pytest.raises(Cancelled):
        plan_rig("sphere:0.15", 2, (0.6, 1.0), ROOM, CAMERA, distance=2.0, settings=QUICK,
                 cancel=cancel)
    assert len(calls) == 8


def test_check_names_the_mirror_and_the_limit(space):
    x = space.hand_made(0.0, 120.0, 0.9, 0.0)
    space.check(x)
    outside = x.copy()
    outside[1] = -1.6
    with pytest.raises(MirrorscanError, match=r"^mirror 1: outside the room by 0\.\d\d m$"):
        space.check(outside)
    away = x.copy()
    away[10] = 180.0 - away[10]
    with pytest.raises(MirrorscanError, match="^mirror 2: turned away from the camera"):
        space.check(away)
    crossing = x.copy()
    crossing[8:10] = crossing[1:3] + [0.1, 0.0]
    crossing[10] = -crossing[3]
    with pytest.raises(MirrorscanError, match="crosses|too near|behind"):
        space.check(crossing)


def test_search_from_a_layout_keeps_it_when_nothing_better_is_found():
    with pytest.raises(MirrorscanError, match="needs the subject's distance"):
        plan_rig("sphere:0.15", 2, (0.6, 1.0), ROOM, CAMERA, start=np.zeros(15))
    first = plan_rig("sphere:0.15", 2, (0.6, 1.0), ROOM, CAMERA, distance=2.0, settings=QUICK)
    again = plan_rig("sphere:0.15", 2, (0.6, 1.0), ROOM, CAMERA, distance=2.0, settings=QUICK,
                     start=first.x)
    assert score(again.coverage) >= score(first.coverage) - 1e-12
    assert again.space.violation(again.x) == 0.0
