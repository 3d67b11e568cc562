"""GLB (binary glTF 2.0) files of clouds and meshes with their vertices' colours, for viewers and
browsers: the vertices in metres in the camera frame (OpenCV axes), under one node that turns them
into glTF's axes (y up, looking along -z: a half turn about x)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from mirrorcore.base.atomic import write_atomic
from mirrorcore.base.palette import source_colours
from mirrorcore.io.ply import checked_colours, checked_faces, write_ply

GLB_SUFFIX = ".glb"
# the node's transform: OpenCV's camera frame (x right, y down, z forward) to glTF's axes
CAMERA_TO_GLTF = np.diag([1.0, -1.0, -1.0, 1.0])


def encode_glb(points: np.ndarray, colours: np.ndarray,
               faces: np.ndarray | None = None) -> bytes:
    """Encode a cloud, or a mesh with `faces`, with its vertices' colours as GLB bytes.

    A cloud is one primitive of points, a mesh one of triangles; COLOR_0 holds the colours as
    normalised unsigned bytes.

    Parameters
    ----------
    points : (n, 3) float array
        Metres, camera frame.
    colours : (n, 3) uint8 array
        RGB of each vertex.
    faces : (m, 3) integer array, optional
        Vertex indices of triangles.

    Returns
    -------
    bytes

    Raises
    ------
    ValueError
        Mismatched or out-of-range input.
    """
    points = np.asarray(points, dtype=np.float32).reshape(-1, 3)
    colours = checked_colours(colours, len(points), "encode_glb")
    if faces is None:
        geometry = trimesh.PointCloud(points, colors=colours)
    else:
        geometry = trimesh.Trimesh(points, checked_faces(faces, len(points), "encode_glb"),
                                   vertex_colors=colours, process=False, validate=False)
    scene = trimesh.Scene()
    name = "cloud" if faces is None else "mesh"
    scene.add_geometry(geometry, node_name=name, geom_name=name, transform=CAMERA_TO_GLTF)
    return trimesh.exchange.gltf.export_glb(scene)


def write_glb(path: str | Path, points: np.ndarray, colours: np.ndarray,
              faces: np.ndarray | None = None) -> None:
    """Write a cloud, or a mesh with `faces`, as GLB atomically (see `encode_glb`).

    Parameters
    ----------
    path : str or Path
        The file written.
    points : (n, 3) float array
        Metres, camera frame.
    colours : (n, 3) uint8 array
        RGB of each vertex.
    faces : (m, 3) integer array, optional
        Vertex indices of triangles.

    Raises
    ------
    ValueError
        Mismatched or out-of-range input.
    """
    write_atomic(path, encode_glb(points, colours, faces))


def write_result(path: str | Path, points: np.ndarray, sources: np.ndarray,
                 faces: np.ndarray | None = None, colours: np.ndarray | None = None) -> None:
    """Write a labelled cloud, or a mesh with `faces`: GLB when `path` ends in .glb, else PLY.

    Parameters
    ----------
    path : str or Path
        The file written (atomically).
    points : (n, 3) float array
        Metres, camera frame.
    sources : (n,) integer array
        Labels 0..255 (mirrorcore.base.palette); a GLB has the source colours of the labels
        when `colours` is None, and no labels.
    faces : (m, 3) integer array, optional
        Vertex indices of triangles.
    colours : (n, 3) uint8 array, optional
        RGB of each vertex; the source colours without.

    Raises
    ------
    ValueError
        Mismatched or out-of-range input.
    """
    if Path(path).suffix.lower() != GLB_SUFFIX:
        write_ply(path, points, sources, faces, colours)
        return
    sources = np.asarray(sources).reshape(-1)
    if len(sources) != len(np.asarray(points).reshape(-1, 3)):
        raise ValueError(f"write_result: {len(points)} points but {len(sources)} source labels")
    write_glb(path, points, source_colours(sources) if colours is None else colours, faces)
