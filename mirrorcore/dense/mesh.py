"""Source-labelled triangle meshes: the zero level set of voxel values held in blocks (mirrorcore.dense.blocks), by
marching cubes (scikit-image) in one call over the blocks laid side by side.

The blocks are first regrouped into blocks of MESH_BLOCK^3 voxels (fewer, larger tiles). Each block is extended by the
first layer of voxels of its neighbours on its +x, +y and +z sides (where they are blocks too), so that every cube of
the grid lies in exactly one extended block: the one holding its lowest corner. The extended blocks are tiled in a
plane, each followed by a layer of unobserved voxels, and cut in one call. scikit-image computes a cube when its mask
holds at the cube's upper corner (+1 on each axis), so the mask it is given is cleared on each tile's first layers
along x and y, which only the cubes spanning two tiles read, and on the cubes whose corners are all above or all
below zero (a separable 2x2x2 test in numpy: scikit-image then only visits the cubes that make faces; 1.5x faster on
the bench's sphere). The vertices that neighbouring blocks both make (on the faces between them) are merged."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skimage.measure import marching_cubes as _skimage_marching_cubes

from ..budget import check_memory
from ..errors import MirrorscanError
from .blocks import Blocks
from .volume import NO_SOURCE

MESH_BLOCK = 8                  # voxels along the edge of the blocks cut together
MESH_BLOCK_BYTES = 8_000        # bytes per MESH_BLOCK^3 block: the tiles' values, mask, labels (5.4 KB), the cut
ON_GRID = 1e-3                  # voxels: a vertex this close to a grid point lies on it


@dataclass(frozen=True, eq=False)
class Mesh:
    """vertices : (n, 3) float32 metres, camera frame; faces : (m, 3) int32 vertex indices; sources : (n,) uint8,
    0 = direct, j = mirror j, from 33 a sequence of mirrors (the view that saw each vertex best)."""

    vertices: np.ndarray
    faces: np.ndarray
    sources: np.ndarray


def block_marching_cubes(blocks: Blocks, values: np.ndarray, mask: np.ndarray, source: np.ndarray) -> Mesh:
    """The surface values == 0 of the blocks' voxels ((m, B, B, B) float, one block after another), computed only
    where mask (m, B, B, B) bool holds: the mesh that marching cubes gives on the whole grid with the voxels outside
    the blocks unobserved. Each vertex takes the label in `source` (m, B, B, B) uint8 of the nearest labelled corner
    of its cube. Blocks (C order) smaller than MESH_BLOCK are regrouped first. Raises MirrorscanError when the masked
    voxels have no zero crossing, MemoryBudgetError when the tiles would not fit in the memory budget."""
    if not (mask.any() and values[mask].min() < 0 < values[mask].max()):
        raise MirrorscanError("mesh: the volume holds no surface (is the object inside the box?)")
    check_memory(blocks.voxels / MESH_BLOCK ** 3 * 8 * MESH_BLOCK_BYTES,
                 f"mesh: {len(blocks):,} blocks of {blocks.size}^3 voxels")
    fills = (1.0, False, NO_SOURCE)
    arrays = [values.astype(np.float32), mask, source]
    while blocks.size < MESH_BLOCK:
        blocks, arrays = blocks.regroup(list(zip(arrays, fills)))
    arrays = list(zip(arrays, fills))
    tile = blocks.size + 2
    columns = int(np.ceil(np.sqrt(len(blocks))))
    neighbours = _neighbours(blocks)
    tiled = [_tile(_extended(neighbours, a, fill), columns, fill) for a, fill in arrays]
    cubes = tiled[1] & _crossing_cubes(tiled[0])
    cubes[::tile] = False
    cubes[:, ::tile] = False
    # Degenerate faces (two vertices at one grid point) are dropped by the merge below, which keys such vertices by
    # that point: scikit-image's own removal is not needed (5-15 % of the 200^3 sphere's mesh, alternated runs).
    verts, faces, _, _ = _skimage_marching_cubes(tiled[0], 0.0, mask=cubes, allow_degenerate=True)
    verts, faces = _observed_edges(verts, faces, tiled[1])
    grid, edge = _grid_coordinates(blocks, verts, columns)
    keep, faces = _merge_copies(edge, faces)
    volume = blocks.volume
    return Mesh((np.asarray(volume.origin) + volume.voxel * grid[keep]).astype(np.float32), faces.astype(np.int32),
                _corner_labels(verts[keep], tiled[2]))


def _crossing_cubes(values: np.ndarray) -> np.ndarray:
    """(X, Y, Z) bool, at each cube's upper corner (where scikit-image reads its mask): the cubes of `values` (X, Y, Z)
    float whose 8 corners are not all above 0 nor all below (the others make no face); False on the first layers.
    The 2x2x2 test is separable: along x, then y, then z."""
    out = np.zeros(values.shape, bool)
    same = []
    for side in (values > 0, values < 0):
        side = side[:-1] & side[1:]
        side = side[:, :-1] & side[:, 1:]
        same.append(side[:, :, :-1] & side[:, :, 1:])
    np.logical_not(same[0] | same[1], out=out[1:, 1:, 1:])
    return out


NEIGHBOURS = ((1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, 0, 1), (0, 1, 1), (1, 1, 1))   # on the +x, +y, +z sides


def _neighbours(blocks: Blocks) -> list[tuple[np.ndarray, np.ndarray]]:
    """For each step of NEIGHBOURS: found (m,) bool, the block at ijk + step is one of `blocks` (C order), and row
    (m,) int64, its row there (0 where not found)."""
    grid, keys = blocks.volume.block_shape(blocks.size), blocks.keys                    # keys sorted: C order
    out = []
    for step in NEIGHBOURS:
        neighbour = blocks.ijk + step
        inside = (neighbour < grid).all(axis=1)
        found = np.zeros(len(blocks), bool)
        row = np.zeros(len(blocks), np.int64)
        wanted = np.ravel_multi_index(tuple(neighbour[inside].T), grid)
        at = np.minimum(np.searchsorted(keys, wanted), len(keys) - 1)
        found[inside], row[inside] = keys[at] == wanted, at
        out.append((found, row))
    return out


def _extended(neighbours: list[tuple[np.ndarray, np.ndarray]], values: np.ndarray, fill) -> np.ndarray:
    """(m, B, B, B) values of some blocks, their `_neighbours` -> (m, B + 1, B + 1, B + 1): each block with the first
    voxels of its neighbours on the +x, +y, +z sides (`fill` where there is no such block)."""
    m, b = len(values), values.shape[1]
    out = np.full((m, b + 1, b + 1, b + 1), fill, values.dtype)
    out[:, :b, :b, :b] = values
    for step, (found, row) in zip(NEIGHBOURS, neighbours):
        target = tuple(slice(b, b + 1) if s else slice(0, b) for s in step)
        origin = tuple(slice(0, 1) if s else slice(0, b) for s in step)
        out[(found, *target)] = values[(row[found], *origin)]
    return out


def _tile(extended: np.ndarray, columns: int, fill) -> np.ndarray:
    """(m, E, E, E) extended blocks -> one (columns T, rows T, E) grid, T = E + 1: block r at x tile r % columns,
    y tile r // columns, each followed along x and y by a layer of `fill`."""
    m, e = len(extended), extended.shape[1]
    rows = -(-m // columns)
    tiles = np.full((rows * columns, e + 1, e + 1, e), fill, extended.dtype)
    tiles[:m, :e, :e] = extended
    tiles = tiles.reshape(rows, columns, e + 1, e + 1, e).transpose(1, 2, 0, 3, 4)
    return np.ascontiguousarray(tiles).reshape(columns * (e + 1), rows * (e + 1), e)


def _grid_coordinates(blocks: Blocks, verts: np.ndarray, columns: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (n, 3) in the tiled grid's index coordinates -> their (n, 3) float64 coordinates in the volume grid,
    and (n,) int64 keys of the grid edge (or grid point) each lies on: equal for the copies two blocks make; a
    negative key of its own for a vertex inside a cube (the Lewiner method adds some in ambiguous cubes)."""
    b = blocks.size
    tile = np.floor(verts[:, :2] / (b + 2)).astype(np.int64)                         # x, y tile of each vertex
    row = tile[:, 1] * columns + tile[:, 0]
    local = verts.astype(np.float64)
    local[:, :2] -= (b + 2) * tile                                                  # exact: 0 <= local <= b
    low = np.floor(local)
    off = [local[:, k] != low[:, k] for k in range(3)]     # off the grid along x, y, z (per column: numpy reduces
    axis = np.where(off[0], 0, np.where(off[1], 1, np.where(off[2], 2, 3)))     # rows of 3 slowly); 3: a grid point
    first = b * blocks.ijk[row]
    corner = first + low.astype(np.int64)
    shape = tuple(b * n + 1 for n in blocks.volume.block_shape(b))
    key = np.ravel_multi_index(tuple(corner.T), shape) * 4 + axis
    inside = (off[0] & off[1]) | (off[0] & off[2]) | (off[1] & off[2])   # Lewiner's, in a cube: one block's
    key[inside] = -1 - np.arange(np.count_nonzero(inside))
    return first + local, key


def _merge_copies(edge: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices with the same edge key (n,) int64 are one vertex, made by two neighbouring blocks (or by two faces
    meeting at a grid point) -> the index (k,) of the one kept of each, and faces (m', 3) renumbered to 0..k-1: those
    left degenerate by the merge dropped, and the vertices only they used."""
    _, keep, inverse = np.unique(edge, return_index=True, return_inverse=True)
    faces = inverse.reshape(-1)[faces]
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
    used = np.zeros(len(keep), bool)
    used[faces.reshape(-1)] = True
    if used.all():
        return keep, faces
    return keep[used], np.take(np.cumsum(used) - 1, faces)


def _corner_labels(verts: np.ndarray, source: np.ndarray) -> np.ndarray:
    """The label of the nearest of the 8 corners of each vertex's cube that has one (not NO_SOURCE; the first such
    corner in i, j, k order on ties). verts : (n, 3) float grid index coordinates; source : (nx, ny, nz) uint8
    -> (n,) uint8 (NO_SOURCE when no corner has a label)."""
    top = np.array(source.shape) - 1
    nearest = np.clip(np.ceil(verts - 0.5), 0, top).astype(np.int64)        # the nearest corner (the lower on ties)
    labels = source[tuple(nearest.T)]
    missing = np.flatnonzero(labels == NO_SOURCE)                            # rare: a vertex on an edge has both ends
    if len(missing):                                                         # labelled (observed)
        labels[missing] = _labelled_corner(verts[missing], source)
    return labels


def _labelled_corner(verts: np.ndarray, source: np.ndarray) -> np.ndarray:
    """_corner_labels for vertices whose nearest corner has no label: the nearest of the 8 corners of the cube that
    has one."""
    top = np.array(source.shape) - 1
    base = np.clip(np.floor(verts), 0, top).astype(np.int64)
    best = np.full(len(verts), np.inf)
    labels = np.full(len(verts), NO_SOURCE, np.uint8)
    for offset in np.ndindex(2, 2, 2):                       # one corner at a time: memory stays O(n)
        corner = np.minimum(base + offset, top)
        label = source[corner[:, 0], corner[:, 1], corner[:, 2]]
        distance = np.where(label == NO_SOURCE, np.inf, np.square(corner - verts).sum(axis=1))
        nearer = distance < best
        best[nearer], labels[nearer] = distance[nearer], label[nearer]
    return labels


def _observed_edges(verts: np.ndarray, faces: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Keep the faces whose 3 vertices lie on grid edges with both ends in `mask` (a vertex interpolated towards an
    unobserved voxel is false; scikit-image reads its mask at one corner of each cube only), and the vertices they use.
    verts : (n, 3) float, grid index coordinates; faces : (m, 3) int -> the kept (n', 3), (m', 3), faces renumbered."""
    top = np.array(mask.shape, verts.dtype) - 1
    columns, flat = np.ascontiguousarray(verts.T), mask.reshape(-1)
    observed = np.ones(len(verts), bool)
    for shift, rounding in ((ON_GRID, np.floor), (-ON_GRID, np.ceil)):          # on the grid (within ON_GRID):
        ends = [np.clip(rounding(c + c.dtype.type(shift)), 0, t).astype(np.intp) for c, t in zip(columns, top)]
        observed &= np.take(flat, np.ravel_multi_index(ends, mask.shape))       # both ends at that grid point
    ends = np.take(observed, faces)                  # per column, not .all(axis=1): numpy reduces rows of 3 slowly
    faces = np.compress(ends[:, 0] & ends[:, 1] & ends[:, 2], faces, axis=0)
    used = np.zeros(len(verts), bool)
    used[faces.reshape(-1)] = True
    number = np.cumsum(used) - 1                                     # the new index of each used vertex
    return np.compress(used, verts, axis=0), np.take(number, faces)
