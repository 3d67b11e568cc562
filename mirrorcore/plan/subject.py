"""The subject a plan is made for: a SPEC (sphere:R, cylinder:R,H, person:HEIGHT, mesh:PATH) to a
triangle mesh standing on the floor in the level frame, and its surface sampled by area.

The level frame is the camera's frame before its tilt: metres, x right, y down, z forward, origin
at the camera, the floor the plane y = camera height.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import open3d as o3d
import trimesh

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.sim.objects import WalkingFigure, object_geometry
from mirrorcore.sim.scene import SceneObject

SPEC_HELP = "sphere:R, cylinder:R,H, person:HEIGHT or mesh:PATH (metres)"
SPHERE_SUBDIVISIONS = 4
CYLINDER_SECTIONS = 96


@dataclass(frozen=True)
class Subject:
    """A subject's mesh in the level frame and what a plan file says of it.

    Attributes
    ----------
    kind : str
        'sphere', 'cylinder', 'person' or 'mesh'.
    mesh : trimesh.Trimesh
        Metres, level frame.
    radius : float
        Metres: a sphere's or cylinder's radius, else the horizontal reach of the mesh from
        `centre`.
    centre : (3,) float64 array
        Metres, level frame: the middle of its bounding box.
    height : float
        Metres: a cylinder's length, a person's height, else the bounding box's height.
    path : str or None
        The mesh file of a `mesh:PATH` subject.
    """

    kind: str
    mesh: trimesh.Trimesh
    radius: float
    centre: np.ndarray
    height: float
    path: str | None = None

    @property
    def y_range(self) -> tuple[float, float]:
        """(top, bottom) y of the mesh, metres (y down)."""
        return float(self.mesh.bounds[0, 1]), float(self.mesh.bounds[1, 1])


def parse_spec(spec: str) -> tuple[str, tuple[float, ...] | str]:
    """Split a subject SPEC into its kind and its numbers (or a mesh's path).

    Parameters
    ----------
    spec : str
        sphere:R, cylinder:R,H, person:HEIGHT or mesh:PATH.

    Returns
    -------
    kind : str
    values : tuple of float, or str
        Metres; the path for a mesh.

    Raises
    ------
    MirrorscanError
        An unknown kind, a wrong count of numbers, a number not positive.
    """
    kind, _, rest = spec.partition(":")
    counts = {"sphere": 1, "cylinder": 2, "person": 1}
    if kind == "mesh" and rest:
        return kind, rest
    if kind not in counts or not rest:
        raise MirrorscanError(f"--subject: {spec!r} is not a subject; use {SPEC_HELP}")
    try:
        values = tuple(float(v) for v in rest.split(","))
    except ValueError:
        raise MirrorscanError(
            f"--subject: {spec!r}: the sizes must be numbers, in metres") from None
    if len(values) != counts[kind] or not all(np.isfinite(v) and 0 < v <= 10 for v in values):
        raise MirrorscanError(
            f"--subject: {spec!r}: {kind} takes {counts[kind]} size(s) of 0 to 10 metres")
    return kind, values


def make_subject(spec: str, distance: float, floor_y: float) -> Subject:
    """Build a subject standing on the floor, its middle `distance` metres ahead of the camera.

    A sphere rests on the floor unless it would stand taller than the camera, then its centre is
    level with the camera; a cylinder and a person stand on the floor; a mesh is moved so that
    its lowest point is on the floor and its bounding box's middle on the optical axis.

    Parameters
    ----------
    spec : str
        As `parse_spec`.
    distance : float
        Metres from the camera to the subject's middle along z.
    floor_y : float
        Metres: the camera's height above the floor.

    Returns
    -------
    Subject

    Raises
    ------
    MirrorscanError
        A bad SPEC or an unreadable mesh file.
    """
    kind, values = parse_spec(spec)
    if kind == "sphere":
        r = values[0]
        y = floor_y - r if 2 * r < floor_y else 0.0
        mesh = trimesh.creation.icosphere(SPHERE_SUBDIVISIONS, r)
        mesh.apply_translation([0.0, y, distance])
        return Subject(kind, mesh, r, np.array([0.0, y, distance]), 2 * r)
    if kind == "cylinder":
        r, h = values
        mesh = trimesh.creation.cylinder(r, h, sections=CYLINDER_SECTIONS,
                                         transform=trimesh.geometry.align_vectors(
                                             [0, 0, 1], [0, 1, 0]))
        mesh.apply_translation([0.0, floor_y - h / 2, distance])
        return Subject(kind, mesh, r, np.array([0.0, floor_y - h / 2, distance]), h)
    if kind == "person":
        figure = WalkingFigure(SceneObject("figure", (0.0, floor_y, distance), height=values[0]))
        vertices, faces = figure.mesh_at(0.0)
        mesh = trimesh.Trimesh(np.asarray(vertices, np.float64), faces, process=False)
        return _bounded(kind, mesh, values[0], None, distance)
    loaded = object_geometry(SceneObject("mesh", (0.0, 0.0, 0.0), path=values))
    mesh = trimesh.Trimesh(np.asarray(loaded.vertices, np.float64), loaded.faces, process=False)
    mesh.apply_translation([0.0, floor_y - mesh.bounds[1, 1], distance])
    return _bounded(kind, mesh, float(np.ptp(mesh.vertices[:, 1])), values, distance)


def _bounded(kind: str, mesh: trimesh.Trimesh, height: float, path: str | None,
             distance: float) -> Subject:
    """A Subject of a mesh whose centre is its bounding box's middle."""
    centre = mesh.bounds.mean(axis=0)
    centre[[0, 2]] = 0.0, distance
    reach = np.sqrt(((mesh.vertices[:, [0, 2]] - centre[[0, 2]]) ** 2).sum(axis=1)).max()
    return Subject(kind, mesh, float(reach), centre, height, path)


@dataclass(frozen=True)
class Samples:
    """Points spread over a subject's surface by area.

    Attributes
    ----------
    points : (n, 3) float64 array
        Metres, level frame.
    normals : (n, 3) float64 array
        Unit outward normals.
    weight : (n,) float64 array
        Each point's share of the surface area (they sum to 1).
    """

    points: np.ndarray
    normals: np.ndarray
    weight: np.ndarray

    def __len__(self) -> int:
        return len(self.points)


def sample_surface(subject: Subject, count: int, seed: int = 0) -> Samples:
    """Sample a subject's outer surface by area.

    The surface is the mesh's faces less the parts inside another of its closed components (a
    person's limbs enter its torso): points inside another component are dropped and the rest
    share the area equally.

    Parameters
    ----------
    subject : Subject
    count : int
        Points drawn (fewer are kept where components overlap).
    seed : int

    Returns
    -------
    Samples
    """
    mesh = subject.mesh
    rng = np.random.default_rng(seed)
    area = mesh.area_faces
    face = rng.choice(len(area), size=count, p=area / area.sum())
    ab = rng.random((count, 2))
    flip = ab.sum(axis=1) > 1
    ab[flip] = 1 - ab[flip]
    tri = mesh.triangles[face]
    points = tri[:, 0] + ab[:, :1] * (tri[:, 1] - tri[:, 0]) + ab[:, 1:] * (tri[:, 2] - tri[:, 0])
    normals = mesh.face_normals[face]
    keep = ~_inside_other_part(mesh, face, points)
    n = int(keep.sum())
    return Samples(points[keep], normals[keep], np.full(n, 1.0 / n))


def _inside_other_part(mesh: trimesh.Trimesh, face: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(n,) bool: the point (on face `face`) lies inside a closed component other than its own."""
    labels = trimesh.graph.connected_component_labels(mesh.face_adjacency, len(mesh.faces))
    parts = np.unique(labels)
    inside = np.zeros(len(points), bool)
    if len(parts) < 2:
        return inside
    query = o3d.core.Tensor(points.astype(np.float32))
    for part in parts:
        faces = mesh.faces[labels == part]
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(o3d.core.Tensor(mesh.vertices.astype(np.float32)),
                            o3d.core.Tensor(faces.astype(np.uint32)))
        occupied = scene.compute_occupancy(query).numpy() > 0.5
        inside |= occupied & (labels[face] != part)
    return inside
