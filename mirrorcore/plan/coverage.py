"""What a rig sees of a subject: per view (direct, through each mirror, through several in turn),
which of the subject's surface samples it sees and at what depth (docs/planning.md, "Coverage").

A surface point counts as seen by a view when it faces that view's (virtual) camera within
MAX_INCIDENCE_DEG of incidence, the ray leaves the real camera inside the image and within the
sensor's depth range (the depth of the virtual point: the path through the mirrors along the
camera's axis), meets each mirror inside its outline, and nothing (the subject, another mirror,
a mirror's back) lies on the ray's path from the camera to the point. Shares are of the surface
area. Everything is in the level frame (mirrorcore.plan.subject); the camera is tilted by `tilt`.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from itertools import product

import numpy as np
import open3d as o3d

from mirrorcore.base.palette import sequence_label, source_name
from mirrorcore.plan.setup import PlanCamera
from mirrorcore.plan.subject import Samples, Subject
from mirrorcore.sim.sensor import SensorModel

MAX_INCIDENCE_DEG = 70.0
_COS_INCIDENCE = np.cos(np.radians(MAX_INCIDENCE_DEG))
# metres: a path's segments are tested for obstacles this far from their ends
_END = 1e-4
AXIAL_K = SensorModel.kinect_v1().axial_k


@dataclass(frozen=True)
class Glass:
    """The mirrors of a layout: rectangles, level frame.

    Attributes
    ----------
    centre, right, up, normal : (m, 3) float64 arrays
        Metres; unit axes, `normal` the reflective side's.
    half : (m, 2) float64 array
        Half the width (along right) and height (along up), metres.
    """

    centre: np.ndarray
    right: np.ndarray
    up: np.ndarray
    normal: np.ndarray
    half: np.ndarray

    def __len__(self) -> int:
        return len(self.centre)

    def corners(self) -> np.ndarray:
        """(m, 4, 3) corners in order around each rectangle, metres."""
        signs = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=np.float64)
        s = signs[None] * self.half[:, None]
        return (self.centre[:, None] + s[..., :1] * self.right[:, None]
                + s[..., 1:] * self.up[:, None])

    def reflect(self, j: int, points: np.ndarray) -> np.ndarray:
        """Reflect points (k, 3) through mirror j's plane."""
        n = self.normal[j]
        return points - 2 * ((points - self.centre[j]) @ n)[:, None] * n


def glass_from(centre, normal, up, width, height) -> Glass:
    """Make Glass from per-mirror centres, normals, up hints and sizes.

    Parameters
    ----------
    centre, normal, up : (m, 3) arrays
        Metres; `normal` towards the reflective side; `up` made orthogonal to it.
    width, height : (m,) arrays
        Metres.

    Returns
    -------
    Glass
    """
    n = np.asarray(normal, np.float64).reshape(-1, 3)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    up = np.asarray(up, np.float64).reshape(-1, 3)
    up = up - (up * n).sum(axis=1, keepdims=True) * n
    up /= np.linalg.norm(up, axis=1, keepdims=True)
    half = np.stack([np.asarray(width, np.float64), np.asarray(height, np.float64)], axis=1) / 2
    return Glass(np.asarray(centre, np.float64).reshape(-1, 3), np.cross(up, n), up, n,
                 half.reshape(-1, 2))


def tilt_rotation(tilt_deg: float) -> np.ndarray:
    """(3, 3) rotation from the level frame to the camera tilted down by `tilt_deg` (about x)."""
    t = np.radians(tilt_deg)
    return np.array([[1.0, 0.0, 0.0], [0.0, np.cos(t), -np.sin(t)], [0.0, np.sin(t), np.cos(t)]])


def view_sequences(mirrors: int, bounces: int) -> tuple[tuple[int, ...], ...]:
    """Every view: () direct, then the 0-based mirror sequences of 1..bounces mirrors (no mirror
    twice in a row), shortest first."""
    views: list[tuple[int, ...]] = [()]
    for k in range(1, bounces + 1):
        views += [s for s in product(range(mirrors), repeat=k)
                  if all(a != b for a, b in zip(s, s[1:]))]
    return tuple(views)


def view_name(sequence: tuple[int, ...]) -> str:
    """'direct', 'mirror 1', 'mirror 1 then 2', ... for a 0-based sequence."""
    label = sequence_label(tuple(j + 1 for j in sequence)) if sequence else 0
    return source_name(label) if label is not None else " then ".join(
        f"mirror {j + 1}" for j in sequence)


@dataclass(frozen=True, eq=False)
class Coverage:
    """Which samples each view sees, and at what depth.

    Attributes
    ----------
    views : tuple of tuple of int
        0-based mirror sequences, () the direct view.
    seen : (v, n) bool array
    depth : (v, n) float32 array
        Metres: the depth the camera reads (z of the virtual point), 0 where not seen.
    weight : (n,) float64 array
        Each sample's share of the surface area.
    """

    views: tuple[tuple[int, ...], ...]
    seen: np.ndarray
    depth: np.ndarray
    weight: np.ndarray

    @cached_property
    def counts(self) -> np.ndarray:
        """(n,) int: how many views see each sample."""
        return self.seen.sum(axis=0)

    @property
    def coverage(self) -> float:
        """The share of the surface area seen by at least one view."""
        return float(self.weight[self.counts >= 1].sum())

    @property
    def coverage_2(self) -> float:
        """The share of the surface area seen by two or more views."""
        return float(self.weight[self.counts >= 2].sum())

    @property
    def per_view(self) -> np.ndarray:
        """(v,) the share of the surface area each view sees."""
        return self.seen.astype(np.float64) @ self.weight

    def noise_mm(self, axial_k: float = AXIAL_K) -> np.ndarray:
        """(v,) the area-weighted mean axial noise (axial_k * Z^2) over what each view sees, mm;
        NaN for a view that sees nothing."""
        w = self.seen * self.weight
        total = w.sum(axis=1)
        sigma = axial_k * self.depth.astype(np.float64) ** 2 * 1e3
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(total > 0, (w * sigma).sum(axis=1) / total, np.nan)

    def mean_noise_mm(self, axial_k: float = AXIAL_K) -> float:
        """The area-weighted mean axial noise over every (sample, view) seen, mm (0 if none)."""
        w = self.seen * self.weight
        if w.sum() == 0:
            return 0.0
        return float((w * axial_k * self.depth.astype(np.float64) ** 2).sum() / w.sum() * 1e3)


class CoverageModel:
    """Coverage of one subject's samples by layouts of mirrors (see the module docstring).

    Parameters
    ----------
    subject : Subject
    samples : Samples
    camera : PlanCamera
    bounces : int
        The most mirrors a view goes through in turn.
    """

    def __init__(self, subject: Subject, samples: Samples, camera: PlanCamera, bounces: int = 1):
        self.subject, self.samples, self.camera, self.bounces = subject, samples, camera, bounces
        self._scene = o3d.t.geometry.RaycastingScene()
        self._scene.add_triangles(o3d.core.Tensor(subject.mesh.vertices.astype(np.float32)),
                                  o3d.core.Tensor(subject.mesh.faces.astype(np.uint32)))
        # the direct view's paths never change: what the subject hides of them, once
        self._direct_clear = self._subject_clear(np.zeros_like(samples.points), samples.points)

    def evaluate(self, glass: Glass, tilt_deg: float = 0.0) -> Coverage:
        """Which samples each view of the layout sees.

        Parameters
        ----------
        glass : Glass
            The mirrors, level frame.
        tilt_deg : float
            The camera's tilt down, degrees.

        Returns
        -------
        Coverage
        """
        views = view_sequences(len(glass), self.bounces)
        n = len(self.samples)
        seen = np.zeros((len(views), n), bool)
        depth = np.zeros((len(views), n), np.float32)
        R = tilt_rotation(tilt_deg)
        paths = [self._path(glass, view, R) for view in views]
        segments = [s for _, _, segs in paths[1:] for s in segs]
        if segments:
            clear = self._subject_clear(np.concatenate([s[0] for s in segments]),
                                        np.concatenate([s[1] for s in segments]))
        at = 0
        for v, (idx, z, segs) in enumerate(paths):
            ok = self._direct_clear[idx] if v == 0 else np.ones(len(idx), bool)
            for start, end in segs:
                if v:
                    ok &= clear[at:at + len(idx)]
                    at += len(idx)
                ok &= _glass_clear(start, end, glass)
            seen[v, idx[ok]] = True
            depth[v, idx[ok]] = z[ok]
        return Coverage(views, seen, depth, self.samples.weight)

    def _path(self, glass: Glass, view: tuple[int, ...], R: np.ndarray):
        """The samples that pass the tests of a view but the obstacles: their indices (k,), depths
        (k,) and the path's segments [(start (k, 3), end (k, 3))], camera first."""
        X, N = self.samples.points, self.samples.normals
        V, NV = X, N
        for j in reversed(view):
            V = glass.reflect(j, V)
            NV = NV - 2 * (NV @ glass.normal[j])[:, None] * glass.normal[j]
        dist = np.linalg.norm(V, axis=1)
        ok = -(NV * V).sum(axis=1) >= _COS_INCIDENCE * dist
        Vc = V @ R.T
        z = Vc[:, 2]
        cam = self.camera
        ok &= (z >= cam.min_depth) & (z <= cam.max_depth)
        intr = cam.intrinsics
        with np.errstate(divide="ignore", invalid="ignore"):
            u = intr.fx * Vc[:, 0] / z + intr.cx
            v = intr.fy * Vc[:, 1] / z + intr.cy
        ok &= (u >= -0.5) & (u < intr.width - 0.5) & (v >= -0.5) & (v < intr.height - 0.5)
        idx = np.flatnonzero(ok)
        d = V[idx] / dist[idx, None]
        o = np.zeros_like(d)
        travelled = np.zeros(len(idx))
        keep = np.ones(len(idx), bool)
        starts = [o]
        for j in view:
            n = glass.normal[j]
            denom = d @ n
            with np.errstate(divide="ignore", invalid="ignore"):
                t = ((glass.centre[j] - o) @ n) / denom
            keep &= (denom < 0) & (t > _END)
            t = np.where(keep, t, 0.0)
            p = o + t[:, None] * d
            local = p - glass.centre[j]
            keep &= (np.abs(local @ glass.right[j]) <= glass.half[j, 0]) & (
                np.abs(local @ glass.up[j]) <= glass.half[j, 1])
            travelled += t
            o = p
            d = d - 2 * (d @ n)[:, None] * n
            starts.append(o)
        keep &= travelled < dist[idx] - _END
        idx, starts = idx[keep], [s[keep] for s in starts]
        ends = starts[1:] + [X[idx]]
        return idx, z[idx], list(zip(starts, ends))

    def _subject_clear(self, start: np.ndarray, end: np.ndarray) -> np.ndarray:
        """(k,) bool: nothing of the subject lies on the segments start -> end (k, 3), their ends
        excepted."""
        seg = end - start
        length = np.linalg.norm(seg, axis=1)
        d = seg / np.maximum(length, 1e-12)[:, None]
        # cast back from the far end, which may lie on the subject's surface
        rays = np.concatenate([end - _END * d, -d], axis=1).astype(np.float32)
        t_hit = self._scene.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy()
        return t_hit >= length - 2 * _END


def _glass_clear(start: np.ndarray, end: np.ndarray, glass: Glass) -> np.ndarray:
    """(k,) bool: no mirror (front or back) lies on the segments start -> end (k, 3), their ends
    excepted."""
    seg = end - start
    length = np.linalg.norm(seg, axis=1)
    d = seg / np.maximum(length, 1e-12)[:, None]
    clear = np.ones(len(start), bool)
    for j in range(len(glass)):
        n = glass.normal[j]
        denom = d @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((glass.centre[j] - start) @ n) / denom
        hit = (t > _END) & (t < length - _END)
        p = start + np.where(hit, t, 0.0)[:, None] * d - glass.centre[j]
        hit &= (np.abs(p @ glass.right[j]) <= glass.half[j, 0]) & (
            np.abs(p @ glass.up[j]) <= glass.half[j, 1])
        clear &= ~hit
    return clear
