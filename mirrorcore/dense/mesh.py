"""Source-labelled triangle meshes: the zero level set of voxel values held in blocks
(mirrorcore.dense.blocks), by classic (Lorensen) marching cubes in numpy, over the blocks as they
are.

Every cube of the grid belongs to the block holding its lowest corner, and every grid edge to the
voxel at its lower end. Each block is extended by the first layer of voxels of its neighbours on its
+x, +y and +z sides (the block index last, so that numpy's loops run along it), so that its B^3
cubes have their 8 corners in it; a cube's key (which corners are at or below zero, which are
observed) gives its triangles in a table, and each triangle corner's edge is looked up, in the block
of the voxel that owns it, in one array of vertex ids per voxel and axis: the vertices that
neighbouring blocks share are one by construction, with no sort. The blocks that are not there but
have one on their +x, +y or +z side are added as unobserved "ghosts" (a cube whose lowest corner is
unobserved may still have faces on the edges between its other corners).

The table is built once from scikit-image's own Lorensen marching cubes, run on one cube for each of
the 254 cases, so the triangulation and its winding are scikit-image's: the mesh is
`skimage.measure.marching_cubes(method= 'lorensen')` on the whole grids with the rules below. On the
bench's sphere (6367 blocks, 120,000 faces) the whole mesh takes 40-60 ms, against 105-135 ms for
scikit-image's marching cubes (Lewiner's method) on the same blocks tiled side by side with the
numpy around it, and ~50 ms for scikit-image's call alone (alternated runs; README, *Figures*).

Rules: a face is kept when each of its 3 corners lies on a grid edge with both ends observed (in the
mask), a corner on a grid point too; a vertex is interpolated linearly along its edge, t = v0 / (v0
- v1); a vertex that falls exactly on a grid point (t is 0 or 1 in float32: a value exactly 0 there,
or one negligible beside the other end's) is one vertex for that point, whatever edges it was found
on, and the faces that this makes degenerate are dropped; vertices used by no face are dropped."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

import cv2
import numpy as np
from skimage.measure import marching_cubes as _skimage_marching_cubes

from mirrorcore.base.budget import check_memory
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.dense.blocks import Blocks
from mirrorcore.dense.volume import NO_SOURCE

# bytes per 64 voxels of blocks at the peak, ghosts included: traced (tracemalloc) on the
MESH_BLOCK_BYTES = 5_500
# bench's sphere in blocks of 4^3 voxels, 5.0 KB at 100^3, 4.9 KB at 200^3, 4.7 KB at 300^3
# a cube's corner k: offset (x, y, z)
CORNERS = tuple((k & 1, k >> 1 & 1, k >> 2) for k in range(8))
# a cube's edges: (lower corner, axis)
EDGES = tuple((d, a) for a in range(3) for d in CORNERS if d[a] == 0)
# per cube (classic marching cubes)
MAX_TRIANGLES = 5


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh with source labels.

    Attributes
    ----------
    vertices : (n, 3) float32 array
        Metres, camera frame.
    faces : (m, 3) int32 array
        Vertex indices.
    sources : (n,) uint8 array
        0 = direct, j = mirror j, from 33 a sequence of mirrors (the view that saw each vertex
        best).
    colours : (n, 3) uint8 array or None
        RGB levels of each vertex (a fusion with colour), else None.
    """

    vertices: np.ndarray
    faces: np.ndarray
    sources: np.ndarray
    colours: np.ndarray | None = None


def block_marching_cubes(blocks: Blocks, values: np.ndarray, mask: np.ndarray,
                         source: np.ndarray,
                         colour: Callable[[np.ndarray], np.ndarray] | None = None) -> Mesh:
    """Extract the surface values == 0 of blocks' voxels by marching cubes.

    On the edges with both ends where `mask` holds: the mesh of classic marching cubes on the whole
    grid with the voxels outside the blocks unobserved, by the rules of the module docstring. Each
    vertex takes the label in `source` of the nearer end of its edge (the lower end on ties), or of
    the other end when that one has none (NO_SOURCE); NO_SOURCE when neither has one (a fusion
    labels every voxel it observes, so not there); a vertex on a grid point takes that point's.
    With `colour`, each vertex's colour is interpolated between its edge's ends' as its position is
    (an end without colour takes the other end's).

    Parameters
    ----------
    blocks : Blocks
    values : (m, B, B, B) float array
        One block after another, in the order of `blocks`.
    mask : (m, B, B, B) bool array
    source : (m, B, B, B) uint8 array
    colour : callable, optional
        (k, 3) int64 voxel indices in the volume -> (k, 4) uint8 their red, green, blue and 1 (0:
        no colour; TsdfResult.voxel_colours).

    Returns
    -------
    Mesh

    Raises
    ------
    MirrorscanError
        The masked voxels have no zero crossing.
    MemoryBudgetError
        The work would not fit in the memory budget.
    """
    seen = values[mask]
    if not (len(seen) and seen.min() < 0 < seen.max()):
        raise MirrorscanError("mesh: the volume holds no surface (is the object inside the box?)")
    check_memory(blocks.voxels / 64 * MESH_BLOCK_BYTES,
                 f"mesh: {len(blocks):,} blocks of {blocks.size}^3 voxels")
    rows = _neighbour_rows(blocks)
    ext = [_extended(rows, a, fill) for a,
           fill in ((values.astype(np.float32, copy=False), 1.0), (mask, False),
                                                   (source, NO_SOURCE))]
    ids, grid, labels, points, colours = _edge_vertices(blocks, rows, *ext, colour)
    faces = _faces(rows, _cases(ext[0] <= 0, ext[1]), ids, points, blocks.size)
    used = np.zeros(len(grid), bool)
    used[faces.reshape(-1)] = True
    volume = blocks.volume
    vertices = (np.asarray(volume.origin) + volume.voxel * grid[used]).astype(np.float32)
    return Mesh(vertices, np.take(np.cumsum(used, dtype=np.int32) - 1, faces), labels[used],
                None if colours is None else colours[used])


@cache
def case_table() -> tuple[np.ndarray, np.ndarray]:
    """Return classic marching cubes' triangles per case, from scikit-image's Lorensen method.

    In scikit-image's order and winding (its default gradient_direction, 'descent'). Bit k of a
    case: CORNERS[k] is at or below the level (scikit-image's side for a value equal to it).

    Returns
    -------
    counts : (256,) int64 array
        The triangles of each case.
    edges : (256, MAX_TRIANGLES, 3) int64 array
        The EDGES index of each triangle's corners.
    """
    counts, edges = np.zeros(256, np.int64), np.zeros((256, MAX_TRIANGLES, 3), np.int64)
    number = {(d, a): e for e, (d, a) in enumerate(EDGES)}
    for case in range(1, 255):
        cube = np.ones((2, 2, 2), np.float32)
        for k, corner in enumerate(CORNERS):
            if case >> k & 1:
                cube[corner] = -1.0
        verts, faces, _, _ = _skimage_marching_cubes(cube, 0.0, method="lorensen",
                                                     allow_degenerate=True)
        # vertices at the edges' midpoints
        lower = np.floor(verts).astype(int)
        axis = np.argmax(verts != lower, axis=1)
        on_edge = [number[tuple(d), a] for d, a in zip(lower.tolist(), axis.tolist())]
        counts[case] = len(faces)
        edges[case, :len(faces)] = np.asarray(on_edge)[faces]
    return counts, edges


@cache
def _cube_table() -> tuple[np.ndarray, np.ndarray]:
    """case_table by cube key (`_cases`: bit 2k, CORNERS[k] at or below zero; bit 2k + 1, observed),
    keeping the triangles whose 3 edges have both ends observed: counts (65536,) uint8 and edges
    (65536 * MAX_TRIANGLES, 3) int8 (row key * MAX_TRIANGLES + n: the key's n-th kept triangle)."""
    counts, edges = case_table()
    key = np.arange(1 << 16)
    case, seen = (sum((key >> 2 * k + bit & 1) << k for k in range(8)) for bit in (0, 1))
    ends = [1 << CORNERS.index(d) | 1 << CORNERS.index(tuple(np.add(d, np.eye(3, dtype=int)[a])))
            for d, a in EDGES]
    # (256, 5): the corners to observe
    needs = np.bitwise_or.reduce(np.array(ends)[edges], axis=2)
    keep = ((np.arange(MAX_TRIANGLES) < counts[case][:, None])
            & (seen[:, None] & needs[case] == needs[case]))
    # the kept ones first, in order
    order = np.argsort(~keep, axis=1, kind="stable")
    kept = edges.astype(np.int8).reshape(-1, 3)[(case[:, None] * MAX_TRIANGLES + order).reshape(-1)]
    return keep.sum(axis=1).astype(np.uint8), kept


def _neighbour_rows(blocks: Blocks) -> np.ndarray:
    """The m blocks, then (in C order) the g blocks not among them that have one of them on their
    +x, +y, +z sides (ghosts: all their voxels are unobserved, but the cubes whose lowest corner is
    in them may have faces on the edges between their other corners, in the blocks) -> (M + 1, 8)
    int64, M = m + g: the row of the block at ijk + CORNERS[c] of each of them (c = 0 is the block
    itself), M where there is none; row M (no block) is all M."""
    # a layer on each side
    marks = np.zeros(np.add(blocks.volume.block_shape(blocks.size), 2), bool)
    own = blocks.ijk + 1
    for step in CORNERS[1:]:
        marks[tuple((own - step).T)] = True
    marks[tuple(own.T)] = False
    every = np.concatenate([own, np.argwhere(marks[1:, 1:, 1:]) + 1])
    lookup = np.full(marks.shape, len(every), np.int32)
    lookup[tuple(every.T)] = np.arange(len(every))
    out = np.full((len(every) + 1, 8), len(every), np.int64)
    for c, step in enumerate(CORNERS):
        out[:-1, c] = lookup[tuple((every + step).T)]
    return out


def _extended(rows: np.ndarray, values: np.ndarray, fill) -> np.ndarray:
    """(m, B, B, B) values of the first m of M blocks (the others: `fill`), the blocks'
    `_neighbour_rows` -> (B + 1, B + 1, B + 1, M + 1), the block index last (numpy's loops then run
    along it): each block with the first voxels of its neighbours on the +x, +y, +z sides (`fill`
    where there is no such block), then a block of `fill` (row M, no block)."""
    m, b = len(values), values.shape[1]
    out = np.empty((b + 1, b + 1, b + 1, len(rows)), values.dtype)
    out[:b, :b, :b, :m] = values.transpose(1, 2, 3, 0)
    out[:b, :b, :b, m:] = fill
    for c, step in enumerate(CORNERS[1:], 1):
        target = tuple(slice(b, b + 1) if s else slice(0, b) for s in step)
        origin = tuple(slice(0, 1) if s else slice(0, b) for s in step)
        out[target] = np.take(out[origin], rows[:, c], axis=3)
    return out


def _cases(below: np.ndarray, observed: np.ndarray) -> np.ndarray:
    """(B + 1, B + 1, B + 1, M + 1) bool, the extended blocks' voxels at or below zero and observed
    -> (B^3 * (M + 1),) uint16 the key of each cube ([voxel in C order, row]): bit 2k, CORNERS[k]
    below; bit 2k + 1, observed. Built along x, then y, then z."""
    packed = below.view(np.uint8) | observed.view(np.uint8) << 1
    x = packed[:-1] | packed[1:] << 2
    y = x[:, :-1] | x[:, 1:] << 4
    z = y[:, :, :-1].astype(np.uint16) | y[:, :, 1:].astype(np.uint16) << 8
    return z.reshape(-1)


def _edge_vertices(blocks: Blocks, rows: np.ndarray, values: np.ndarray, mask: np.ndarray,
                   source: np.ndarray, colour: Callable[[np.ndarray], np.ndarray] | None = None
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, np.ndarray | None]:
    """The vertices on the crossing, observed edges of the m `blocks`, the first of the extended
    blocks (values float32, mask bool, source uint8, (B + 1, B + 1, B + 1, M + 1); the others,
    unobserved ghosts, own none) -> ids (B^3 * 3 * m,) int32, the vertex on the edge of each voxel
    along each axis (index [voxel in C order, axis, row]), -1 where there is none; grid (n, 3)
    float64 the vertices' voxel index coordinates in the volume; labels (n,) uint8; how many of
    them lie on grid points (the last ones, one per point); and with colour (block_marching_cubes)
    their colours (n, 3) uint8, else None."""
    b, span, m = values.shape[0] - 1, values.shape[3], len(blocks)
    edge = _crossing_edges(values[..., :m], mask[..., :m])              # [voxel, axis, row]
    voxel, axis, row = edge // (3 * m), edge // m % 3, edge % m
    # the ends' voxels in the extended blocks
    low = _ext_voxel(b)[voxel]
    high = low + np.array([(b + 1) ** 2, b + 1, 1])[axis]
    v0, v1 = np.take(values, low * span + row), np.take(values, high * span + row)
    # float32 in [0, 1]: the signs differ
    t = v0 / (v0 - v1)
    colours = None
    if colour is not None:
        owner, local = _ext_owner(b)
        colours = _edge_colours(colour, blocks, *(
            rows[row, owner[ends]] * b ** 3 + local[ends] for ends in (low, high)), t)
    s0, s1 = np.take(source, low * span + row), np.take(source, high * span + row)
    near, far = np.where(t <= 0.5, s0, s1), np.where(t <= 0.5, s1, s0)
    labels = np.where(near == NO_SOURCE, far, near)
    on = (t == 0) | (t == 1)
    off, on = np.flatnonzero(~on), np.flatnonzero(on)
    point = np.where(t[on] == 1, high[on], low[on])                     # on a grid point: which one
    one, which = _grid_points(rows, row[on], point, b)
    ids = np.full(b ** 3 * 3 * m, -1, np.int32)
    ids[edge[off]] = np.arange(len(off))
    ids[edge[on]] = len(off) + which
    row, at = np.concatenate([row[off], row[on][one]]), np.concatenate([low[off], point[one]])
    grid = (np.take(blocks.size * blocks.ijk, row,
                    axis=0) + np.take(np.argwhere(np.ones((b + 1,) * 3, bool)), at,
                                                                     axis=0)).astype(np.float64)
    grid[np.arange(len(off)), axis[off]] += t[off]
    sources = np.concatenate([labels[off], np.take(source, point[one] * span + row[len(off):])])
    if colours is not None:
        colours = np.concatenate([colours[off], colours[on][one]])
    return ids, grid, sources, len(one), colours


def _edge_colours(colour: Callable[[np.ndarray], np.ndarray], blocks: Blocks, low: np.ndarray,
                  high: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The colours (k, 3) uint8 at t (k,) float32 along the edges from voxel low to voxel high (k,
    int64, block row * B^3 + voxel in C order, in `blocks`) of colour's voxels
    (block_marching_cubes; an end without colour takes the other end's). Each voxel is coloured
    once (it ends up to 6 edges), found by marks rather than a sort."""
    b = blocks.size
    marks = np.zeros(len(blocks) * b ** 3, bool)
    marks[low] = True
    marks[high] = True
    voxels = np.flatnonzero(marks)
    number = np.empty(len(marks), np.int32)
    number[voxels] = np.arange(len(voxels), dtype=np.int32)
    row, local = np.divmod(voxels, b ** 3)
    ijk = np.take(b * blocks.ijk, row, axis=0) + np.take(_block_voxels(b), local, axis=0)
    painted = colour(ijk)
    c0, c1 = (np.take(painted, np.take(number, ends), axis=0).astype(np.float32)
              for ends in (low, high))
    lost = c0[:, 3] == 0
    c0[lost] = c1[lost]
    lost = c1[:, 3] == 0
    c1[lost] = c0[lost]
    c1 -= c0
    c1 *= t[:, None]
    c1 += c0
    # rounded and saturated in one pass (the values are not negative)
    return cv2.convertScaleAbs(c1)[:, :3]


@cache
def _block_voxels(b: int) -> np.ndarray:
    """(B^3, 3) int64: the voxels of a block in C order."""
    return np.argwhere(np.ones((b, b, b), bool)).astype(np.int64)


def _grid_points(rows: np.ndarray, row: np.ndarray, point: np.ndarray, b: int) -> tuple[np.ndarray,
                                                                                        np.ndarray]:
    """Vertices on grid points: the rows (n,) of their blocks and their points (n,), voxels of the
    extended blocks ((B + 1)^3, C order), observed -> the index (k,) of the first vertex on each
    distinct grid point and which one (n,) each is on, 0..k-1. The only sort of the mesh, on these
    few vertices."""
    owner, local = _ext_owner(b)
    _, one, which = np.unique(local[point] * len(rows) + rows[row, owner[point]], return_index=True,
                              return_inverse=True)
    return one, which.reshape(-1)


def _crossing_edges(values: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(B + 1, B + 1, B + 1, m) values and mask of extended blocks -> the edges from each block's
    voxels to their +x, +y, +z neighbours whose ends are on both sides of zero (above it; at or
    below it) and both observed: sorted indices [voxel in C order, axis, row] into (B^3, 3, m)."""
    b = values.shape[0] - 1
    above = values > 0
    own = (slice(0, b),) * 3
    crossing = np.empty((b, b, b, 3, values.shape[3]), bool)
    for axis in range(3):
        upper = tuple(slice(1, b + 1) if k == axis else slice(0, b) for k in range(3))
        out = crossing[:, :, :, axis]
        np.not_equal(above[own], above[upper], out=out)
        out &= mask[own]
        out &= mask[upper]
    return np.flatnonzero(crossing)


@cache
def _ext_voxel(b: int) -> np.ndarray:
    """(B^3,) int64: the index of each voxel of a block (C order) in its extended block ((B + 1)^3,
    C order)."""
    return np.ravel_multi_index(tuple(np.argwhere(np.ones((b, b, b), bool)).T), (b + 1,) * 3)


@cache
def _ext_owner(b: int) -> tuple[np.ndarray, np.ndarray]:
    """For each voxel of an extended block ((B + 1)^3, C order): which block holds it (CORNERS
    index, 0 the block itself) and its voxel there (C order): two ((B + 1)^3,) int64."""
    ext = np.argwhere(np.ones((b + 1,) * 3, bool))
    beyond = ext >= b
    return beyond[:, 0] + 2 * beyond[:, 1] + 4 * beyond[:,
                                                        2], np.ravel_multi_index(tuple((ext % b).T),
                                                                                    (b,) * 3)


@cache
def _corner_edges(b: int) -> tuple[np.ndarray, np.ndarray]:
    """For the cube of each voxel of a block and each of its EDGES ([voxel in C order, edge], flat):
    which block (CORNERS index, 0 the block itself) holds the voxel that owns the edge (its lower
    end), and the index [voxel in C order, axis] of the edge there: two (B^3 * 12,) int64."""
    owner, local = _ext_owner(b)
    ext = _ext_voxel(b)[:,
                        None] + np.array([np.ravel_multi_index(d, (b + 1,) * 3) for d, _ in EDGES])
    axes = np.array([a for _, a in EDGES])
    return owner[ext].reshape(-1), (local[ext] * 3 + axes).reshape(-1)


def _faces(rows: np.ndarray, keys: np.ndarray, ids: np.ndarray, points: int, b: int) -> np.ndarray:
    """The triangles of the M blocks' cubes (keys (B^3 * (M + 1),) uint16, `_cases`) on observed
    edges, their corners' vertices looked up in ids (`_edge_vertices`, the first m blocks: those
    edges are all theirs) -> (f, 3) int32 vertex indices; when some vertices lie on grid `points`,
    the triangles with two corners on one of them are dropped."""
    counts, table = _cube_table()
    span, m = len(rows), len(ids) // (3 * b ** 3)
    n = counts[keys]
    cubes = np.flatnonzero(n)
    count = n[cubes].astype(np.int64)
    # + nth triangle: table row
    first = keys[cubes].astype(np.int64) * MAX_TRIANGLES - np.cumsum(count) + count
    edges = np.take(table, np.arange(count.sum()) + np.repeat(first, count), axis=0)
    voxel, row = np.divmod(cubes, span)
    # [voxel, edge] of each corner
    at = np.repeat(voxel * 12, count)[:, None] + edges
    codes, slots = _corner_edges(b)
    owner = np.take(rows, np.repeat(row * 8, count)[:, None] + np.take(codes, at))
    faces = np.take(ids, np.take(slots, at) * m + owner)
    if not points:
        return faces
    first, second, third = faces.T                     # per column: numpy reduces rows of 3 slowly
    return faces[(first != second) & (second != third) & (first != third)]
