"""The measures a person builds a plan from, in the level frame under the camera.

The level frame has its origin on the floor below the camera: x to the camera's right, `elev` up
from the floor, z forward (the camera's axis laid flat on the floor). Lengths are metres, angles
degrees.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from mirrorcore.base.errors import FileFormatError
from mirrorcore.plan.planread import Plan

# below this, two mirrors' top-view lines are parallel: no apex to mark
MIN_APEX_ANGLE = 1.0     # degrees


@dataclass(frozen=True)
class Level:
    """The level frame: its axes in the camera frame and the camera's height.

    Attributes
    ----------
    right, up, forward : (3,) float64
        Unit vectors in the camera frame.
    height : float
        The camera's height above the floor, metres.
    """

    right: np.ndarray
    up: np.ndarray
    forward: np.ndarray
    height: float

    @classmethod
    def of(cls, plan: Plan) -> "Level":
        """The level frame of a plan (its floor plane)."""
        up = np.asarray(plan.floor.normal, np.float64)
        axis = np.array([0.0, 0.0, 1.0])
        forward = axis - (axis @ up) * up
        forward /= np.linalg.norm(forward)
        return cls(np.cross(-up, forward), up, forward, float(plan.floor.d))

    def points(self, points: np.ndarray) -> np.ndarray:
        """(n, 3) camera-frame points as (n, 3) [x, elev, z] level coordinates, metres."""
        points = np.asarray(points, np.float64).reshape(-1, 3)
        return np.stack([points @ self.right, points @ self.up + self.height,
                         points @ self.forward], axis=1)

    @property
    def tilt(self) -> float:
        """Degrees the camera's axis points below the horizontal (negative: above)."""
        return float(np.degrees(np.arcsin(np.clip(-self.up[2], -1, 1))))

    @property
    def roll(self) -> float:
        """Degrees the camera's x axis rises to the right (negative: falls)."""
        return float(np.degrees(np.arcsin(np.clip(self.up[0], -1, 1))))


@dataclass(frozen=True)
class MirrorMeasure:
    """One mirror's measures.

    Attributes
    ----------
    name : str
    corners : (4, 3) float64
        [x, elev, z] metres, in the plan's order.
    width, height : float
        Metres: the mean length of the near-horizontal edges and of the others.
    bottom, top : float
        Metres above the floor of its lowest and highest corner.
    centre : (3,) float64
        [x, elev, z] metres.
    normal : (3,) float64
        Unit [x, elev, z] normal of its face, towards the camera.
    sides : (2, 2) float64
        [x, z] of the middle of its two side edges (its ends in the top view), metres.
    to_axis : float
        Degrees between its face and the camera's axis in the top view (0 to 90).
    lean : float
        Degrees its face leans from the vertical: above 0 its top leans back (away from the
        camera), below 0 forward.
    centre_distance : float
        Metres from the camera to its centre, along the floor.
    edge_distance : float
        Metres from the camera to its nearer side edge, along the floor.
    """

    name: str
    corners: np.ndarray
    width: float
    height: float
    bottom: float
    top: float
    centre: np.ndarray
    normal: np.ndarray
    sides: np.ndarray
    to_axis: float
    lean: float
    centre_distance: float
    edge_distance: float


@dataclass(frozen=True)
class PairMeasure:
    """Two neighbouring mirrors (next to each other seen from the camera).

    Attributes
    ----------
    first, second : int
        Indices into the plan's mirrors.
    angle : float
        Degrees between their faces, on the camera's side.
    gap : float
        Metres between their nearest side edges, in the top view.
    apex : (2,) float64 or None
        [x, z] where their top-view lines meet, None when they are nearly parallel.
    """

    first: int
    second: int
    angle: float
    gap: float
    apex: np.ndarray | None


def mirror_measure(name: str, corners: np.ndarray, level: Level) -> MirrorMeasure:
    """Measure one mirror of four camera-frame corners (4, 3), metres."""
    c = level.points(corners)
    edges = np.roll(c, -1, axis=0) - c
    lengths = np.linalg.norm(edges, axis=1)
    rise = np.abs(edges[:, 1]) / lengths
    # edges 0 and 2 face each other, as do 1 and 3: the pair that rises more is the height
    upright = 0 if rise[0] + rise[2] > rise[1] + rise[3] else 1
    width = float(lengths[[1 - upright, 3 - upright]].mean())
    height = float(lengths[[upright, upright + 2]].mean())
    sides = np.array([(c[k] + c[(k + 1) % 4])[[0, 2]] / 2 for k in (upright, upright + 2)])
    centre = c.mean(axis=0)
    n = np.cross(edges[0], edges[1])
    n /= np.linalg.norm(n)
    if n @ (np.array([0.0, level.height, 0.0]) - centre) < 0:
        n = -n
    flat = n[[0, 2]]
    flat_norm = np.linalg.norm(flat)
    # the face's direction in the top view is perpendicular to its flat normal (a mirror lying
    # flat has none: 0)
    to_axis = 0.0 if flat_norm < 1e-9 else 90.0 - float(
        np.degrees(np.arccos(np.clip(abs(flat[1]) / flat_norm, 0, 1))))
    # a face turned up to the camera leans back
    lean = float(np.degrees(np.arcsin(np.clip(n[1], -1, 1))))
    return MirrorMeasure(name, c, width, height, float(c[:, 1].min()), float(c[:, 1].max()),
                         centre, n, sides, to_axis, lean, float(np.hypot(centre[0], centre[2])),
                         float(np.linalg.norm(sides, axis=1).min()))


def pair_measure(i: int, j: int, a: MirrorMeasure, b: MirrorMeasure) -> PairMeasure:
    """Measure two neighbouring mirrors a (index i) and b (index j)."""
    cos = float(np.clip(a.normal @ b.normal, -1, 1))
    angle = 180.0 - float(np.degrees(np.arccos(cos)))
    gap = float(min(np.linalg.norm(p - q) for p in a.sides for q in b.sides))
    da, db = a.sides[1] - a.sides[0], b.sides[1] - b.sides[0]
    cross = da[0] * db[1] - da[1] * db[0]
    apex = None
    if abs(cross) > np.sin(np.radians(MIN_APEX_ANGLE)) * np.linalg.norm(da) * np.linalg.norm(db):
        t = ((b.sides[0] - a.sides[0])[0] * db[1] - (b.sides[0] - a.sides[0])[1] * db[0]) / cross
        apex = a.sides[0] + t * da
    return PairMeasure(i, j, angle, gap, apex)


@dataclass(frozen=True)
class Measures:
    """Everything the drawing and the report state about a plan.

    Attributes
    ----------
    level : Level
    mirrors : tuple of MirrorMeasure
    pairs : tuple of PairMeasure
        Mirrors next to each other, left to right as the camera sees them.
    subject_points : (n, 3) float64
        [x, elev, z] of points outlining the subject (a mesh's vertices, a sphere's or a
        cylinder's rims), metres.
    """

    level: Level
    mirrors: tuple[MirrorMeasure, ...]
    pairs: tuple[PairMeasure, ...]
    subject_points: np.ndarray


def measure(plan: Plan) -> Measures:
    """Measure a plan.

    Parameters
    ----------
    plan : Plan

    Returns
    -------
    Measures

    Raises
    ------
    FileFormatError
        The subject's mesh file is unreadable.
    """
    level = Level.of(plan)
    mirrors = tuple(mirror_measure(m.name, m.corners, level) for m in plan.mirrors)
    order = sorted(range(len(mirrors)),
                   key=lambda k: np.arctan2(mirrors[k].centre[0], mirrors[k].centre[2]))
    pairs = tuple(pair_measure(i, j, mirrors[i], mirrors[j]) for i, j in zip(order, order[1:]))
    return Measures(level, mirrors, pairs, level.points(subject_outline(plan)))


def subject_outline(plan: Plan) -> np.ndarray:
    """(n, 3) camera-frame points outlining the plan's subject, metres."""
    s = plan.subject
    if s.kind == "mesh":
        try:
            mesh = trimesh.load(s.path, force="mesh")
        except Exception as exc:  # trimesh raises many types for unreadable files
            raise FileFormatError(f"{s.path}: not a mesh file trimesh can read "
                                  f"({type(exc).__name__}: {exc})") from None
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.vertices) == 0:
            raise FileFormatError(f"{s.path}: the file holds no triangles")
        return np.asarray(mesh.vertices, np.float64)
    if s.kind == "cylinder":
        turn = np.linspace(0, 2 * np.pi, 72, endpoint=False)
        ends = s.ends or [(s.axis_xz[0], y, s.axis_xz[1]) for y in s.y_range]
        axis = np.subtract(ends[1], ends[0])
        axis /= np.linalg.norm(axis)
        # the rims: circles about the axis
        u = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 0.0, 1.0])
        u /= np.linalg.norm(u)
        rim = s.radius * (np.outer(np.cos(turn), u) + np.outer(np.sin(turn), np.cross(axis, u)))
        return np.concatenate([rim + e for e in ends])
    # a Fibonacci lattice: its outline from any side is the sphere's to within 1 %
    k = np.arange(800) + 0.5
    y = 1 - 2 * k / len(k)
    turn = np.pi * (3 - np.sqrt(5)) * k
    r = np.sqrt(1 - y * y)
    unit = np.stack([r * np.cos(turn), y, r * np.sin(turn)], axis=1)
    return unit * s.radius + np.asarray(s.center)
