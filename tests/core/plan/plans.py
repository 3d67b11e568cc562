"""Hand-written plan.json files for the drawing's and the plan file's tests.

V_PLAN: a symmetric V of two mirrors of 0.8 x 1.9 m at 120 degrees, its apex 2.6 m ahead of a
level camera 1.0 m above the floor, behind a sphere of 0.15 m radius 1.8 m ahead; the mirrors'
bottom edges 0.2 m above the floor (y = 0.8 in the camera frame). Each mirror runs 0.8 m from the
apex at 60 degrees to the camera's axis: its far end at x = -/+0.8 sin 60 = 0.69282,
z = 2.6 - 0.8 cos 60 = 2.2.

THREE_PLAN: a middle mirror of 0.8 x 1.9 m facing the camera 2.6 m ahead, and two of 0.6 x 1.5 m
(bottom 0.3 m above the floor) beside it at 120 degrees to it, 20 mm from its edges: from
x = -/+0.42 towards the camera at 30 degrees to its axis (0.6 sin 30 = 0.3, 0.6 cos 30 = 0.51962).
"""
from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np

CAMERA = {"width": 640, "height": 480, "fx": 525.0, "fy": 525.0, "cx": 319.5, "cy": 239.5,
          "min_depth": 0.5, "max_depth": 4.5}

V_PLAN = {
    "camera": CAMERA,
    "mirrors": [
        {"name": "mirror 1", "corners": [[0.0, 0.8, 2.6], [-0.69282032, 0.8, 2.2],
                                         [-0.69282032, -1.1, 2.2], [0.0, -1.1, 2.6]]},
        {"name": "mirror 2", "corners": [[0.0, 0.8, 2.6], [0.69282032, 0.8, 2.2],
                                         [0.69282032, -1.1, 2.2], [0.0, -1.1, 2.6]]}],
    "subject": {"kind": "sphere", "center": [0.0, 0.0, 1.8], "radius": 0.15},
    "room": {"width": 3.0, "depth": 3.6, "height": 2.5, "camera_height": 1.0},
    "predicted": {"coverage": 0.812, "coverage_2": 0.365,
                  "per_view": {"direct": 0.5, "mirror 1": 0.31, "mirror 2": 0.31},
                  "noise_mm": {"direct": 2.3, "mirror 1": 7.9, "mirror 2": 7.9}},
    "search": {"mirrors": 2, "bounces": 1},
}

THREE_PLAN = {
    "camera": CAMERA,
    "mirrors": [
        {"name": "left", "corners": [[-0.42, 0.9, 2.6], [-0.72, 0.9, 2.08038],
                                     [-0.72, -0.6, 2.08038], [-0.42, -0.6, 2.6]]},
        {"name": "middle", "corners": [[-0.4, 1.0, 2.6], [0.4, 1.0, 2.6],
                                       [0.4, -0.9, 2.6], [-0.4, -0.9, 2.6]]},
        {"name": "right", "corners": [[0.42, 0.9, 2.6], [0.72, 0.9, 2.08038],
                                      [0.72, -0.6, 2.08038], [0.42, -0.6, 2.6]]}],
    "subject": {"kind": "cylinder", "axis_xz": [0.0, 1.9], "radius": 0.2,
                "y_range": [-0.5, 1.2]},
    "room": {"width": 3.0, "depth": 3.6, "camera_height": 1.2},
    "predicted": {"coverage": 0.9, "coverage_2": 0.5,
                  "per_view": {"direct": 0.4, "left": 0.3, "middle": 0.35, "right": 0.3},
                  "noise_mm": {"direct": 2.0, "left": 6.0, "middle": 6.5, "right": 6.0}},
}


def tilted(plan: dict, down: float) -> dict:
    """The same layout stated in the frame of the camera turned `down` degrees about its x axis,
    with the `up` that gives the floor (a cylinder's axis by its `ends`)."""
    t = np.radians(down)
    # rows: the tilted camera's axes in the level camera's frame
    rotation = np.array([[1, 0, 0], [0, np.cos(t), -np.sin(t)], [0, np.sin(t), np.cos(t)]])
    out = copy.deepcopy(plan)
    out["up"] = (rotation @ [0.0, -1.0, 0.0]).tolist()
    for mirror in out["mirrors"]:
        mirror["corners"] = (np.asarray(mirror["corners"]) @ rotation.T).tolist()
    subject = out["subject"]
    if subject["kind"] == "sphere":
        subject["center"] = (rotation @ subject["center"]).tolist()
    if subject["kind"] == "cylinder":
        ends = [[subject["axis_xz"][0], y, subject["axis_xz"][1]] for y in subject["y_range"]]
        subject["ends"] = (np.asarray(ends) @ rotation.T).tolist()
    return out


def write_plan(folder: Path, plan: dict) -> Path:
    """Write plan.json into folder (made) and return the folder."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "plan.json").write_text(json.dumps(plan, indent=1))
    return folder
