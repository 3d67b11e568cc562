"""Paths of the camera's rays through several mirrors in turn (the kaleidoscope), traced once per
rig, and the virtual cameras they make.

A pixel's ray first meets the mirror Algorithm 1 gives it (the first calibrated mirror whose
boundary holds it) at the depth where it crosses that plane. Reflected there, it may meet another
mirror: where its reflected ray crosses a mirror's plane from the front at a point that the camera
sees inside that mirror's boundary (the boundary polygon lifted onto its plane), and so on. A depth
camera measures along the unfolded ray, so each mirror met is a depth threshold along the pixel's
own ray: a point measured beyond the k-th threshold came back through k mirrors, and its real place
is X = M_k (... M_2 (M_1 (V))), V the measured (virtual) point, M_i the reflection through the i-th
mirror met. Seen the other way, the pixels of a sequence form a virtual camera whose extrinsic is
M_1 M_2 ... M_k.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.base.palette import MAX_MIRRORS, sequence_label, source_name, source_sequence

# metres: a reflected ray meets a mirror at least this far along (never the mirror it left)
MIN_PATH = 1e-6


@dataclass(frozen=True, eq=False)
class Chains:
    """The c pixels whose ray, after its first mirror, meets another one, sorted by pixel.

    For a rig followed up to K reflections. Depths are z in metres along the pixel's own (unfolded)
    ray. Row k of the per-level arrays is about the (k + 2)-th mirror the rays meet (level-major, so
    that a frame reads each level contiguously).

    Attributes
    ----------
    pixel : (c,) int64 array
        Flat index v * W + u.
    threshold : (K - 1, c) float32 array
        Metres, where the ray meets its 2nd, 3rd, ... mirror (inf: it meets no more, or the encoding
        has no label for the sequence; see cutoff).
    label : (K - 1, c) uint8 array
        The source label of a point beyond that threshold (palette.sequence_label).
    normal : (K - 1, c, 3) float32 array
        That mirror's plane normal n.
    offset : (K - 1, c) float32 array
        That mirror's plane offset d, metres.
    cutoff : (c,) float32 array
        Metres; beyond this depth a point came through more mirrors than are followed (or a sequence
        that no label names): its place is not known and it is left out; inf when it never is.
    """

    pixel: np.ndarray
    threshold: np.ndarray
    label: np.ndarray
    normal: np.ndarray
    offset: np.ndarray
    cutoff: np.ndarray

    def __len__(self) -> int:
        return len(self.pixel)


def trace_chains(intr: Intrinsics, planes: tuple[Plane | None, ...], inside_bits: np.ndarray,
                 first: np.ndarray,
                 threshold: np.ndarray, bounces: int) -> Chains:
    """Follow every pixel's ray past its first mirror (see the module docstring).

    Parameters
    ----------
    intr : Intrinsics
        The camera.
    planes : tuple of Plane or None
        Each mirror's plane in session order (None: uncalibrated, never met).
    inside_bits : (H, W) uint32 array
        Bit j - 1 set inside mirror j's boundary.
    first : (H, W) uint8 array
        The first mirror (1-based, 0 none), as ReflectionTable holds it.
    threshold : (H, W) float32 array
        Metres, the depth where the ray meets the first mirror (inf: never).
    bounces : int
        The most reflections in all.

    Returns
    -------
    Chains
    """
    pixel = np.flatnonzero(np.isfinite(threshold))
    levels = bounces - 1
    chains = Chains(pixel, np.full((levels, len(pixel)), np.inf, np.float32),
                    np.zeros((levels, len(pixel)), np.uint8),
                    np.zeros((levels, len(pixel), 3), np.float32),
                    np.zeros((levels, len(pixel)), np.float32),
                    np.full(len(pixel), np.inf, np.float32))
    # the rays still followed: rows of `chains`
    rows = np.arange(len(pixel))
    z = threshold.reshape(-1)[pixel].astype(np.float64)
    rays = np.stack([intr.rays[0].reshape(-1)[pixel], intr.rays[1].reshape(-1)[pixel],
                     np.ones(len(pixel))], axis=1)
    # where each ray meets its first mirror
    point = rays * z[:, None]
    # 1-based: the mirror each ray last met
    mirror = first.reshape(-1)[pixel].astype(np.int64)
    direction, label = _reflect_directions(rays, planes, mirror), mirror
    for level in range(bounces):
        t, nxt = _next_mirror(intr, planes, inside_bits, point, direction, mirror)
        met = np.flatnonzero(nxt > 0)
        rows, z, t, nxt = rows[met], z[met] + t[met], t[met], nxt[met]
        point, direction = point[met], direction[met]
        label = _NEXT_LABEL[label[met], nxt] if level < levels else np.zeros(len(met), np.int64)
        # one mirror more than followed, or no label for it
        chains.cutoff[rows[label == 0]] = z[label == 0]
        named = np.flatnonzero(label)
        rows, z, t, nxt, point, direction, label = (a[named]
                                                    for a in (rows, z, t, nxt, point, direction,
                                                                       label))
        if not len(rows):
            break
        _record(chains, level, rows, z, label, nxt, planes)
        point = point + t[:, None] * direction
        direction, mirror = _reflect_directions(direction, planes, nxt), nxt
    keep = np.isfinite(chains.cutoff) | np.isfinite(chains.threshold).any(axis=0)
    return Chains(chains.pixel[keep], *(np.ascontiguousarray(a[:, keep]) for a in
                                        (chains.threshold, chains.label, chains.normal,
                                         chains.offset)),
                  chains.cutoff[keep])


def _record(chains: Chains, level: int, rows: np.ndarray, z: np.ndarray, label: np.ndarray,
            mirror: np.ndarray,
            planes: tuple[Plane | None, ...]) -> None:
    """Write, for rows `rows` of `chains`, the depth z where the ray meets its (level + 2)-th mirror
    `mirror` (1-based), that mirror's plane and the label of the sequence so far."""
    chains.threshold[level, rows] = z
    chains.label[level, rows] = label
    for j in np.unique(mirror):
        chains.normal[level, rows[mirror == j]] = planes[j - 1].n
        chains.offset[level, rows[mirror == j]] = planes[j - 1].d


def _reflect_directions(directions: np.ndarray, planes: tuple[Plane | None, ...],
                        mirror: np.ndarray) -> np.ndarray:
    """(n, 3) directions reflected off mirror[i] (1-based; 0 leaves the row as it is) -> (n, 3)
    float64."""
    out = np.array(directions, np.float64)
    for j in np.unique(mirror[mirror > 0]):
        rows = mirror == j
        n = planes[j - 1].n
        out[rows] -= 2 * (out[rows] @ n)[:, None] * n
    return out


def _next_mirror(intr: Intrinsics, planes: tuple[Plane | None, ...], inside_bits: np.ndarray,
                 point: np.ndarray,
                 direction: np.ndarray, mirror: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For rays point + t * direction ((n, 3) float64 each) that left mirror `mirror` (n,) 1-based:
    the nearest mirror met from the front inside its boundary as the camera sees it -> t (n,)
    float64 (inf: none) and that mirror (n,) int64, 1-based, 0 for none."""
    best_t = np.full(len(point), np.inf)
    best = np.zeros(len(point), np.int64)
    for j, plane in enumerate(planes, start=1):
        if plane is None:
            continue
        towards = direction @ plane.n
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -(point @ plane.n + plane.d) / towards
        rows = np.flatnonzero((mirror != j) & (towards < 0) & (t > MIN_PATH) & (t < best_t))
        hit = point[rows] + t[rows, None] * direction[rows]
        seen = _in_boundary(intr, inside_bits, hit, j)
        best_t[rows[seen]] = t[rows[seen]]
        best[rows[seen]] = j
    return best_t, best


def _in_boundary(intr: Intrinsics, inside_bits: np.ndarray, points: np.ndarray,
                 j: int) -> np.ndarray:
    """(n, 3) points (camera frame, metres) -> (n,) bool: the camera sees them inside mirror j's
    boundary (their nearest pixel is in its rasterised polygon)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.rint(intr.fx * points[:, 0] / points[:, 2] + intr.cx)
        v = np.rint(intr.fy * points[:, 1] / points[:, 2] + intr.cy)
        ok = (points[:, 2] > 0) & (u >= 0) & (u < intr.width) & (v >= 0) & (v < intr.height)
    bits = inside_bits[v[ok].astype(np.int64), u[ok].astype(np.int64)]
    ok[ok] = ((bits >> np.uint32(j - 1)) & np.uint32(1)).astype(bool)
    return ok


def _next_labels() -> np.ndarray:
    """(256, MAX_MIRRORS + 1) int64: the label of a label's sequence followed by mirror j, 0 where
    none names it."""
    table = np.zeros((256, MAX_MIRRORS + 1), np.int64)
    for label in range(1, 255):
        try:
            sequence = source_sequence(label)
        except ValueError:
            continue
        for j in range(1, MAX_MIRRORS + 1):
            table[label, j] = sequence_label(sequence + (j,)) or 0
    return table


_NEXT_LABEL = _next_labels()


def sequence_reflection(planes: tuple[Plane | None, ...], sequence: tuple[int, ...]) -> np.ndarray:
    """Return M_1 M_2 ... M_k for mirrors `sequence`.

    It maps camera-frame real points to the virtual points the camera measures through them.

    Parameters
    ----------
    planes : tuple of Plane or None
        Each mirror's plane in session order.
    sequence : tuple of int
        1-based mirrors, ray order.

    Returns
    -------
    (4, 4) float64 array
        det (-1)^k; the identity for ().
    """
    matrix = np.eye(4)
    for j in sequence:
        matrix = matrix @ planes[j - 1].reflection_matrix()
    return matrix


@dataclass(frozen=True, eq=False)
class VirtualCamera:
    """One view of the rig: the camera itself (source 0) or the camera seen through mirrors in turn.

    Attributes
    ----------
    source : int
        Its label (palette).
    name : str
        palette.source_name.
    sequence : tuple of int
        The mirrors (1-based, session order) its rays meet, in order.
    to_view : (4, 4) float64 array
        Camera-frame points -> the points this view measures (M_1 M_2 ... M_k, det (-1)^k).
    pose : (4, 4) float64 array
        Proper rigid pose (camera frame <- virtual camera frame): the inverse of to_view with its x
        axis flipped back after an odd number of mirrors (an image seen through a mirror is flipped
        left-right), as Plane.virtual_camera_pose.
    pixels : int
        How many pixels of the image see through it.
    """

    source: int
    name: str
    sequence: tuple[int, ...]
    to_view: np.ndarray
    pose: np.ndarray
    pixels: int

    @classmethod
    def of(cls, planes: tuple[Plane | None, ...], sequence: tuple[int, ...],
           pixels: int) -> "VirtualCamera":
        """Build the view through mirrors `sequence`.

        Parameters
        ----------
        planes : tuple of Plane or None
            Each mirror's plane in session order.
        sequence : tuple of int
            1-based mirrors, ray order.
        pixels : int
            How many pixels see through it.

        Returns
        -------
        VirtualCamera
        """
        to_view = sequence_reflection(planes, sequence)
        pose = np.linalg.inv(to_view)
        if len(sequence) % 2:
            pose[:3, 0] = -pose[:3, 0]
        label = sequence_label(sequence)
        return cls(label, source_name(label), tuple(sequence), to_view, pose, int(pixels))
