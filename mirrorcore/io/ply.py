"""PLY files of source-labelled clouds and meshes (docs/DESIGN.md layout): binary_little_endian, x y
z float32 (metres, camera frame), red green blue uchar (the scene's colour, or the source colour),
source uchar; faces (vertex_indices, uchar count + int32) for meshes."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from mirrorcore.base.atomic import write_atomic
from mirrorcore.base.budget import check_memory
from mirrorcore.base.errors import FileFormatError
from mirrorcore.base.palette import source_colours

_VERTEX = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"),
                    ("red", "u1"), ("green", "u1"), ("blue", "u1"), ("source", "u1")])
# trimesh holds the file, its parsed vertices and our float32 copy: about 4 times the file
READ_COPIES = 4
_FACE = np.dtype([("count", "u1"), ("vertex_indices", "<i4", (3,))])
# a PLY header longer than this (lines, bytes a line) is damage
_HEADER_LINES, _HEADER_LINE = 200, 1024


def encode_ply(points: np.ndarray, sources: np.ndarray, faces: np.ndarray | None = None,
               colours: np.ndarray | None = None) -> bytes:
    """Encode a labelled cloud, or a mesh with `faces`, as PLY bytes.

    Parameters
    ----------
    points : (n, 3) float array
        Metres, camera frame.
    sources : (n,) integer array
        Labels 0..255 (0 direct, j mirror j, 33.. several mirrors in turn:
        mirrorcore.base.palette).
    faces : (m, 3) integer array, optional
        Vertex indices of triangles.
    colours : (n, 3) uint8 array, optional
        RGB of each vertex (the scene's colour); the source colours without.

    Returns
    -------
    bytes

    Raises
    ------
    ValueError
        Mismatched or out-of-range input.
    """
    points = np.asarray(points, dtype=np.float32).reshape(-1, 3)
    sources = np.asarray(sources).reshape(-1)
    if len(sources) != len(points):
        raise ValueError(f"encode_ply: {len(points)} points but {len(sources)} source labels")
    if len(sources) and (sources.min() < 0 or sources.max() > 255):
        raise ValueError("encode_ply: source labels must be in 0..255")
    colours = (source_colours(sources) if colours is None
               else checked_colours(colours, len(points), "encode_ply"))
    vertex = np.empty(len(points), dtype=_VERTEX)
    vertex["x"], vertex["y"], vertex["z"] = points.T
    vertex["red"], vertex["green"], vertex["blue"] = colours.T
    vertex["source"] = sources
    header = ("ply\nformat binary_little_endian 1.0\ncomment mirrorscan: metres, camera frame "
              "(OpenCV axes); "
              "source 0 = direct, j = mirror j, 33 and up = through several mirrors in turn "
              "(docs/DESIGN.md)\n"
              f"element vertex {len(points)}\n"
              + "".join(f"property {'float' if n in 'xyz' else 'uchar'} {n}\n"
                        for n in _VERTEX.names)
              + ("" if faces is None
                 else f"element face {len(faces)}\nproperty list uchar int vertex_indices\n")
              + "end_header\n")
    return header.encode("ascii") + vertex.tobytes() + (b"" if faces is None
                                                        else _face_bytes(faces, len(points)))


def checked_colours(colours: np.ndarray, n_vertices: int, where: str) -> np.ndarray:
    """Check the vertices' colours of a file being encoded.

    Parameters
    ----------
    colours : (n, 3) array
        RGB levels.
    n_vertices : int
        n.
    where : str
        The encoder, for the message.

    Returns
    -------
    (n, 3) uint8 array

    Raises
    ------
    ValueError
        Not one colour a vertex.
    """
    if np.shape(colours) != (n_vertices, 3):
        raise ValueError(f"{where}: {n_vertices} points but colours of shape {np.shape(colours)}")
    return np.asarray(colours, np.uint8)


def checked_faces(faces: np.ndarray, n_vertices: int, where: str) -> np.ndarray:
    """Check the triangles of a mesh being encoded.

    Parameters
    ----------
    faces : (m, 3) integer array
        Vertex indices.
    n_vertices : int
        The mesh's vertex count.
    where : str
        The encoder, for the message.

    Returns
    -------
    (m, 3) integer array

    Raises
    ------
    ValueError
        An index outside 0..n_vertices - 1.
    """
    faces = np.asarray(faces).reshape(-1, 3)
    if len(faces) and (faces.min() < 0 or faces.max() >= n_vertices):
        raise ValueError(f"{where}: face indices must be in 0..{n_vertices - 1}")
    return faces


def _face_bytes(faces: np.ndarray, n_vertices: int) -> bytes:
    """(m, 3) int triangles -> the binary face element (a uchar 3 then three int32 per face)."""
    faces = checked_faces(faces, n_vertices, "encode_ply")
    face = np.empty(len(faces), dtype=_FACE)
    face["count"] = 3
    face["vertex_indices"] = faces
    return face.tobytes()


def write_ply(path: str | Path, points: np.ndarray, sources: np.ndarray,
              faces: np.ndarray | None = None, colours: np.ndarray | None = None) -> None:
    """Write a labelled cloud, or a mesh with `faces`, atomically (see `encode_ply`).

    Parameters
    ----------
    path : str or Path
        The file written.
    points : (n, 3) float array
        Metres, camera frame.
    sources : (n,) integer array
        Labels 0..255.
    faces : (m, 3) integer array, optional
        Vertex indices of triangles.
    colours : (n, 3) uint8 array, optional
        RGB of each vertex; the source colours without.

    Raises
    ------
    ValueError
        Mismatched or out-of-range input.
    """
    write_atomic(path, encode_ply(points, sources, faces, colours))


def read_ply(path: str | Path) -> tuple[np.ndarray, np.ndarray | None]:
    """Read the vertices of any PLY (ours, Open3D's, MeshLab's...).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    points : (n, 3) float32 array
        The vertices.
    sources : (n,) uint8 array or None
        None when the file has no `source` property.

    Raises
    ------
    FileFormatError
        Naming the file: missing, not a PLY, or broken.
    """
    return read_ply_colours(path)[:2]


def read_ply_colours(path: str | Path) -> tuple[np.ndarray, np.ndarray | None,
                                                np.ndarray | None]:
    """Read the vertices of any PLY with their colours.

    Returns
    -------
    points, sources
        As `read_ply` returns them (which also says what it raises).
    colours : (n, 3) uint8 array or None
        `red green blue`; None when the file has no such properties.
    """
    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"{path}: no such file")
    with open(path, "rb") as f:
        if f.read(3) != b"ply":
            raise FileFormatError(f"{path}: not a PLY file (it does not start with 'ply')")
    check_memory(READ_COPIES * path.stat().st_size, f"{path}: reading the PLY")
    try:
        geometry = trimesh.load(path, file_type="ply", process=False)
        vertex = geometry.metadata["_ply_raw"]["vertex"]["data"]
    # trimesh raises many kinds on broken files; all mean the same to the user
    except Exception as exc:
        raise FileFormatError(f"{path}: broken PLY ({type(exc).__name__}: {exc})") from None
    # ASCII: dict of columns
    names = set(vertex) if isinstance(vertex, dict) else set(vertex.dtype.names or ())
    if not {"x", "y", "z"} <= names:
        raise FileFormatError(f"{path}: the PLY's vertices have no x, y, z")
    points = np.stack([vertex["x"], vertex["y"], vertex["z"]],
                      axis=-1).astype(np.float32).reshape(-1, 3)
    sources = np.asarray(vertex["source"],
                         dtype=np.uint8).reshape(-1) if "source" in names else None
    colours = (np.stack([np.asarray(vertex[c]).reshape(-1) for c in ("red", "green", "blue")],
                        axis=-1).astype(np.uint8) if {"red", "green", "blue"} <= names else None)
    return points, sources, colours


def ply_element_counts(path: str | Path) -> dict[str, int]:
    """Read the element counts of a PLY file's header without loading the data.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    dict of str to int
        {'vertex': n, 'face': m}.

    Raises
    ------
    FileFormatError
        Naming the file: missing, or a header that is not a PLY header.
    """
    path = Path(path)
    counts: dict[str, int] = {}
    try:
        with open(path, "rb") as f:
            if f.readline(_HEADER_LINE) != b"ply\n":
                raise FileFormatError(f"{path}: not a PLY file (it does not start with 'ply')")
            for _ in range(_HEADER_LINES):
                words = f.readline(_HEADER_LINE).split()
                if words == [b"end_header"]:
                    return counts
                if len(words) == 3 and words[0] == b"element":
                    counts[words[1].decode("ascii", "replace")] = int(words[2])
    except FileNotFoundError:
        raise FileFormatError(f"{path}: no such file") from None
    except ValueError:
        raise FileFormatError(
            f"{path}: broken PLY header (an element count is not a number)") from None
    raise FileFormatError(f"{path}: broken PLY header (no end_header)")
