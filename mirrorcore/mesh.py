"""Source-labelled triangle meshes: the zero level set of a voxel grid by marching cubes (scikit-image)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skimage.measure import marching_cubes as _skimage_marching_cubes

from .errors import MirrorscanError
from .volume import Volume


@dataclass(frozen=True, eq=False)
class Mesh:
    """vertices : (n, 3) float32 metres, camera frame; faces : (m, 3) int32 vertex indices; sources : (n,) uint8,
    0 = direct, j = mirror j (the view that saw each vertex best)."""

    vertices: np.ndarray
    faces: np.ndarray
    sources: np.ndarray


def marching_cubes(volume: Volume, values: np.ndarray, mask: np.ndarray, source: np.ndarray) -> Mesh:
    """The surface values == 0 of a (nx, ny, nz) float grid over `volume`, computed only where mask (nx, ny, nz) bool
    holds; each vertex takes the label in `source` (nx, ny, nz) uint8 of its nearest voxel.
    Raises MirrorscanError when the masked grid has no zero crossing."""
    if not (mask.any() and values[mask].min() < 0 < values[mask].max()):
        raise MirrorscanError("mesh: the volume holds no surface (is the object inside the box?)")
    verts, faces, _, _ = _skimage_marching_cubes(values, 0.0, mask=mask, allow_degenerate=False)
    verts, faces = _observed_edges(verts, faces, mask)
    verts = (np.asarray(volume.origin) + volume.voxel * verts).astype(np.float32)
    return Mesh(verts, faces.astype(np.int32), source.reshape(-1)[volume.nearest_index(verts)])


def _observed_edges(verts: np.ndarray, faces: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Keep the faces whose 3 vertices lie on grid edges with both ends in `mask` (a vertex interpolated towards an
    unobserved voxel is false; scikit-image reads its mask at one corner of each cube only), and the vertices they use.
    verts : (n, 3) float, grid index coordinates; faces : (m, 3) int -> the kept (n', 3), (m', 3), faces renumbered."""
    near = np.rint(verts)
    on_grid = np.abs(verts - near) < 1e-3
    top = np.array(mask.shape) - 1
    lo = np.clip(np.where(on_grid, near, np.floor(verts)), 0, top).astype(np.int64)
    hi = np.clip(np.where(on_grid, near, np.ceil(verts)), 0, top).astype(np.int64)
    observed = mask[tuple(lo.T)] & mask[tuple(hi.T)]
    faces = faces[observed[faces].all(axis=1)]
    used, faces = np.unique(faces, return_inverse=True)
    return verts[used], faces.reshape(-1, 3)
