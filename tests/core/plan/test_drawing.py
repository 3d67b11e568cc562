"""The plan's drawing and report: the SVG's dimension texts, read back by their keys, give the
hand-written plans' measures; the PNG is the same sheet; no label hides another."""
from __future__ import annotations

import copy
import itertools
import xml.etree.ElementTree as ET

import cv2
import numpy as np
import pytest
import trimesh

from mirrorcore.plan.drawing import PAGE, drawing, write_drawing
from mirrorcore.plan.planread import load_plan
from mirrorcore.plan.report import write_documents, write_report
from tests.core.plan.plans import THREE_PLAN, V_PLAN, tilted, write_plan


def keyed_texts(svg_path) -> dict[str, str]:
    """The SVG's texts by their data-key."""
    root = ET.parse(svg_path).getroot()
    return {e.get("data-key"): e.text for e in root.iter("{http://www.w3.org/2000/svg}text")
            if e.get("data-key")}


# V_PLAN by hand: the far ends at (-/+0.69282, 2.2), the centres at (-/+0.34641, 2.4):
# hypot = 2.4249 m; the nearer side edges the far ends, hypot(0.69282, 2.2) = 2.3065 m
V_TEXTS = {
    "mirror 1 width": "800", "mirror 2 width": "800", "mirror 1 size": "800 x 1900",
    "mirror 1 / mirror 2 angle": "120°", "mirror 1 / mirror 2 gap": "gap 0",
    "mirror 1 angle to axis": "60° to camera axis", "mirror 2 angle to axis": "60° to camera axis",
    "mirror 1 centre distance": "2425", "mirror 1 edge distance": "edge 2307 from camera",
    "mirror 1 and mirror 2 bottom": "200", "mirror 1 and mirror 2 top": "2100",
    "camera height": "1000", "room width": "3000", "room depth": "3600", "room height": "2500",
    "subject size": "300 across", "subject position": "1800 ahead",
    "subject bottom": "850", "subject top": "1150",
}


@pytest.mark.parametrize("down", [0, 12])
def test_the_v_drawing_states_its_dimensions(tmp_path, down):
    plan = load_plan(write_plan(tmp_path, tilted(V_PLAN, down) if down else V_PLAN))
    png, svg = write_drawing(plan)
    texts = keyed_texts(svg)
    assert {k: texts.get(k) for k in V_TEXTS} == V_TEXTS
    assert texts["camera tilt"] == ("tilt: level" if down == 0 else "tilt: down 12°")
    assert texts["coverage"].startswith("Seen by one view or more: 81 %")
    image = cv2.imread(str(png))
    assert image.shape == (PAGE[1], PAGE[0], 3)
    # a drawing, not a blank page: lines and text cover some of it, the mirrors in their colours
    assert 0.02 < (image.min(axis=2) < 200).mean() < 0.5
    orange = np.all(np.abs(image.astype(int) - [0, 159, 230]) < 20, axis=2)
    assert orange.sum() > 500


@pytest.mark.parametrize("down", [0, -8])
def test_three_mirrors_each_pair_its_angle_and_gap(tmp_path, down):
    data = tilted(THREE_PLAN, down) if down else copy.deepcopy(THREE_PLAN)
    data["predicted"]["noise_mm"]["left"] = None
    _, svg = write_drawing(load_plan(write_plan(tmp_path, data)))
    texts = keyed_texts(svg)
    assert texts["left / middle angle"] == texts["middle / right angle"] == "120°"
    assert texts["left / middle gap"] == texts["middle / right gap"] == "gap 20"
    assert texts["left angle to axis"] == "30° to camera axis"
    assert texts["middle angle to axis"] == "90° to camera axis"
    assert (texts["left size"], texts["middle size"]) == ("600 x 1500", "800 x 1900")
    assert (texts["left and right bottom"], texts["left and right top"]) == ("300", "1800")
    assert (texts["middle bottom"], texts["middle top"]) == ("200", "2100")
    assert texts["camera height"] == "1200" and "room height" not in texts
    # a cylinder standing on the floor: no bottom to measure
    assert texts["subject top"] == "1700" and "subject bottom" not in texts
    assert texts["left view"] == "left: 30 % seen"
    assert texts["camera tilt"] == ("tilt: level" if down == 0 else "tilt: up 8°")


def _many_views() -> dict:
    """THREE_PLAN followed through up to three mirrors: 22 views."""
    data = copy.deepcopy(THREE_PLAN)
    mirrors = ("left", "middle", "right")
    paths = [(m,) for m in mirrors]
    for _ in range(2):
        paths += [p + (m,) for p in paths if len(p) == len(paths[-1]) for m in mirrors
                  if m != p[-1]]
    names = ["direct"] + [" then ".join(p) for p in paths]
    assert len(names) == 22
    data["predicted"]["per_view"] = {n: 0.1 for n in names}
    data["predicted"]["noise_mm"] = {n: 9.5 for n in names}
    return data


@pytest.mark.parametrize("data", [V_PLAN, THREE_PLAN, tilted(V_PLAN, 20), _many_views()],
                         ids=["v", "three", "v tilted", "22 views"])
def test_no_label_overlaps_another_or_an_outline_or_leaves_the_page(tmp_path, data):
    sheet = drawing(load_plan(write_plan(tmp_path, data)))
    for a, b in itertools.combinations(sheet.labels, 2):
        assert not a.overlaps(b), (a.lines, b.lines)
    # nor a mirror's or the subject's outline in the top view
    for a, b in itertools.product(sheet.labels, sheet.obstacles):
        assert not a.overlaps(b), a.lines
    for label in sheet.labels:
        assert 0 <= label.x and label.x + label.width <= PAGE[0], label.lines
        # the panels end 20 pixels above the page's edge
        assert 0 <= label.y and label.y + label.height <= PAGE[1] - 20, label.lines


def test_a_mesh_subject_is_drawn_by_its_extent(tmp_path):
    box = trimesh.creation.box((0.4, 1.7, 0.3))
    box.apply_translation((0.1, 0.15, 1.9))
    box.export(tmp_path / "subject.ply")
    data = copy.deepcopy(V_PLAN)
    data["subject"] = {"kind": "mesh", "path": "subject.ply"}
    texts = keyed_texts(write_drawing(load_plan(write_plan(tmp_path, data)))[1])
    assert texts["subject size"] == "400 x 300"
    assert texts["subject position"] == "1900 ahead, 100 right"
    # y from -0.7 to 1.0 in the camera frame: from the floor to 1700 above it
    assert texts["subject top"] == "1700" and "subject bottom" not in texts


def test_the_report_gives_the_layout_in_numbers(tmp_path):
    text = write_report(load_plan(write_plan(tmp_path, tilted(V_PLAN, 12)))).read_text()
    assert "1000 above the floor, tilt 12° down" in text
    assert "mirror 2: 800 wide x 1900 high" in text
    assert "bottom edge 200 above the floor, top 2100" in text
    assert "face at 60° to the camera's axis, upright" in text
    assert "(693, 200, 2200)" in text
    assert ("mirror 1 and mirror 2: 120° between their faces, gap 0 between their edges; their "
            "faces meet at x 0, z 2600") in text
    assert "seen by one view or more: 81.2 %" in text
    assert "seen by two views or more: 36.5 %" in text
    assert "mirror 1                        31.0 %    7.9 mm" in text
    assert "3000 wide (centred on the camera), 3600 deep" in text


def test_a_view_that_sees_nothing_has_no_noise(tmp_path):
    data = copy.deepcopy(THREE_PLAN)
    data["predicted"]["per_view"]["left"] = 0.0
    data["predicted"]["noise_mm"]["left"] = None
    text = write_report(load_plan(write_plan(tmp_path, data))).read_text()
    assert "  left                             0.0 %      -\n" in text


def test_a_plan_folder_gets_its_drawing_and_report(tmp_path):
    written = write_documents(write_plan(tmp_path, V_PLAN))
    assert [p.name for p in written] == ["drawing.png", "drawing.svg", "report.txt"]
    assert all(p.stat().st_size > 1000 for p in written)


def test_mirrors_leaning_back_say_so(tmp_path):
    # each top edge moved 1.9 sin 5 back along the mirror's outward normal (-/+0.5, 0.866 in
    # x, z) and 1.9 (1 - cos 5) down: 1900 along the face, 5 degrees back from upright
    data = copy.deepcopy(V_PLAN)
    back, drop = 1.9 * np.sin(np.radians(5)), 1.9 * (1 - np.cos(np.radians(5)))
    for side, mirror in zip((-1, 1), data["mirrors"]):
        for corner in mirror["corners"][2:]:
            corner[0] += side * 0.5 * back
            corner[1] += drop
            corner[2] += 0.8660254 * back
    plan = load_plan(write_plan(tmp_path, data))
    texts = keyed_texts(write_drawing(plan)[1])
    assert texts["mirror 1 and mirror 2 lean"] == "leans 5° back"
    assert texts["mirror 1 size"] == "800 x 1900"
    assert texts["mirror 1 and mirror 2 top"] == str(round(200 + 1900 * np.cos(np.radians(5))))
    assert "its top leaning 5° away from the camera" in write_report(plan).read_text()
