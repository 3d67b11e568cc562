"""Algorithm 1 of the paper: the merged, source-labelled cloud of one depth frame (reproject, then
reflect the pixels seen in a mirror through its plane), generalised to pixels seen through several
mirrors in turn (mirrorcore.rig.raypaths)."""
from __future__ import annotations

import numpy as np

from mirrorcore.rig.cloud import Cloud
from mirrorcore.rig.colour import check_colour_image, point_colours
from mirrorcore.geometry.camera import Intrinsics, check_depth_shape
from mirrorcore.rig.model import ReflectionTable, Rig


def reconstruct_raw(rig: Rig, depth: np.ndarray, mask: np.ndarray | None = None,
                    colour: np.ndarray | None = None) -> Cloud:
    """Paper Algorithm 1, vectorised over the pixels with the rig's precomputed ReflectionTable.

    A pixel inside mirror j's boundary whose point lies behind plane j (n.P + d < 0) is reflected
    through plane j (paper eq. 3) and labelled j; mirrors are tried in session order and the first
    that applies wins (the algorithm's `break`). Every other pixel is direct (label 0), including
    pixels inside a boundary but in front of its mirror (the real object, a marker on the glass).
    Pixels inside the boundary of a mirror with no plane yet are left out unless a calibrated mirror
    reflects them: their true position is unknown.

    Generalised to the kaleidoscope: where the pixel's ray, reflected, meets further mirrors (the
    rig's ReflectionTable.chains), a point beyond the depth where it meets the k-th mirror is
    reflected through the k-th mirror too (the composition of the reflections, X = M_k(...M_1(V)))
    and labelled with the sequence (palette.sequence_label); a point beyond the last mirror followed
    (rig.bounces) is left out.

    Parameters
    ----------
    rig : Rig
    depth : (H, W) float
        Metres, 0 = no reading.
    mask : (H, W) bool, optional
        The pixels to use (the object).
    colour : (H, W, 3) uint8, optional
        RGB registered to the depth image: each point takes its pixel's colour with its view's
        colour gain undone (Cloud.rgb; mirrorcore.rig.colour).

    Returns
    -------
    Cloud
        The used pixels with a reading, in row-major pixel order.
    """
    intr, table = rig.intrinsics, rig.reflection_table
    depth = check_depth_shape(intr, depth).astype(np.float32, copy=False)
    if mask is not None:
        mask = check_depth_shape(intr, mask, "object mask")
    # the pixels used, in row-major order; every step below reads only them
    index = np.flatnonzero(depth > 0 if mask is None else mask)
    z = np.take(depth.reshape(-1), index)
    if mask is not None and not np.all(z > 0):
        index, z = index[z > 0], z[z > 0]
    behind = z > np.take(table.threshold.reshape(-1), index)
    rows = np.flatnonzero(behind)
    pixel = np.take(index, rows)
    sources = np.zeros(len(index), np.uint8)
    sources[rows] = label = np.take(table.label.reshape(-1), pixel)
    xyz = _first_mirror(_rays(intr, index, whole=mask is None), table, z, rows, pixel, label)
    if table.any_overlap:
        _later_mirrors(rig, index, xyz, sources,
                       np.flatnonzero(~behind & table.overlap.reshape(-1)[index]))
    drop = np.zeros(len(index), bool) if len(table.chains) or table.any_uncalibrated else None
    if len(table.chains):
        _further_mirrors(table, index, z, xyz, sources, drop)
    if table.any_uncalibrated:
        drop |= table.uncalibrated.reshape(-1)[index] & (sources == 0)
    if drop is not None and drop.any():
        kept = np.flatnonzero(~drop)
        index, sources, xyz = index[kept], sources[kept], np.take(xyz, kept, axis=1)
    rgb = None if colour is None else point_colours(
        check_colour_image(intr, colour), index, sources, rig.colour_correction)
    # (n, 3) as a view of the (3, n) rows: no interleaving pass
    return Cloud(xyz.T, sources, index, intr.width, rgb)


def _rays(intr: Intrinsics, index: np.ndarray, whole: bool) -> tuple[np.ndarray, np.ndarray]:
    """x/z and y/z (n,) float32 of the pixels at flat indices `index` (n,): for a whole frame's
    pixels from intr.rays by flat index (the reads stream), for an object's from the per-column and
    per-row tables by column and row (they stay in cache: 10 % faster on the bench's object, where a
    division by the width for every pixel of a whole frame would cost more than it saves)."""
    if whole:
        return np.take(intr.rays[0].reshape(-1), index), np.take(intr.rays[1].reshape(-1), index)
    x, y = intr.axis_rays
    row = index // intr.width
    return np.take(x, index - row * intr.width), np.take(y, row)


def _first_mirror(rays: tuple[np.ndarray, np.ndarray], table: ReflectionTable, z: np.ndarray,
                  rows: np.ndarray,
                  pixel: np.ndarray, label: np.ndarray) -> np.ndarray:
    """The points (3, n) float32, rows x, y, z, of pixels with rays (x/z, y/z, each (n,)) at depth z
    (n,) float32 (paper eq. 1), the columns `rows` (k,) behind their pixel's first mirror (pixels
    `pixel` (k,), mirrors `label` (k,)) reflected through it (paper eq. 3 as P_r = P + step * n with
    step = -2 (n.P + d) = -2 (z (n . ray) + d))."""
    xyz = np.empty((3, len(z)), np.float32)
    np.multiply(z, rays[0], out=xyz[0])
    np.multiply(z, rays[1], out=xyz[1])
    xyz[2] = z
    plane = np.take(table.planes, label, axis=0)                # d, nx, ny, nz
    step = np.float32(-2) * (np.take(z, rows) * np.take(table.ray_dot.reshape(-1),
                                                        pixel) + plane[:, 0])
    for axis in range(3):
        xyz[axis][rows] = np.take(xyz[axis], rows) + step * plane[:, 1 + axis]
    return xyz


def _later_mirrors(rig: Rig, index: np.ndarray, xyz: np.ndarray, sources: np.ndarray,
                   rows: np.ndarray) -> None:
    """Where boundaries overlap and the first mirror did not apply, try the others in session order
    (in place).
    index : (n,) flat pixel indices of the points xyz (3, n) float32 and sources (n,); rows : the
    columns to try."""
    candidates = np.stack([np.take(a, rows) for a in xyz], axis=1).astype(np.float64)
    bits = rig.inside_bits.reshape(-1)[index[rows]]
    todo = np.ones(len(rows), dtype=bool)
    for j, mirror in enumerate(rig.mirrors, start=1):
        if mirror.plane is None:
            continue
        hit = todo & ((bits >> np.uint32(j - 1)) & np.uint32(1)).astype(bool)
        hit &= mirror.plane.signed_distance(candidates) < 0
        reflected = mirror.plane.reflect(candidates[hit])
        for axis in range(3):
            xyz[axis][rows[hit]] = reflected[:, axis]
        sources[rows[hit]] = j
        todo &= ~hit


def _further_mirrors(table: ReflectionTable, index: np.ndarray, z: np.ndarray, xyz: np.ndarray,
                     sources: np.ndarray,
                     drop: np.ndarray) -> None:
    """Reflect the points of the chains' pixels through the further mirrors their depth is beyond
    and relabel them;
    mark in `drop` those beyond the cutoff (in place). index : (n,) flat pixel indices of z (n,)
    float32, the points xyz (3, n) float32, sources (n,) and drop (n,) bool."""
    chain = np.take(table.chain_row.reshape(-1), index)
    rows = np.flatnonzero(chain >= 0)
    if not len(rows):
        return
    chains, chain, depth = table.chains, np.take(chain, rows), np.take(z, rows)
    for level in range(len(chains.threshold)):
        go = np.flatnonzero(depth > np.take(chains.threshold[level], chain))
        if not len(go):
            break
        at, which = np.take(rows, go), np.take(chain, go)
        n, d = np.take(chains.normal[level], which, axis=0), np.take(chains.offset[level], which)
        p = [np.take(a, at) for a in xyz]
        step = np.float32(-2) * (p[0] * n[:, 0] + p[1] * n[:, 1] + p[2] * n[:, 2] + d)
        for axis in range(3):
            xyz[axis][at] = p[axis] + step * n[:, axis]
        sources[at] = np.take(chains.label[level], which)
    drop[rows[depth > np.take(chains.cutoff, chain)]] = True
