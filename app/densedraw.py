"""How a dense result is drawn in a tab's 3D scene: a carving's points shaded by their outward
normals under two fixed lights (so that a carved sphere reads round from any side it is turned to),
a fusion's mesh lit by the scene's lights; each in the result's colours where it has them, else in
the dense result's own colour."""
from __future__ import annotations

import numpy as np
import trimesh
import viser

from .results import DenseResult

DENSE_COLOUR = (120, 200, 190)   # the dense result's own colour (a pale teal, unlike any source)
# Lights of the points, towards the light in the camera frame (x right, y down, z away): a key
# light from above, left and the camera's side; a fill light from below, right and behind (the
# side the mirrors see).
KEY_LIGHT = np.array([-0.4, -0.7, -0.6]) / np.linalg.norm([-0.4, -0.7, -0.6])
FILL_LIGHT = np.array([0.6, 0.3, 0.75]) / np.linalg.norm([0.6, 0.3, 0.75])
AMBIENT, KEY, FILL = 0.25, 0.65, 0.3
# the shade of a point without a normal
UNLIT = 0.75
# a point's disc, as large as the voxel times this (the discs overlap: no gaps between voxels)
POINT_SCALE = 1.3


def shade(normals: np.ndarray | None, colours: np.ndarray | None, count: int) -> np.ndarray:
    """Return the points' colours lit by KEY_LIGHT and FILL_LIGHT over an AMBIENT light.

    Lambert's law: each light adds its strength times the cosine between a normal and it.

    Parameters
    ----------
    normals : (n, 3) float array or None
        Unit normals, camera frame; a zero normal (or None) is drawn UNLIT.
    colours : (n, 3) uint8 array or None
        The points' own colours (None: DENSE_COLOUR).
    count : int
        n.

    Returns
    -------
    (n, 3) uint8 array
    """
    if normals is None:
        light = np.full(count, UNLIT)
    else:
        normals = np.asarray(normals, np.float64)
        light = (AMBIENT + KEY * np.clip(normals @ KEY_LIGHT, 0, None)
                 + FILL * np.clip(normals @ FILL_LIGHT, 0, None))
        light = np.where(np.any(normals != 0, axis=1), np.minimum(light, 1.0), UNLIT)
    base = (np.broadcast_to(np.asarray(DENSE_COLOUR, np.float64), (count, 3)) if colours is None
            else np.asarray(colours, np.float64))
    return np.rint(base * light[:, None]).astype(np.uint8)


def draw_dense(scene: viser.SceneApi, name: str, result: DenseResult):
    """Add a dense result's node: shaded points for a carving, a lit mesh for a fusion.

    Parameters
    ----------
    scene : viser.SceneApi
        The tab's scene.
    name : str
        The node's name.
    result : DenseResult

    Returns
    -------
    viser.PointCloudHandle or viser.MeshHandle
    """
    vertices = np.ascontiguousarray(result.vertices, np.float32)
    if result.faces is None:
        colours = shade(result.normals, result.colours, len(vertices))
        return scene.add_point_cloud(name, vertices, colours, point_size=result.voxel * POINT_SCALE,
                                     precision="float32", point_shape="circle",
                                     point_shading="flat")
    faces = np.asarray(result.faces, np.uint32)
    if result.colours is None:
        return scene.add_mesh_simple(name, vertices, faces, color=DENSE_COLOUR)
    mesh = trimesh.Trimesh(vertices, faces, vertex_colors=result.colours, process=False)
    return scene.add_mesh_trimesh(name, mesh)
