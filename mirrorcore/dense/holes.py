"""The holes of a triangle mesh (loops of edges that only one face uses) and their closing where the
views saw the surface: a hole no longer than a limit is closed by a fan of triangles from the mean
of its loop's vertices, when the fan lies in voxels a view observed (`seen`); a hole where no view
saw stays open, so no surface is invented there."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from mirrorcore.dense.mesh import Mesh


@dataclass(frozen=True)
class Holes:
    """The holes of a mesh.

    Attributes
    ----------
    count : int
        Loops of boundary edges (a pinch vertex joins its loops into one).
    length : float
        Their edges' total length, metres.
    """

    count: int
    length: float


@dataclass(frozen=True, eq=False)
class _Loops:
    """Boundary edges, each (a, b) in its face's winding, its loop, and each loop's length."""

    edges: np.ndarray
    loop: np.ndarray
    lengths: np.ndarray


def _loops(vertices: np.ndarray, faces: np.ndarray) -> _Loops:
    """The boundary edges of a mesh grouped in loops."""
    directed = np.asarray(faces, np.int64)[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    n = len(vertices)
    keys = directed.min(axis=1) * n + directed.max(axis=1)
    _, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
    edges = directed[counts[inverse.reshape(-1)] == 1]
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    # loops numbered 0..k-1
    _, loop = np.unique(labels[edges[:, 0]], return_inverse=True)
    loop = loop.reshape(-1)
    step = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    return _Loops(edges, loop, np.bincount(loop, weights=step, minlength=loop.max(initial=-1) + 1))


def mesh_holes(mesh: Mesh) -> Holes:
    """Count the holes of a mesh and measure their boundary.

    Parameters
    ----------
    mesh : Mesh

    Returns
    -------
    Holes
    """
    loops = _loops(mesh.vertices, mesh.faces)
    return Holes(len(loops.lengths), float(loops.lengths.sum()))


def close_holes(mesh: Mesh, seen: Callable[[np.ndarray], np.ndarray], max_length: float) -> Mesh:
    """Close the holes of a mesh that are short and lie where a view saw the surface.

    A hole whose loop is at most `max_length` long is closed by one new vertex, the mean of its
    loop's vertices, and a triangle from each of its edges to it, wound as the mesh; the new vertex
    takes the source of a vertex of the loop and the mean colour of the loop's vertices. It is
    closed only when `seen` holds at the new vertex and at every new triangle's centroid, and its
    loop passes each of its vertices once.

    Parameters
    ----------
    mesh : Mesh
    seen : callable
        (k, 3) points, metres -> (k,) bool: whether a view observed the voxel there.
    max_length : float
        Metres.

    Returns
    -------
    Mesh
        `mesh` itself when no hole is closed; else its vertices, then the new ones, and its faces,
        then the new ones.
    """
    vertices = np.asarray(mesh.vertices)
    loops = _loops(vertices, mesh.faces)
    short = loops.lengths <= max_length
    edges, loop = loops.edges[short[loops.loop]], loops.loop[short[loops.loop]]
    if not len(edges):
        return mesh
    # each vertex of a loop starts one of its edges
    count = np.bincount(loop, minlength=len(short))
    centres = np.stack([np.bincount(loop, weights=vertices[edges[:, 0], a], minlength=len(short))
                        for a in range(3)], axis=1) / np.maximum(count, 1)[:, None]
    fan = (vertices[edges[:, 0]] + vertices[edges[:, 1]] + centres[loop]) / 3
    unseen = np.bincount(loop, weights=~seen(fan), minlength=len(short)) > 0
    unseen |= ~seen(centres)
    # a loop through a vertex twice (a pinch) would give its fan an edge of three faces
    pinched = np.bincount(edges[:, 0], minlength=len(vertices))[edges[:, 0]] > 1
    kept = short & ~unseen & (np.bincount(loop, weights=pinched, minlength=len(short)) == 0)
    closing = kept[loop]
    if not closing.any():
        return mesh
    number = np.cumsum(kept) - 1 + len(vertices)
    edges, loop = edges[closing], loop[closing]
    faces = np.stack([edges[:, 1], edges[:, 0], number[loop]], axis=1).astype(np.int32)
    first = np.zeros(len(short), np.int64)
    first[loop[::-1]] = edges[::-1, 0]
    colours = mesh.colours
    if colours is not None:
        mean = np.stack([np.bincount(loop, weights=colours[edges[:, 0], c], minlength=len(short))
                         for c in range(3)], axis=1) / np.maximum(count, 1)[:, None]
        colours = np.concatenate([colours, np.rint(mean[kept]).astype(np.uint8)])
    return Mesh(np.concatenate([vertices, centres[kept].astype(np.float32)]),
                np.concatenate([mesh.faces, faces]),
                np.concatenate([mesh.sources, mesh.sources[first[kept]]]), colours)
