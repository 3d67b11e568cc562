"""Ray casting of a simulated scene with Open3D's RaycastingScene: rays reflect off the mirrors (up
to three bounces) and each pixel gets the depth of the VIRTUAL point along its unfolded ray, plus
per-pixel ground truth (the full sequence of mirrors its ray met).

A structured-light camera sees through a mirror at the depth of the virtual image: the reported
depth of a pixel is z of (camera origin + ray direction * total path length). Markers are matte
squares in front of the reflecting surface (by each mirror's marker_lift); a mirror's back is matte
too.

The camera's rays and the static geometry (room, glass, markers) never change, so every pixel's path
through the static geometry (up to four segments) is traced once, when the Renderer is made: that is
the background. A frame casts only into a scene of the objects, and only the segments that can reach
one: the pixels inside the projected bounding box of an object's image through the mirrors the
segment has reflected off (a conservative window). A segment that meets an object before its static
surface ends there; the result is the same as casting every ray into one scene of everything.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import open3d as o3d

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics, project_points
from mirrorcore.geometry.plane import Plane
from mirrorcore.base.palette import MAX_ORDER, sequence_label
from mirrorcore.sim.objects import object_geometry
from mirrorcore.sim.scene import Scene

# Ground-truth surface codes: what the (last) ray segment of a pixel hit.
NONE, ROOM, OBJECT, MARKER, MIRROR_BACK = 0, 1, 2, 3, 4
SURFACE_NAMES = ("none", "room", "object", "marker", "mirror back")
_MIRROR = 5                   # geometry kind of a mirror's glass (never a final surface code)
# metres: a reflected ray starts this far along its new direction (no self-hit)
_REFLECT_OFFSET = 1e-5
# the most reflections a rendered ray may make (the source labels name up to this many)
MAX_BOUNCES = MAX_ORDER


@dataclass(frozen=True)
class GroundTruth:
    """What the ideal camera sees, per pixel.

    Attributes
    ----------
    camera : Intrinsics
        The intrinsics, for `points`.
    planes : tuple of Plane
        The true mirror planes (session order), for `points`.
    depth : (H, W) float32 array
        Metres, z of the unfolded (virtual) point, 0 where no surface (surface == NONE).
    surface : (H, W) uint8 array
        Code NONE / ROOM / OBJECT / MARKER / MIRROR_BACK of the real surface hit.
    mirrors : (MAX_BOUNCES, H, W) uint8 array
        The full sequence of mirrors the pixel's ray met: mirrors[k] is the mirror j (1-based) of
        its (k+1)-th reflection, 0 once it made no more.
    object_index : (H, W) int16 array
        Index into scene.objects of the object hit, -1 elsewhere.
    """

    camera: Intrinsics
    planes: tuple[Plane, ...]
    depth: np.ndarray
    surface: np.ndarray
    mirrors: np.ndarray
    object_index: np.ndarray

    @property
    def first_mirror(self) -> np.ndarray:
        """(H, W) uint8 the mirror of the first reflection, 0 = none."""
        return self.mirrors[0]

    @property
    def second_mirror(self) -> np.ndarray:
        """(H, W) uint8 the mirror of the second reflection, 0 = none."""
        return self.mirrors[1]

    @property
    def bounces(self) -> np.ndarray:
        """(H, W) uint8 number of reflections, 0 to MAX_BOUNCES."""
        return np.count_nonzero(self.mirrors, axis=0).astype(np.uint8)

    @property
    def object_mask(self) -> np.ndarray:
        """(H, W) bool: the pixel shows an object (directly or through mirrors)."""
        return self.surface == OBJECT

    @property
    def source(self) -> np.ndarray:
        """(H, W) int16 source labels (docs/DESIGN.md, mirrorcore.base.palette).

        0 = direct, j = through mirror j, the label of the sequence for several mirrors; -1 where no
        surface (or a sequence the labels do not cover).
        """
        keys, inverse = np.unique(self.mirrors.reshape(len(self.mirrors), -1), axis=1,
                                  return_inverse=True)
        labels = np.array([_label(tuple(int(j) for j in key if j)) for key in keys.T], np.int16)
        src = labels[inverse.reshape(-1)].reshape(self.depth.shape)
        src[self.surface == NONE] = -1
        return src

    @cached_property
    def points(self) -> np.ndarray:
        """(H, W, 3) float32 metres, camera frame: the REAL surface point hit, NaN where no surface.

        The virtual point depth * ray is folded back through the first mirror's plane, then the
        second's... (X = M3(M2(M1(V)))).
        """
        rays = self.camera.rays
        pts = np.stack([rays[0] * self.depth, rays[1] * self.depth, self.depth], axis=-1)
        self._fold(pts, self.mirrors)
        pts[self.surface == NONE] = np.nan
        return pts

    def points_at(self, pixels: np.ndarray) -> np.ndarray:
        """(k, 3) float32 metres, camera frame: the real surface points of `pixels` (k,) int flat
        (row-major) indices, each with a surface; `points` there within float32 rounding,
        without folding the whole image."""
        depth = self.depth.reshape(-1)[pixels]
        rays = self.camera.rays.reshape(2, -1)[:, pixels]
        pts = np.stack([rays[0] * depth, rays[1] * depth, depth], axis=-1)
        self._fold(pts, self.mirrors.reshape(len(self.mirrors), -1)[:, pixels])
        return pts

    def _fold(self, pts: np.ndarray, mirrors: np.ndarray) -> None:
        """Fold virtual points (..., 3) in place through the mirrors (MAX_BOUNCES, ...) of their
        rays, first reflection first."""
        for labels in mirrors:
            if not labels.any():
                break
            for j, plane in enumerate(self.planes, start=1):
                sel = labels == j
                pts[sel] = plane.reflect(pts[sel])


def _label(sequence: tuple[int, ...]) -> int:
    """The source label of a sequence of mirrors (1-based), -1 when the labels do not cover it."""
    label = sequence_label(sequence)
    return -1 if label is None else label


def _quads(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """corners : (q, 4, 3) quads, corners in order around -> vertices (4q, 3) float32 and faces (2q,
    3) uint32."""
    base = 4 * np.arange(len(corners), dtype=np.uint32)[:, None, None]
    faces = (base + np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32)).reshape(-1, 3)
    return np.ascontiguousarray(corners.reshape(-1, 3), dtype=np.float32), faces


def _static_meshes(scene: Scene) -> tuple[list, list, list]:
    """(vertices, faces) of the room's planes, of each mirror's reflecting surface and of each
    mirror's markers (matte squares marker_lift in front of the reflecting surface)."""
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
        corners = m.local_to_camera((np.asarray(m.markers).reshape(-1, 1, 2) + square).reshape(-1,
                                                                                               2))
        markers.append(_quads((corners + m.marker_lift * np.asarray(m.normal)).reshape(-1, 4, 3)))
    return room, glass, markers


def _raycasting_scene(meshes: list[tuple[np.ndarray,
                                         np.ndarray]]) -> o3d.t.geometry.RaycastingScene:
    """A RaycastingScene of meshes (vertices (n, 3) float32, faces (m, 3) uint32); geometry id i =
    meshes[i]."""
    rc = o3d.t.geometry.RaycastingScene()
    for vertices, faces in meshes:
        rc.add_triangles(o3d.core.Tensor(vertices), o3d.core.Tensor(faces))
    return rc


def _box_corners(vertices: np.ndarray) -> np.ndarray:
    """vertices : (n, 3) -> (8, 3) float64 corners of their axis-aligned bounding box."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    return np.stack(np.meshgrid(*zip(lo, hi), indexing="ij"), axis=-1).reshape(-1,
                                                                               3).astype(np.float64)


def _pixel_window(camera: Intrinsics, points: np.ndarray) -> tuple[slice, slice] | None:
    """The image window (rows, columns) holding every pixel whose ray passes through the convex hull
    of `points` (k, 3) metres, camera frame: the bounding rectangle of their projections widened by
    a pixel; the whole image when a point is not in front of the camera; None when the rectangle
    lies outside the image."""
    uv, z = project_points(camera, points)
    if np.any(z <= 0):
        return slice(None), slice(None)
    lo = np.maximum(np.floor(uv.min(axis=0)).astype(int) - 1, 0)
    hi = np.minimum(np.ceil(uv.max(axis=0)).astype(int) + 2, [camera.width, camera.height])
    if np.any(lo >= hi):
        return None
    return slice(lo[1], hi[1]), slice(lo[0], hi[0])


@dataclass(frozen=True)
class _Segment:
    """Segment s of the static paths (s = 0: from the camera; s: after s reflections), for the k
    pixels whose path reaches it.

    pixels : (k,) int64 flat (row-major) pixel indices. rays : (k, 6) float32 origin and unit
    direction, metres,
    camera frame. start : (k,) float32 path length at the origin, metres. t_hit : (k,) float32
    distance along the ray
    to the static surface the segment ends on, inf for none. mirror_paths : per path, the 0-based
    mirrors the ray reflected off before the segment, in the order it met them (one empty path for s
    = 0). path : (H, W) int16 index
    into mirror_paths, row : (H, W) int32 the pixel's index into pixels; both -1 where the pixel's
    path does not reach segment s.
    """

    pixels: np.ndarray
    rays: np.ndarray
    start: np.ndarray
    t_hit: np.ndarray
    mirror_paths: tuple[tuple[int, ...], ...]
    path: np.ndarray
    row: np.ndarray


class Renderer:
    """Ideal ray-cast rendering of a Scene: `render(t)` -> GroundTruth.

    Parameters
    ----------
    scene : Scene
    bounces : int
        The most reflections a ray may make, 1 to MAX_BOUNCES (a real rig shows them all); a ray
        that meets one more mirror reads no surface.

    Raises
    ------
    MirrorscanError
        `bounces` out of range.
    """

    def __init__(self, scene: Scene, bounces: int = MAX_BOUNCES):
        if not 1 <= bounces <= MAX_BOUNCES:
            raise MirrorscanError(f"--bounces: the simulator renders 1 to {MAX_BOUNCES} "
                                  f"reflections, got {bounces}")
        self.scene = scene
        self.max_bounces = int(bounces)
        room, glass, markers = _static_meshes(scene)
        m = len(scene.mirrors)
        # static geometry id -> kind and mirror index (0-based); the last entry is for misses
        self._kind = np.array([ROOM] * len(room) + [_MIRROR] * m + [MARKER] * m + [NONE],
                              dtype=np.uint8)
        self._index = np.array([-1] * len(room) + [*range(m)] * 2 + [-1], dtype=np.int16)
        self._normals = np.array([mm.normal for mm in scene.mirrors],
                                 dtype=np.float32).reshape(-1, 3)
        self._planes = tuple(mm.plane for mm in scene.mirrors)
        self._objects = [object_geometry(o) for o in scene.objects]
        self._still_objects: tuple[o3d.t.geometry.RaycastingScene, list[np.ndarray]] | None = None
        xy = scene.camera.rays.reshape(2, -1)                    # (x/z, y/z) per pixel, row-major
        rays = np.stack([xy[0], xy[1], np.ones_like(xy[0])], axis=1)
        # (H*W, 3) float32 unit camera rays
        self._dirs = rays / np.linalg.norm(rays, axis=1, keepdims=True)
        # (H*W,) their z: depth per path length
        self._dirs_z = np.ascontiguousarray(self._dirs[:, 2])
        static = _raycasting_scene(room + glass + markers)
        self._background, self._segments = self._trace_static(static)

    @property
    def animated(self) -> bool:
        """True when an object moves."""
        return any(g.animated for g in self._objects)

    def _reflected(self, origins, dirs, t, mirror) -> tuple[np.ndarray, np.ndarray]:
        """Rays (k, 3) that hit mirrors `mirror` (k,) 0-based after t (k,) -> the reflected rays'
        origins, dirs."""
        n = self._normals[mirror]
        hit = origins + t[:, None] * dirs
        new = dirs - 2 * np.einsum("ij,ij->i", dirs, n)[:, None] * n
        return hit + _REFLECT_OFFSET * new, new

    def _trace_static(self, rc: o3d.t.geometry.RaycastingScene) -> tuple[tuple[np.ndarray, ...],
                                                                         list[_Segment]]:
        """Every pixel's path through the static geometry `rc` -> the background, flat arrays (depth
        (H*W,) float32 metres, surface (H*W,) uint8, mirrors (MAX_BOUNCES, H*W) uint8), and the
        segments of the paths."""
        shape, m = self.scene.camera.shape, len(self._planes)
        n = shape[0] * shape[1]
        length, surface = np.zeros(n, np.float32), np.zeros(n, np.uint8)
        labels = np.zeros((MAX_BOUNCES, n), np.uint8)
        pixels, start = np.arange(n), np.zeros(n, np.float32)
        origins, dirs = np.zeros_like(self._dirs), self._dirs
        mirror_paths, path = ((),), np.zeros(n, np.int64)
        segments = []
        for bounce in range(self.max_bounces + 1):
            rays = np.concatenate([origins, dirs], axis=1)
            ans = rc.cast_rays(o3d.core.Tensor(rays))
            t_hit = ans["t_hit"].numpy()
            # misses (INVALID_ID) -> last entry
            gid = np.minimum(ans["geometry_ids"].numpy(), len(self._kind) - 1)
            kind, index = self._kind[gid], self._index[gid]
            glass = np.flatnonzero(kind == _MIRROR)
            facing = np.einsum("ij,ij->i", dirs[glass], self._normals[index[glass]]) < 0
            kind[glass[~facing]] = MIRROR_BACK
            if bounce == self.max_bounces:
                # glass reached with the bounce budget spent: no reading
                kind[glass[facing]] = NONE
            maps = np.full((2, n), -1, np.int32)
            maps[:, pixels] = path, np.arange(len(pixels))
            segments.append(_Segment(pixels, rays, start, t_hit, mirror_paths,
                                     maps[0].astype(np.int16).reshape(shape),
                                     maps[1].reshape(shape)))
            end = np.flatnonzero(kind != _MIRROR)
            surface[pixels[end]] = kind[end]
            length[pixels[end]] = start[end] + t_hit[end]
            go = np.flatnonzero(kind == _MIRROR)
            if len(go) == 0:
                break
            labels[bounce, pixels[go]] = index[go] + 1
            keys, path = np.unique(path[go] * m + index[go], return_inverse=True)
            mirror_paths = tuple(mirror_paths[k // m] + (int(k % m),) for k in keys)
            origins, dirs = self._reflected(origins[go], dirs[go], t_hit[go], index[go])
            start, pixels = start[go] + t_hit[go] + np.float32(_REFLECT_OFFSET), pixels[go]
        depth = np.where(surface != NONE, length * self._dirs_z, 0).astype(np.float32)
        return (depth, surface, labels), segments

    def _object_scene(self, t: float) -> tuple[o3d.t.geometry.RaycastingScene, list[np.ndarray]]:
        """The objects at time t in a RaycastingScene of their own (geometry id = object index) and
        the corners (8, 3) of each one's bounding box; built once unless an object moves."""
        if self._still_objects is not None:
            return self._still_objects
        meshes = [g.mesh_at(t) for g in self._objects]
        built = _raycasting_scene(meshes), [_box_corners(vertices) for vertices, _ in meshes]
        if not self.animated:
            self._still_objects = built
        return built

    def _candidates(self, segment: _Segment, boxes: list[np.ndarray],
                    done: np.ndarray) -> np.ndarray:
        """(c,) int64 indices into `segment` of the rays that may hit an object: the pixels inside
        the window of each box's image through the mirrors of each path, leaving out the pixels
        `done` (d,) int64 (flat indices)."""
        take = np.zeros(len(segment.pixels), bool)
        for p, mirrors in enumerate(segment.mirror_paths):
            for corners in boxes:
                # the virtual image V = M_first(M_second(X))
                for j in reversed(mirrors):
                    corners = self._planes[j].reflect(corners)
                window = _pixel_window(self.scene.camera, corners)
                if window is not None:
                    take[segment.row[window][segment.path[window] == p]] = True
        done_rows = segment.row.reshape(-1)[done]
        take[done_rows[done_rows >= 0]] = False
        return np.flatnonzero(take)

    def render(self, t: float = 0.0, with_objects: bool = True) -> GroundTruth:
        """Return the ideal view at a time.

        Parameters
        ----------
        t : float
            Seconds.
        with_objects : bool
            False leaves the objects out (the background).

        Returns
        -------
        GroundTruth
        """
        depth, surface, mirrors = (a.copy() for a in self._background)
        obj = np.full(len(depth), -1, np.int16)
        if with_objects and self._objects:
            rc, boxes = self._object_scene(t)
            done = np.zeros(0, np.int64)                  # pixels whose path ended on an object
            for bounce, segment in enumerate(self._segments):
                rows = self._candidates(segment, boxes, done)
                if len(rows) == 0:
                    continue
                ans = rc.cast_rays(o3d.core.Tensor(segment.rays[rows]))
                t_obj = ans["t_hit"].numpy()
                hit = np.flatnonzero(t_obj < segment.t_hit[rows])
                rows, pix = rows[hit], segment.pixels[rows[hit]]
                surface[pix] = OBJECT
                obj[pix] = ans["geometry_ids"].numpy()[hit]
                depth[pix] = (segment.start[rows] + t_obj[hit]) * self._dirs_z[pix]
                # reflections the static path made after the object
                mirrors[bounce:, pix] = 0
                done = np.concatenate([done, pix])
        shape = self.scene.camera.shape
        return GroundTruth(self.scene.camera, self._planes, depth.reshape(shape),
                           surface.reshape(shape),
                           mirrors.reshape(MAX_BOUNCES, *shape), obj.reshape(shape))
