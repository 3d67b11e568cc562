"""Ray casting of a simulated scene with Open3D's RaycastingScene: rays reflect off the mirrors (up to two bounces) and
each pixel gets the depth of the VIRTUAL point along its unfolded ray, plus per-pixel ground truth.

A structured-light camera sees through a mirror at the depth of the virtual image: the reported depth of a pixel is
z of (camera origin + ray direction * total path length). Markers are matte squares on the glass; a mirror's back is
matte too. Static geometry is merged into one RaycastingScene built once; an animated object rebuilds it per frame
(a few thousand triangles, about a millisecond: cheaper than casting every ray into a second scene).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import open3d as o3d

from ..camera import Intrinsics
from ..plane import Plane
from .objects import object_geometry
from .scene import Scene

# Ground-truth surface codes: what the (last) ray segment of a pixel hit.
NONE, ROOM, OBJECT, MARKER, MIRROR_BACK = 0, 1, 2, 3, 4
SURFACE_NAMES = ("none", "room", "object", "marker", "mirror back")
_MIRROR = 5                   # geometry kind of a mirror's glass (never a final surface code)
_REFLECT_OFFSET = 1e-5        # metres: a reflected ray starts this far along its new direction (no self-hit)
MARKER_LIFT = 1e-4            # metres: markers are modelled this far in front of the glass (0.1 mm)


@dataclass(frozen=True)
class GroundTruth:
    """What the ideal camera sees, per pixel (H, W):

    depth : float32 metres, z of the unfolded (virtual) point, 0 where no surface (surface == NONE)
    surface : uint8 code NONE / ROOM / OBJECT / MARKER / MIRROR_BACK of the real surface hit
    first_mirror, second_mirror : uint8 the mirror j (1-based) of the first / second reflection, 0 = none
    object_index : int16 index into scene.objects of the object hit, -1 elsewhere
    camera, planes : the intrinsics and the true mirror planes (session order), for `points`
    """

    camera: Intrinsics
    planes: tuple[Plane, ...]
    depth: np.ndarray
    surface: np.ndarray
    first_mirror: np.ndarray
    second_mirror: np.ndarray
    object_index: np.ndarray

    @property
    def bounces(self) -> np.ndarray:
        """(H, W) uint8 number of reflections: 0, 1 or 2."""
        return (self.first_mirror > 0).astype(np.uint8) + (self.second_mirror > 0)

    @property
    def object_mask(self) -> np.ndarray:
        """(H, W) bool: the pixel shows an object (directly or through mirrors)."""
        return self.surface == OBJECT

    @property
    def source(self) -> np.ndarray:
        """(H, W) int8 in DESIGN.md's convention: 0 = direct, j = through mirror j (one bounce); -1 = two bounces or
        no surface."""
        src = self.first_mirror.astype(np.int8)
        src[(self.second_mirror > 0) | (self.surface == NONE)] = -1
        return src

    @cached_property
    def points(self) -> np.ndarray:
        """(H, W, 3) float32 metres, camera frame: the REAL surface point hit, NaN where no surface. The virtual point
        depth * ray is folded back through the first mirror's plane, then the second's (X = M2(M1(V)))."""
        rays = self.camera.rays
        pts = np.stack([rays[0] * self.depth, rays[1] * self.depth, self.depth], axis=-1)
        for labels in (self.first_mirror, self.second_mirror):
            for j, plane in enumerate(self.planes, start=1):
                sel = labels == j
                pts[sel] = plane.reflect(pts[sel])
        pts[self.surface == NONE] = np.nan
        return pts


def _quads(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """corners : (q, 4, 3) quads, corners in order around -> vertices (4q, 3) float32 and faces (2q, 3) uint32."""
    base = 4 * np.arange(len(corners), dtype=np.uint32)[:, None, None]
    faces = (base + np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32)).reshape(-1, 3)
    return np.ascontiguousarray(corners.reshape(-1, 3), dtype=np.float32), faces


def _static_meshes(scene: Scene) -> tuple[list, list, list]:
    """(vertices, faces) of the room's planes, of each mirror's glass and of each mirror's markers (matte squares
    MARKER_LIFT in front of the glass)."""
    room = []
    if scene.room is not None:
        r = scene.room
        x, y, z, top = r.half_width, r.floor_y, r.back_z, r.floor_y - 3.0
        room = [_quads(np.array([[[-x, y, -1.0], [x, y, -1.0], [x, y, z], [-x, y, z]]])),
                _quads(np.array([[[-x, top, z], [x, top, z], [x, y, z], [-x, y, z]]]))]
    glass = [_quads(m.corners()[None]) for m in scene.mirrors]
    markers = []
    for m in scene.mirrors:
        h = m.marker_size / 2
        square = np.array([[-h, -h], [h, -h], [h, h], [-h, h]])
        corners = m.local_to_camera((np.asarray(m.markers).reshape(-1, 1, 2) + square).reshape(-1, 2))
        markers.append(_quads((corners + MARKER_LIFT * np.asarray(m.normal)).reshape(-1, 4, 3)))
    return room, glass, markers


class Renderer:
    """Ideal ray-cast rendering of a Scene: `render(t)` -> GroundTruth.

    two_bounces : render rays that reflect off a second mirror (as a real rig shows them); when False such rays
    (and any ray that would need a third reflection) read no surface.
    """

    def __init__(self, scene: Scene, two_bounces: bool = True):
        self.scene = scene
        self.max_bounces = 2 if two_bounces else 1
        room, glass, markers = _static_meshes(scene)
        self._static = room + glass + markers
        self._objects = [object_geometry(o) for o in scene.objects]
        m = len(scene.mirrors)
        # geometry id -> kind and index (mirror 0-based / object index); the last entry is for misses
        self._kind = np.array([ROOM] * len(room) + [_MIRROR] * m + [MARKER] * m + [OBJECT] * len(self._objects)
                              + [NONE], dtype=np.uint8)
        self._index = np.array([-1] * len(room) + [*range(m)] * 2 + [*range(len(self._objects))] + [-1],
                               dtype=np.int16)
        self._normals = np.array([mm.normal for mm in scene.mirrors], dtype=np.float32).reshape(-1, 3)
        self._planes = tuple(mm.plane for mm in scene.mirrors)
        self._cache: dict[bool, o3d.t.geometry.RaycastingScene] = {}
        xy = scene.camera.rays.reshape(2, -1)                    # (x/z, y/z) per pixel, row-major
        rays = np.stack([xy[0], xy[1], np.ones_like(xy[0])], axis=1)
        self._dirs = rays / np.linalg.norm(rays, axis=1, keepdims=True)   # (H*W, 3) float32 unit camera rays
        self._camera_rays = o3d.core.Tensor(np.concatenate([np.zeros_like(self._dirs), self._dirs], axis=1))

    @property
    def animated(self) -> bool:
        return any(g.animated for g in self._objects)

    def _raycasting_scene(self, t: float, with_objects: bool) -> o3d.t.geometry.RaycastingScene:
        """The scene at time t; cached unless an object moves."""
        cached = self._cache.get(with_objects)
        if cached is not None and not (with_objects and self.animated):
            return cached
        rc = o3d.t.geometry.RaycastingScene()
        meshes = self._static + ([g.mesh_at(t) for g in self._objects] if with_objects else [])
        for vertices, faces in meshes:
            rc.add_triangles(o3d.core.Tensor(vertices), o3d.core.Tensor(faces))
        self._cache[with_objects] = rc
        return rc

    def _cast(self, rc, rays: o3d.core.Tensor, dirs: np.ndarray, can_reflect: bool):
        """Cast (k, 6) rays -> path length t (k,) float32 (0 where nothing is seen), kind (k,) uint8 (_MIRROR where
        the ray reflects on) and index (k,) int16 (mirror 0-based or object index)."""
        ans = rc.cast_rays(rays)
        t = ans["t_hit"].numpy()
        gid = np.minimum(ans["geometry_ids"].numpy(), len(self._kind) - 1)   # misses (INVALID_ID) -> last entry
        kind, index = self._kind[gid], self._index[gid]
        glass = np.flatnonzero(kind == _MIRROR)
        facing = np.einsum("ij,ij->i", dirs[glass], self._normals[index[glass]]) < 0
        kind[glass[~facing]] = MIRROR_BACK
        if not can_reflect:
            kind[glass[facing]] = NONE          # glass reached with the bounce budget spent: no reading
        t[kind == NONE] = 0
        return t, kind, index

    def _reflected(self, origins, dirs, t, mirror) -> tuple[np.ndarray, np.ndarray]:
        """Rays (k, 3) that hit mirrors `mirror` (k,) 0-based after t (k,) -> the reflected rays' origins, dirs."""
        n = self._normals[mirror]
        hit = origins + t[:, None] * dirs
        new = dirs - 2 * np.einsum("ij,ij->i", dirs, n)[:, None] * n
        return hit + _REFLECT_OFFSET * new, new

    def render(self, t: float = 0.0, with_objects: bool = True) -> GroundTruth:
        """The ideal view at time t seconds (objects left out when `with_objects` is False: the background)."""
        rc = self._raycasting_scene(t, with_objects)
        length, surface, index = self._cast(rc, self._camera_rays, self._dirs, True)
        first = np.where(surface == _MIRROR, index + 1, 0).astype(np.uint8)
        second = np.zeros_like(first)
        obj = np.where(surface == OBJECT, index, -1).astype(np.int16)
        idx = np.flatnonzero(surface == _MIRROR)
        origins, dirs = self._reflected(np.zeros((len(idx), 3), np.float32), self._dirs[idx], length[idx],
                                        index[idx])
        for bounce in range(1, self.max_bounces + 1):
            if len(idx) == 0:
                break
            t_seg, kind, index = self._cast(rc, o3d.core.Tensor(np.concatenate([origins, dirs], axis=1)), dirs,
                                            bounce < self.max_bounces)
            length[idx] += t_seg + _REFLECT_OFFSET
            surface[idx] = kind
            hit_obj = kind == OBJECT
            obj[idx[hit_obj]] = index[hit_obj]
            go = np.flatnonzero(kind == _MIRROR)
            second[idx[go]] = index[go] + 1
            origins, dirs = self._reflected(origins[go], dirs[go], t_seg[go], index[go])
            idx = idx[go]
        depth = np.where(surface != NONE, length * self._dirs[:, 2], 0).astype(np.float32)
        shape = self.scene.camera.shape
        return GroundTruth(self.scene.camera, self._planes, depth.reshape(shape), surface.reshape(shape),
                           first.reshape(shape), second.reshape(shape), obj.reshape(shape))
