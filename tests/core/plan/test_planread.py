"""plan.json read and validated: the hand-written plans load as written, a tilted camera's floor
gives its height, and each bad key is refused in one line naming the file and the key."""
from __future__ import annotations

import copy

import numpy as np
import pytest
import trimesh

from mirrorcore.base.errors import FileFormatError
from mirrorcore.plan.planread import load_plan
from tests.core.plan.plans import THREE_PLAN, V_PLAN, tilted, write_plan


def test_the_v_plan_reads_as_written(tmp_path):
    plan = load_plan(write_plan(tmp_path, V_PLAN))
    assert (plan.camera.width, plan.camera.fx, plan.min_depth, plan.max_depth) == (
        640, 525.0, 0.5, 4.5)
    assert plan.floor.normal == (0.0, -1.0, 0.0) and plan.floor.d == 1.0
    assert [m.name for m in plan.mirrors] == ["mirror 1", "mirror 2"]
    np.testing.assert_allclose(plan.mirrors[1].corners[1], [0.69282032, 0.8, 2.2])
    assert not plan.mirrors[0].corners.flags.writeable
    assert (plan.subject.kind, plan.subject.center, plan.subject.radius) == (
        "sphere", (0.0, 0.0, 1.8), 0.15)
    assert (plan.room.width, plan.room.depth, plan.room.height) == (3.0, 3.6, 2.5)
    assert plan.room.camera_height == 1.0
    assert plan.predicted.coverage_2 == 0.365
    assert plan.predicted.noise_mm == {"direct": 2.3, "mirror 1": 7.9, "mirror 2": 7.9}
    assert plan.search == {"mirrors": 2, "bounces": 1}


def test_a_tilted_camera_states_its_up(tmp_path):
    plan = load_plan(write_plan(tmp_path, tilted(V_PLAN, 12)))
    assert plan.floor.d == pytest.approx(1.0)
    # up, in the frame of a camera looking down, has a negative z
    assert plan.floor.normal[2] == pytest.approx(-np.sin(np.radians(12)))


def test_the_planners_own_keys_are_kept_or_ignored(tmp_path):
    data = copy.deepcopy(THREE_PLAN)
    data.update(version=1, level_from_camera=np.eye(3).tolist(), hand_made={"kind": "arc"})
    data["camera"]["tilt_deg"] = 0.0
    data["mirrors"][0].update(width=0.6, height=1.5)
    data["subject"]["spec"] = "cylinder:0.2,1.7"
    data["predicted"]["noise_mm"]["left"] = None
    plan = load_plan(write_plan(tmp_path, data))
    assert plan.predicted.noise_mm["left"] is None and plan.mirrors[0].name == "left"


def test_three_mirrors_and_a_cylinder_without_a_ceiling(tmp_path):
    plan = load_plan(write_plan(tmp_path, THREE_PLAN))
    assert [m.name for m in plan.mirrors] == ["left", "middle", "right"]
    assert (plan.subject.axis_xz, plan.subject.y_range) == ((0.0, 1.9), (-0.5, 1.2))
    assert plan.room.height is None and plan.search == {}


def test_a_mesh_subject_is_a_file_in_the_plan_folder(tmp_path):
    trimesh.creation.box((0.4, 1.7, 0.3)).export(tmp_path / "subject.ply")
    data = copy.deepcopy(V_PLAN)
    data["subject"] = {"kind": "mesh", "path": "subject.ply"}
    assert load_plan(write_plan(tmp_path, data)).subject.path == tmp_path / "subject.ply"


def _set(path: str, value):
    """A change to V_PLAN: the value at a path of keys and indices ('mirrors.0.corners'),
    deleted when value is ...."""
    def change(data):
        *parents, last = [int(k) if k.isdigit() else k for k in path.split(".")]
        for key in parents:
            data = data[key]
        if value is ...:
            del data[last]
        else:
            data[last] = value
    return change


BAD = [
    ("room", _set("room", ...), "missing key(s) room"),
    ("camera_height", _set("room.camera_height", ...), "room: missing key(s) camera_height"),
    ("camera_height", _set("room.camera_height", -1.0),
     "room: 'camera_height' must be a number above 0"),
    ("camera_height", _set("room.camera_height", 2.6), "room: 'camera_height' (2.6) must be below"),
    ("min_depth", _set("camera.min_depth", 5.0), "camera: 'max_depth'"),
    ("camera", _set("camera.fx", "wide"), "camera values must be numbers"),
    ("corners", _set("mirrors.0.corners", [[0, 0, 2]] * 3), "mirrors[0]: corners: must be 4"),
    ("corners", _set("mirrors.1.corners.2", [0.69282032, -1.1, 2.21]),
     "mirrors[1]: corners: a corner lies 9 mm off the plane of the other three"),
    ("corners", _set("mirrors.1.corners", [[0.0, 0.8, 2.6], [0.69282032, -1.1, 2.2],
                                           [0.69282032, 0.8, 2.2], [0.0, -1.1, 2.6]]),
     "mirrors[1]: corners: the 4 corners enclose no area"),
    ("corners", _set("mirrors.1.corners.3", [0.5, 0.3, 2.311325]),
     "mirrors[1]: corners: the corners must go around"),
    ("corners", _set("mirrors.0.corners.3", [0.0, "up", 2.6]), "mirrors[0]: corners[3]"),
    ("mirrors", _set("mirrors", []), "mirrors: must be a list of 1 to"),
    ("name", _set("mirrors.0.name", ""), "mirrors[0]: 'name'"),
    ("kind", _set("subject.kind", "cube"), "subject: 'kind' must be one of"),
    ("radius", _set("subject.radius", 0), "subject: 'radius' must be a number above 0"),
    ("center", _set("subject.center", [0, 1]), "subject: center: must be 3 numbers"),
    ("path", _set("subject", {"kind": "mesh", "path": "../x.ply"}),
     "subject: path: must be a file name inside the plan folder"),
    ("path", _set("subject", {"kind": "mesh", "path": "x.ply"}), "subject: path: no such file"),
    ("y_range", _set("subject", {"kind": "cylinder", "axis_xz": [0, 2], "radius": 0.2,
                                 "y_range": [1, -1]}), "subject: y_range: must be [low, high]"),
    ("width", _set("room.width", 0), "room: 'width' must be a number above 0"),
    ("coverage", _set("predicted.coverage", 1.5), "predicted: 'coverage' must be a share"),
    ("noise_mm", _set("predicted.noise_mm", {"direct": 2.0}),
     "predicted: noise_mm: must name the views of per_view"),
    ("up", _set("up", [0, 1, 0]), "up: must be a unit vector pointing up"),
    ("up", _set("up", [0, -2, 0]), "up: must be a unit vector pointing up"),
    ("up", _set("up", [0, -1]), "up: must be 3 numbers"),
    ("version", _set("version", 2), "unknown version 2"),
    ("noise_mm", _set("predicted.noise_mm.direct", "low"), "predicted: noise_mm: 'direct'"),
    ("ends", _set("subject", {"kind": "cylinder", "axis_xz": [0, 2], "radius": 0.2,
                              "y_range": [-1, 1], "ends": [[0, -1, 2]]}),
     "subject: ends: must be 2 points"),
    ("search", _set("search", [1]), "search: must be an object"),
]


@pytest.mark.parametrize("key, change, message", BAD, ids=[b[2][:40] for b in BAD])
def test_a_bad_key_is_refused_in_one_line_naming_it(tmp_path, key, change, message):
    data = copy.deepcopy(V_PLAN)
    change(data)
    with pytest.raises(FileFormatError) as caught:
        load_plan(write_plan(tmp_path, data))
    text = str(caught.value)
    assert "\n" not in text and text.startswith(str(tmp_path / "plan.json"))
    assert message in text and key in text


def test_a_folder_without_a_plan_or_with_bad_json_is_named(tmp_path):
    with pytest.raises(FileFormatError, match="no such file .is .* a plan folder"):
        load_plan(tmp_path)
    (tmp_path / "plan.json").write_text("[1, 2")
    with pytest.raises(FileFormatError, match="plan.json: invalid JSON"):
        load_plan(tmp_path)
    (tmp_path / "plan.json").write_text("[1, 2]")
    with pytest.raises(FileFormatError, match="plan.json: the top level must be a JSON object"):
        load_plan(tmp_path)


def _paths(data, prefix=()):
    """Every (key or index) path into nested dicts and lists."""
    items = data.items() if isinstance(data, dict) else enumerate(data)
    for key, value in items:
        yield prefix + (key,)
        if isinstance(value, (dict, list)):
            yield from _paths(value, prefix + (key,))


def test_any_value_replaced_by_any_other_is_read_or_refused_in_one_line(tmp_path):
    strange = [None, True, -1, 0, 1e308, "x", [], {}, [1, 2], {"kind": "sphere"}, float("nan")]
    rng = np.random.default_rng(0)
    for data in (V_PLAN, THREE_PLAN, tilted(V_PLAN, 10)):
        for path in _paths(data):
            changed = copy.deepcopy(data)
            target = changed
            for key in path[:-1]:
                target = target[key]
            target[path[-1]] = strange[rng.integers(len(strange))]
            try:
                load_plan(write_plan(tmp_path, changed))
            except FileFormatError as exc:
                assert "\n" not in str(exc)
