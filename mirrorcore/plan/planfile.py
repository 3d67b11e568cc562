"""A plan folder's files (docs/DESIGN.md, "Plan folders"): plan.json, the layout and its predicted
figures in the final (tilted) camera's frame, scene.json that the simulator runs as it is, and the
subject's mesh when it is a person or a mesh file."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mirrorcore.base.atomic import write_atomic
from mirrorcore.plan.coverage import Coverage, tilt_rotation, view_name
from mirrorcore.plan.search import PlanResult
from mirrorcore.sim.layouts import corner_markers
from mirrorcore.sim.scene import Scene, SceneMirror, SceneObject
from mirrorcore.sim.scenefile import save_scene

PLAN_FILE, SCENE_FILE, SUBJECT_MESH = "plan.json", "scene.json", "subject.ply"
PLAN_VERSION = 1


def _rounded(values, places: int = 4) -> list:
    """Nested lists of floats rounded to `places` decimals (0.1 mm for metres)."""
    return np.round(np.asarray(values, np.float64), places).tolist()


def predicted(cov: Coverage) -> dict:
    """plan.json's `predicted` object of a coverage."""
    names = [view_name(v) for v in cov.views]
    noise = cov.noise_mm()
    return {"coverage": round(cov.coverage, 4), "coverage_2": round(cov.coverage_2, 4),
            "per_view": {n: round(float(s), 4) for n, s in zip(names, cov.per_view)},
            "noise_mm": {n: None if np.isnan(v) else round(float(v), 2)
                         for n, v in zip(names, noise)}}


def plan_json(result: PlanResult) -> dict:
    """The plan's plan.json object (every position in the final camera's frame, metres).

    Parameters
    ----------
    result : PlanResult

    Returns
    -------
    dict
    """
    R = tilt_rotation(result.tilt)
    glass, space = result.glass, result.space
    subject = space.subject
    mirrors = [{"name": f"mirror {j + 1}", "corners": _rounded(corners @ R.T),
                "width": round(float(2 * glass.half[j, 0]), 4),
                "height": round(float(2 * glass.half[j, 1]), 4)}
               for j, corners in enumerate(glass.corners())]
    if subject.kind == "sphere":
        shape = {"kind": "sphere", "center": _rounded(R @ subject.centre),
                 "radius": subject.radius}
    elif subject.kind == "cylinder":
        ends = subject.centre + np.outer([-0.5, 0.5], [0.0, subject.height, 0.0])
        ends = ends @ R.T
        middle = ends.mean(axis=0)
        shape = {"kind": "cylinder", "axis_xz": _rounded(middle[[0, 2]]),
                 "radius": subject.radius, "y_range": _rounded(ends[:, 1]),
                 "ends": _rounded(ends)}
    else:
        shape = {"kind": "mesh", "path": SUBJECT_MESH}
    shape["spec"] = result.spec
    kind = "v" if space.mirrors == 2 else "arc"
    tilt, angle, reach, shift = result.hand_made
    return {
        "version": PLAN_VERSION,
        "camera": {**result.camera.to_json(), "tilt_deg": round(result.tilt, 3)},
        "level_from_camera": _rounded(R.T, 6),
        "up": _rounded(R @ [0.0, -1.0, 0.0], 6),
        "mirrors": mirrors,
        "subject": shape,
        "room": space.room.to_json(),
        "predicted": predicted(result.coverage),
        "hand_made": {"kind": kind, "tilt_deg": round(tilt, 3), "angle_deg": round(angle, 3),
                      "reach": round(reach, 4), "shift": round(shift, 4),
                      "predicted": predicted(result.hand_made_coverage)},
        "search": {"mirrors": space.mirrors, "mirror_size": list(space.size),
                   "bounces": result.bounces, "distance": round(float(subject.centre[2]), 4),
                   **result.settings.to_json()},
    }


def plan_scene(result: PlanResult, mesh_path: str = SUBJECT_MESH) -> Scene:
    """The plan's simulated scene, in the final camera's frame, without a room.

    Each mirror carries six markers near its corners and edges; a person or a mesh subject is
    the mesh file `mesh_path` (`subject_mesh`; relative: beside the scene file).
    """
    R = tilt_rotation(result.tilt)
    glass, subject = result.glass, result.space.subject
    mirrors = tuple(
        SceneMirror(f"mirror {j + 1}", tuple((R @ glass.centre[j]).tolist()),
                    tuple((R @ glass.normal[j]).tolist()), tuple((R @ glass.up[j]).tolist()),
                    float(2 * glass.half[j, 0]), float(2 * glass.half[j, 1]),
                    corner_markers(2 * glass.half[j, 0], 2 * glass.half[j, 1]))
        for j in range(len(glass)))
    centre = tuple((R @ subject.centre).tolist())
    if subject.kind == "sphere":
        obj = SceneObject("sphere", centre, radius=subject.radius)
    elif subject.kind == "cylinder":
        obj = SceneObject("cylinder", centre, radius=subject.radius, height=subject.height,
                          axis=tuple((R @ [0.0, 1.0, 0.0]).tolist()))
    else:
        bounds = subject.mesh.vertices @ R.T
        middle = (bounds.min(axis=0) + bounds.max(axis=0)) / 2
        obj = SceneObject("mesh", tuple(middle.tolist()), path=mesh_path)
    return Scene(result.camera.intrinsics, mirrors, (obj,), room=None)


def subject_mesh(result: PlanResult) -> bytes:
    """The subject's mesh in the final camera's frame, as a binary PLY file's bytes."""
    mesh = result.space.subject.mesh.copy()
    mesh.apply_transform(np.block([[tilt_rotation(result.tilt), np.zeros((3, 1))],
                                   [np.zeros((1, 3)), np.ones((1, 1))]]))
    return mesh.export(file_type="ply")


def write_plan(result: PlanResult, folder: str | Path) -> list[Path]:
    """Write plan.json, scene.json and (for a person or a mesh) the subject's mesh, each
    atomically, into an existing folder.

    Parameters
    ----------
    result : PlanResult
    folder : str or Path

    Returns
    -------
    list of Path
        The files written.
    """
    folder = Path(folder)
    written = []
    if result.space.subject.kind not in ("sphere", "cylinder"):
        write_atomic(folder / SUBJECT_MESH, subject_mesh(result))
        written.append(folder / SUBJECT_MESH)
    data = (json.dumps(plan_json(result), indent=2) + "\n").encode("utf-8")
    write_atomic(folder / PLAN_FILE, data)
    save_scene(plan_scene(result), folder / SCENE_FILE)
    return written + [folder / PLAN_FILE, folder / SCENE_FILE]
