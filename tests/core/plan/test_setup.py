"""The plan's camera (presets with their depth range, a camera file) and room, and the subject's
SPEC."""
import pytest

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.camerafiles import save_open3d_json
from mirrorcore.plan.setup import parse_room, plan_camera
from mirrorcore.plan.subject import make_subject, parse_spec


def test_presets_and_files_give_the_camera_and_its_depth_range(tmp_path):
    kinect = plan_camera("kinect_v1")
    assert kinect.intrinsics == Intrinsics.kinect_v1()
    assert (kinect.min_depth, kinect.max_depth) == (0.5, 4.5)
    assert plan_camera("realsense_d435").intrinsics.width == 848
    save_open3d_json(Intrinsics.primesense(), tmp_path / "cam.json")
    assert plan_camera(str(tmp_path / "cam.json")).intrinsics.fx == 525.0
    with pytest.raises(MirrorscanError, match="^--camera: 'kinect2' is neither"):
        plan_camera("kinect2")


def test_room_reads_width_depth_and_height():
    room = parse_room("3,3.6", 1.2)
    assert (room.width, room.depth, room.height, room.floor_y) == (3.0, 3.6, 2.5, 1.2)
    assert parse_room("4,5,3", 1.0).ceiling_y == pytest.approx(-2.0)
    for bad in ("3", "3,0", "a,b", "1,2,3,4"):
        with pytest.raises(MirrorscanError, match="^--room: "):
            parse_room(bad, 1.0)


def test_subjects_stand_on_the_floor():
    assert parse_spec("cylinder:0.2,1.5") == ("cylinder", (0.2, 1.5))
    person = make_subject("person:1.8", 2.5, 1.1)
    top, bottom = person.y_range
    assert bottom == pytest.approx(1.1, abs=1e-6) and bottom - top == pytest.approx(1.8, abs=0.03)
    cylinder = make_subject("cylinder:0.2,1.5", 2.0, 1.0)
    assert cylinder.y_range == pytest.approx((-0.5, 1.0), abs=1e-6)
    # a sphere taller than the camera is high stays level with it
    assert make_subject("sphere:0.6", 2.0, 1.0).centre[1] == 0.0
    assert make_subject("sphere:0.2", 2.0, 1.0).centre[1] == pytest.approx(0.8)
