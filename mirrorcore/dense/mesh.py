"""Source-labelled triangle meshes: the zero level set of a voxel grid by marching cubes (scikit-image)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skimage.measure import marching_cubes as _skimage_marching_cubes

from ..errors import MirrorscanError
from .volume import NO_SOURCE, Volume


@dataclass(frozen=True, eq=False)
class Mesh:
    """vertices : (n, 3) float32 metres, camera frame; faces : (m, 3) int32 vertex indices; sources : (n,) uint8,
    0 = direct, j = mirror j, from 33 a sequence of mirrors (the view that saw each vertex best)."""

    vertices: np.ndarray
    faces: np.ndarray
    sources: np.ndarray


def marching_cubes(volume: Volume, values: np.ndarray, mask: np.ndarray, source: np.ndarray) -> Mesh:
    """The surface values == 0 of a (nx, ny, nz) float grid over `volume`, computed only where mask (nx, ny, nz) bool
    holds; each vertex takes the label in `source` (nx, ny, nz) uint8 of the nearest labelled corner of its cube.
    Raises MirrorscanError when the masked grid has no zero crossing."""
    if not (mask.any() and values[mask].min() < 0 < values[mask].max()):
        raise MirrorscanError("mesh: the volume holds no surface (is the object inside the box?)")
    verts, faces, _, _ = _skimage_marching_cubes(values, 0.0, mask=mask, allow_degenerate=False)
    verts, faces = _observed_edges(verts, faces, mask)
    labels = _corner_labels(verts, source)
    verts = (np.asarray(volume.origin) + volume.voxel * verts).astype(np.float32)
    return Mesh(verts, faces.astype(np.int32), labels)


def _corner_labels(verts: np.ndarray, source: np.ndarray) -> np.ndarray:
    """The label of the nearest of the 8 corners of each vertex's cube that has one (not NO_SOURCE).
    verts : (n, 3) float grid index coordinates; source : (nx, ny, nz) uint8 -> (n,) uint8."""
    top = np.array(source.shape) - 1
    base = np.clip(np.floor(verts), 0, top).astype(np.int64)
    offsets = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)])       # (8, 3)
    corners = np.clip(base[:, None, :] + offsets[None], 0, top)                           # (n, 8, 3)
    labels = source[corners[..., 0], corners[..., 1], corners[..., 2]]                    # (n, 8)
    distance = np.linalg.norm(corners - verts[:, None, :], axis=2)
    distance[labels == NO_SOURCE] = np.inf
    return labels[np.arange(len(verts)), np.argmin(distance, axis=1)]


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
