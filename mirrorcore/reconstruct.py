"""Algorithm 1 of the paper: the merged, source-labelled cloud of one depth frame (reproject, then reflect the pixels
seen in a mirror through its plane), generalised to pixels seen through several mirrors in turn (mirrorcore.paths)."""
from __future__ import annotations

import numpy as np

from .cloud import Cloud
from .depthops import bounding_window
from .geometry.camera import check_depth_shape
from .paths import Chains
from .rig import Rig


def reconstruct_raw(rig: Rig, depth: np.ndarray, mask: np.ndarray | None = None) -> Cloud:
    """Paper Algorithm 1, vectorised over the pixels with the rig's precomputed ReflectionTable.

    A pixel inside mirror j's boundary whose point lies behind plane j (n.P + d < 0) is reflected through plane j
    (paper eq. 3) and labelled j; mirrors are tried in session order and the first that applies wins (the algorithm's
    `break`). Every other pixel is direct (label 0), including pixels inside a boundary but in front of its mirror
    (the real object, a marker on the glass). Pixels inside the boundary of a mirror with no plane yet are left out
    unless a calibrated mirror reflects them: their true position is unknown.

    Generalised to the kaleidoscope: where the pixel's ray, reflected, meets further mirrors (the rig's
    ReflectionTable.chains), a point beyond the depth where it meets the k-th mirror is reflected through the k-th
    mirror too (the composition of the reflections, X = M_k(...M_1(V))) and labelled with the sequence
    (palette.sequence_label); a point beyond the last mirror followed (rig.bounces) is left out.

    depth : (H, W) float metres, 0 = no reading; mask : optional (H, W) bool, the pixels to use (the object)
    returns the Cloud of the used pixels with a reading, in row-major pixel order.
    """
    intr, table = rig.intrinsics, rig.reflection_table
    depth = check_depth_shape(intr, depth).astype(np.float32, copy=False)
    keep = depth > 0 if mask is None else (mask & (depth > 0))
    win = bounding_window(keep)                 # all the work happens in the kept pixels' bounding box
    z = depth[win]
    behind = z > table.threshold[win]
    # eq. 3 as P_r = P + step * n with step = -2 (n.P + d): zero where the pixel is not reflected
    step = (np.float32(-2) * (z * table.ray_dot[win] + table.offset[win])) * behind
    out = np.empty((*z.shape, 4), dtype=np.float32)   # x, y, z, source per pixel: gathered in one take below
    out[..., 0] = z * intr.rays[0][win] + step * table.normal[0][win]
    out[..., 1] = z * intr.rays[1][win] + step * table.normal[1][win]
    out[..., 2] = z + step * table.normal[2][win]
    out[..., 3] = table.label[win] * behind
    if table.overlap[win].any():
        _later_mirrors(rig, win, out, keep[win] & table.overlap[win] & ~behind)
    if len(table.chains):
        _further_mirrors(table.chains, depth, win, out, keep)
    keep[win] &= ~table.uncalibrated[win] | (out[..., 3] > 0)
    # row-major order inside the window is the image's row-major order: the same ranks index both
    picked = np.take(out.reshape(-1, 4), np.flatnonzero(keep[win]), axis=0)
    return Cloud(picked[:, :3], picked[:, 3].astype(np.uint8), np.flatnonzero(keep), intr.width)


def _later_mirrors(rig: Rig, win: tuple[slice, slice], out: np.ndarray, pending: np.ndarray) -> None:
    """Where boundaries overlap and the first mirror did not apply, try the others in session order (in place).
    win : the window of the image that `out` (h, w, 4) and `pending` (h, w) bool cover."""
    v, u = np.nonzero(pending)
    points = out[v, u, :3].astype(np.float64)
    bits = rig.inside_bits[win][v, u]
    todo = np.ones(len(v), dtype=bool)
    for j, mirror in enumerate(rig.mirrors, start=1):
        if mirror.plane is None:
            continue
        hit = todo & ((bits >> np.uint32(j - 1)) & np.uint32(1)).astype(bool)
        hit &= mirror.plane.signed_distance(points) < 0
        out[v[hit], u[hit], :3] = mirror.plane.reflect(points[hit])
        out[v[hit], u[hit], 3] = j
        todo &= ~hit


def _further_mirrors(chains: Chains, depth: np.ndarray, win: tuple[slice, slice], out: np.ndarray,
                     keep: np.ndarray) -> None:
    """Reflect the kept points of the chains' pixels in the window `win` through the further mirrors their depth is
    beyond, relabel them, and drop those beyond the cutoff (in place). depth : (H, W) float32 metres; out : (h, w, 4)
    the window's points and labels after the first mirror; keep : (H, W) bool."""
    width = depth.shape[1]
    v, u = np.divmod(chains.pixel, width)
    rows = np.flatnonzero((v >= win[0].start) & (v < win[0].stop) & (u >= win[1].start) & (u < win[1].stop))
    rows = rows[keep.reshape(-1)[chains.pixel[rows]]]
    if not len(rows):
        return
    z = depth.reshape(-1)[chains.pixel[rows]]
    wv, wu = v[rows] - win[0].start, u[rows] - win[1].start
    points = out[wv, wu, :3]
    labels = out[wv, wu, 3]
    for level in range(chains.threshold.shape[1]):
        go = np.flatnonzero(z > chains.threshold[rows, level])
        if not len(go):
            break
        n, d = chains.normal[rows[go], level], chains.offset[rows[go], level]
        p = points[go]
        points[go] = p - (np.float32(2) * (np.einsum("ij,ij->i", p, n) + d))[:, None] * n
        labels[go] = chains.label[rows[go], level]
    out[wv, wu, :3] = points
    out[wv, wu, 3] = labels
    keep.reshape(-1)[chains.pixel[rows[z > chains.cutoff[rows]]]] = False
