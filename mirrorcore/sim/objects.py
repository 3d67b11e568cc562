"""Triangle meshes (camera frame, metres) of the simulated objects: sphere, cylinder, box, mesh
files, and a human-like figure built from capsules that walks in place (a person on a treadmill)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from mirrorcore.base.errors import FileFormatError
from mirrorcore.sim.scene import SceneObject

# icosphere of 5120 faces: its faces lie within 0.12 mm of a 0.115 m sphere
SPHERE_SUBDIVISIONS = 4
CYLINDER_SECTIONS = 128     # faces within 0.05 mm of a 0.15 m cylinder


@dataclass(frozen=True)
class StaticMesh:
    """A mesh that does not move.

    Attributes
    ----------
    vertices : (n, 3) float32 array
        Metres, camera frame.
    faces : (m, 3) uint32 array
    """

    vertices: np.ndarray
    faces: np.ndarray
    animated = False

    @classmethod
    def from_trimesh(cls, mesh: trimesh.Trimesh) -> "StaticMesh":
        """Copy a trimesh's vertices and faces.

        Parameters
        ----------
        mesh : trimesh.Trimesh
            Metres, camera frame.

        Returns
        -------
        StaticMesh
        """
        return cls(np.ascontiguousarray(mesh.vertices, dtype=np.float32),
                   np.ascontiguousarray(mesh.faces, dtype=np.uint32))

    def mesh_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Return the mesh at a time (always the same).

        Parameters
        ----------
        t : float
            Seconds.

        Returns
        -------
        vertices : (n, 3) float32 array
        faces : (m, 3) uint32 array
        """
        return self.vertices, self.faces


# Figure of a 1.75 m person in its own frame: y down, origin on the floor between the feet, facing
# -z (the camera). Limbs: (name, parent joint or None for the pelvis, attachment (x, y) from the
# pelvis, length, radius), metres.
_PELVIS_Y = -0.95
_LIMBS = (
    ("thigh_l", None, (-0.09, 0.03), 0.43, 0.07), ("shin_l", "thigh_l", None, 0.43, 0.05),
    ("thigh_r", None, (0.09, 0.03), 0.43, 0.07), ("shin_r", "thigh_r", None, 0.43, 0.05),
    ("upper_arm_l", None, (-0.21, -0.46), 0.30, 0.05),
    ("forearm_l", "upper_arm_l", None, 0.28, 0.04),
    ("upper_arm_r", None, (0.21, -0.46), 0.30, 0.05),
    ("forearm_r", "upper_arm_r", None, 0.28, 0.04),
)
_FOOT = (0.09, 0.06, 0.24)   # box edges x, y, z; its top at the ankle, reaching forwards
_HIP_SWING, _KNEE_BEND, _ARM_SWING, _ELBOW = np.radians([25.0, 55.0, 0.7 * 25.0, 20.0])


def _x_rotation(angle: np.ndarray) -> np.ndarray:
    """(k,) radians -> (k, 3, 3) rotations about x that swing +y (down) towards -z (forwards) by
    `angle`."""
    c, s = np.cos(angle), np.sin(angle)
    R = np.zeros((len(angle), 3, 3))
    R[:, 0, 0] = 1.0
    R[:, 1, 1], R[:, 1, 2], R[:, 2, 1], R[:, 2, 2] = c, s, -s, c
    return R


class WalkingFigure:
    """A human-like figure of capsules (torso, head, arms, legs) and box feet, walking in place.

    At `gait_hz` strides per second: hips swing +-25 deg, the swinging leg's knee bends, arms swing
    opposite; the lower foot stays on the floor. The figure faces the camera.

    Parameters
    ----------
    obj : SceneObject
        `obj.centre` is the point on the floor between its feet, `obj.height` its height.
    """

    def __init__(self, obj: SceneObject):
        self.scale = obj.height / 1.75
        self.centre = np.asarray(obj.centre, dtype=np.float64)
        self.gait_hz = obj.gait_hz
        self.animated = obj.animated
        limbs = [trimesh.creation.capsule(height=length, radius=r, count=[10, 10]).apply_transform(
            trimesh.transformations.rotation_matrix(-np.pi / 2,
                                                    [1, 0,
                                                     0])).apply_translation([0, length / 2, 0])
            for _, _, _, length, r in _LIMBS]
        feet = [trimesh.creation.box(_FOOT).apply_translation([0, _FOOT[1] / 2, -_FOOT[2] / 4])] * 2
        body = trimesh.util.concatenate([
            trimesh.creation.capsule(height=0.40, radius=0.15,
                                     count=[12, 12]).apply_scale([1.0, 0.6, 1.0])
            .apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
            .apply_translation([0, _PELVIS_Y - 0.24, 0]),
            trimesh.creation.capsule(height=0.10, radius=0.05, count=[8, 8])
            .apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
            .apply_translation([0, _PELVIS_Y - 0.55, 0]),
            trimesh.creation.icosphere(2, 0.11).apply_translation([0, _PELVIS_Y - 0.70, 0])])
        parts = [body, *limbs, *feet]
        self._local = [np.asarray(p.vertices, dtype=np.float64) for p in parts]
        offsets = np.cumsum([0] + [len(v) for v in self._local[:-1]])
        self.faces = np.concatenate([p.faces + o for p, o in zip(parts, offsets)]).astype(np.uint32)

    def _joint_poses(self, phase: float) -> tuple[np.ndarray, np.ndarray]:
        """Limb rotations (8, 3, 3) and limb start points (8, 3), figure frame before lifting the
        feet to the floor."""
        swing = np.sin(phase)
        flex = {"thigh_l": _HIP_SWING * swing, "thigh_r": -_HIP_SWING * swing,
                "upper_arm_l": -_ARM_SWING * swing, "upper_arm_r": _ARM_SWING * swing}
        # the knee of the leg swinging forwards bends; elbows bend a little more as the arm swings
        # forwards
        flex["shin_l"] = flex["thigh_l"] - _KNEE_BEND * max(0.0, np.cos(phase))
        flex["shin_r"] = flex["thigh_r"] - _KNEE_BEND * max(0.0, -np.cos(phase))
        flex["forearm_l"] = flex["upper_arm_l"] + _ELBOW + max(0.0, flex["upper_arm_l"])
        flex["forearm_r"] = flex["upper_arm_r"] + _ELBOW + max(0.0, flex["upper_arm_r"])
        R = _x_rotation(np.array([flex[name] for name, *_ in _LIMBS]))
        starts, ends = {}, {}
        for k, (name, parent, attach, length, _) in enumerate(_LIMBS):
            starts[name] = np.array([attach[0], _PELVIS_Y + attach[1],
                                     0.0]) if parent is None else ends[parent]
            ends[name] = starts[name] + R[k] @ np.array([0.0, length, 0.0])
        return R, np.array([starts[name] for name, *_ in _LIMBS])

    def mesh_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Return the posed mesh at a time.

        Parameters
        ----------
        t : float
            Seconds.

        Returns
        -------
        vertices : (n, 3) float32 array
            Metres, camera frame.
        faces : (m, 3) uint32 array
        """
        R, starts = self._joint_poses(2 * np.pi * self.gait_hz * t)
        ankles = starts[[1, 3]] + R[[1, 3]] @ np.array([0.0, _LIMBS[1][3], 0.0])
        # the lower foot's sole on the floor (y = 0)
        lift = -(ankles[:, 1].max() + _FOOT[1])
        parts = [self._local[0]]
        parts += [v @ R[k].T + starts[k] for k, v in enumerate(self._local[1:1 + len(_LIMBS)])]
        parts += [v + a for v, a in zip(self._local[1 + len(_LIMBS):], ankles)]
        vertices = np.concatenate(parts)
        vertices[:, 1] += lift
        return (vertices * self.scale + self.centre).astype(np.float32), self.faces


def object_geometry(obj: SceneObject) -> StaticMesh | WalkingFigure:
    """Return the mesh source of one scene object.

    Parameters
    ----------
    obj : SceneObject

    Returns
    -------
    StaticMesh or WalkingFigure

    Raises
    ------
    FileFormatError
        An unreadable mesh file.
    """
    centre = np.asarray(obj.centre)
    if obj.type == "sphere":
        mesh = trimesh.creation.icosphere(SPHERE_SUBDIVISIONS, obj.radius)
    elif obj.type == "cylinder":
        mesh = trimesh.creation.cylinder(obj.radius, obj.height, sections=CYLINDER_SECTIONS,
                                         transform=trimesh.geometry.align_vectors([
                                             0, 0, 1], obj.axis))
    elif obj.type == "box":
        mesh = trimesh.creation.box(obj.size)
    elif obj.type == "mesh":
        mesh = _load_mesh(obj.path)
        mesh.apply_scale(obj.scale)
        mesh.apply_translation(-mesh.bounds.mean(axis=0))
    else:
        return WalkingFigure(obj)
    return StaticMesh.from_trimesh(mesh.apply_translation(centre))


def _load_mesh(path: str) -> trimesh.Trimesh:
    """Load a mesh file with trimesh; FileFormatError if unreadable or without triangles."""
    try:
        mesh = trimesh.load(path, force="mesh")
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise FileFormatError(
            f"{path}: not a mesh file trimesh can read ({type(exc).__name__}: {exc})") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise FileFormatError(f"{path}: the file holds no triangles")
    return mesh
