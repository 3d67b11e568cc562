"""The pinhole camera's files: Open3D's PinholeCameraIntrinsic JSON and OpenCV's camera YAML."""
from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import yaml

from mirrorcore.base.errors import FileFormatError
from mirrorcore.base.jsonfile import finite_number
from mirrorcore.geometry.camera import Intrinsics

MAX_YAML_BYTES = 1 << 20   # a camera file is a few hundred bytes


# --------------------------------------------------------------------- intrinsics files
def save_open3d_json(intr: Intrinsics, path: str | Path) -> None:
    """Write Open3D's PinholeCameraIntrinsic JSON (column-major intrinsic_matrix).

    Parameters
    ----------
    intr : Intrinsics
        The camera.
    path : str or Path
        The file written.
    """
    data = {"width": intr.width, "height": intr.height,
            "intrinsic_matrix": intr.K.T.reshape(-1).tolist()}
    Path(path).write_text(json.dumps(data, indent=2))


def load_open3d_json(path: str | Path, depth_scale: float = 0.001) -> Intrinsics:
    """Read Open3D's PinholeCameraIntrinsic JSON.

    Parameters
    ----------
    path : str or Path
        The file.
    depth_scale : float
        Metres per unit of the depth images (the file has none).

    Returns
    -------
    Intrinsics

    Raises
    ------
    FileFormatError
        Naming the file.
    """
    try:
        data = json.loads(Path(path).read_text())
        K = np.asarray(data["intrinsic_matrix"], dtype=float).reshape(3, 3).T
        return Intrinsics(int(data["width"]), int(data["height"]), K[0, 0], K[1, 1], K[0, 2],
                          K[1, 2], depth_scale)
    except FileFormatError as exc:
        raise FileFormatError(f"{path}: {exc}") from None
    except (OSError, ValueError, KeyError, TypeError, OverflowError) as exc:
        raise FileFormatError(f"{path}: not an Open3D PinholeCameraIntrinsic JSON "
                              f"({type(exc).__name__}: {exc})") from None


def save_opencv_yaml(intr: Intrinsics, path: str | Path) -> None:
    """Write OpenCV's camera YAML with cv2.FileStorage.

    The keys are camera_matrix, image_width, image_height and depth_scale.

    Parameters
    ----------
    intr : Intrinsics
        The camera.
    path : str or Path
        The file written.
    """
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    try:
        fs.write("image_width", intr.width)
        fs.write("image_height", intr.height)
        fs.write("camera_matrix", intr.K)
        fs.write("depth_scale", intr.depth_scale)
    finally:
        fs.release()


def load_opencv_yaml(path: str | Path, depth_scale: float = 0.001) -> Intrinsics:
    """Read OpenCV's camera YAML (camera_matrix, image_width, image_height, optional depth_scale).

    Parsed with PyYAML's safe loader (after OpenCV's '%YAML:1.0' line and '!!opencv-matrix' tags
    are set aside), not with OpenCV's own parser, which aborts the whole process on damaged bytes.

    Parameters
    ----------
    path : str or Path
        The file (at most MAX_YAML_BYTES).
    depth_scale : float
        Metres per unit of the depth images when the file has no depth_scale.

    Returns
    -------
    Intrinsics

    Raises
    ------
    FileFormatError
        Naming the file: missing, too large, not UTF-8, not an OpenCV YAML file, or without a 3x3
        camera_matrix, image_width and image_height.
    """
    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"{path}: no such file")
    if path.stat().st_size > MAX_YAML_BYTES:
        raise FileFormatError(
            f"{path}: {path.stat().st_size:,} bytes is too large for a camera file")
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
        body = "\n".join(lines[1:] if lines and lines[0].startswith("%YAML") else lines)
        data = yaml.safe_load(body.replace("!!opencv-matrix", ""))
    except UnicodeDecodeError:
        raise FileFormatError(f"{path}: not UTF-8 text") from None
    except (yaml.YAMLError, RecursionError, ValueError) as exc:
        reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise FileFormatError(f"{path}: not an OpenCV YAML file ({reason})") from None
    if not isinstance(data, dict):
        raise FileFormatError(f"{path}: not an OpenCV YAML file (no keys)")
    K = _opencv_matrix(data.get("camera_matrix"))
    w, h = (finite_number(data.get(k)) for k in ("image_width", "image_height"))
    scale = depth_scale if data.get("depth_scale") is None else finite_number(data["depth_scale"])
    if K is None or w is None or h is None or scale is None or w < 1 or h < 1:
        raise FileFormatError(f"{path}: needs camera_matrix (3x3), image_width and image_height")
    try:
        return Intrinsics(int(w), int(h), K[0, 0], K[1, 1], K[0, 2], K[1, 2], scale)
    except FileFormatError as exc:
        raise FileFormatError(f"{path}: {exc}") from None


def _opencv_matrix(node) -> np.ndarray | None:
    """Read an OpenCV YAML 3x3 matrix node as (3, 3) float64, or None."""
    if not isinstance(node, dict) or node.get("rows") != 3 or node.get("cols") != 3:
        return None
    values = node.get("data")
    if not isinstance(values, list) or len(values) != 9:
        return None
    numbers = [finite_number(v) for v in values]
    return None if None in numbers else np.array(numbers, float).reshape(3, 3)
MAX_YAML_BYTES = 1 << 20   # a camera file is a few hundred bytes

