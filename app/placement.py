"""Where things stand in a tab's 3D scene: the rig's views and their names, the first view's
pose, the dense result's box and place beside the live cloud. Pure geometry, in metres, in the
depth camera's frame (up is -y)."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from mirrorcore.geometry.camera import Intrinsics, pixels_on_plane
from mirrorcore.rig.model import Rig

if TYPE_CHECKING:
    from .jobs import DenseResult

FRUSTUM_SCALE = 0.15       # metres: the depth camera and the virtual cameras, drawn small
# a virtual camera's name stands this many of its frustum's sizes above it: seen from home, above
# the mirror's name and clear of the object
VIRTUAL_LABEL_RISE = 1.2
# metres: virtual cameras closer than this share one label (hinged mirrors at 360 / n degrees put
# the images through two and three mirrors within a few cm of each other)
SAME_PLACE = 0.10
# from the scene's centre towards the first view (right, up, front): from behind the depth camera,
# 33 degrees from above, so that every virtual camera is in view (none behind the panel on the
# right) and above the object
HOME_DIRECTION = np.array([0.0, -0.9, -1.4])
CAMERA_LABEL = (0.0, FRUSTUM_SCALE, 0.0)   # metres: the depth camera's name, under it (y down)
MIN_DISTANCE = 0.3         # metres: the first view stands at least this far from what it frames
# a virtual camera's name through several mirrors, this much smaller: they stand between the others
# and must not run into each other at 1024x600
SEQUENCE_FONT = 0.85


def frustum_angles(intr: Intrinsics) -> tuple[float, float]:
    """A camera's vertical field of view and aspect ratio.

    Parameters
    ----------
    intr : Intrinsics

    Returns
    -------
    fov : float
        Radians.
    aspect : float
        Width / height.
    """
    return 2 * np.arctan2(intr.height / 2, intr.fy), intr.width / intr.height


def same_place(cameras: list) -> list[list]:
    """Virtual cameras grouped by place: each group those within SAME_PLACE of its first.

    Parameters
    ----------
    cameras : list
        rig.virtual_cameras' items.

    Returns
    -------
    list of list
        The groups, in the given order.
    """
    groups: list[list] = []
    for camera in cameras:
        for group in groups:
            if np.linalg.norm(group[0].pose[:3, 3] - camera.pose[:3, 3]) < SAME_PLACE:
                group.append(camera)
                break
        else:
            groups.append([camera])
    return groups


def frustum_scale(camera) -> float:
    """A virtual camera's frustum size: the depth camera's through one mirror, else smaller.

    Parameters
    ----------
    camera
        A rig.virtual_cameras item.

    Returns
    -------
    float
        Metres.
    """
    return FRUSTUM_SCALE * (1.0 if len(camera.sequence) == 1 else 0.7)


def mirror_outline(intr: Intrinsics, mirror) -> np.ndarray | None:
    """A calibrated mirror's boundary lifted onto its plane.

    Parameters
    ----------
    intr : Intrinsics
    mirror
        A rig mirror, with its plane and boundary (pixels).

    Returns
    -------
    np.ndarray, shape (b, 3), or None
        Metres; None without a plane or a boundary, or when a corner's ray misses the plane.
    """
    if mirror.plane is None or mirror.boundary is None:
        return None
    outline = pixels_on_plane(intr, mirror.boundary, mirror.plane)
    return outline if np.all(np.isfinite(outline)) else None


def label_anchor(outline: np.ndarray) -> np.ndarray:
    """Where a mirror's name goes: the middle of its outline's two highest corners (up is -y).

    That is the top edge's middle for a pane, and apart for two mirrors hinged at a shared top
    corner.

    Parameters
    ----------
    outline : (b, 3) ndarray
        Metres.

    Returns
    -------
    (3,) ndarray
        Metres.
    """
    return outline[np.argsort(outline[:, 1], kind="stable")[:2]].mean(axis=0)


def virtual_label_anchor(camera) -> np.ndarray:
    """Where a virtual camera's name goes.

    VIRTUAL_LABEL_RISE of its frustum's size above it (along -y of its pose, the camera's up: a
    vertical mirror keeps it the world's), or as far below it for a camera through several mirrors,
    so that their names do not stack on those of the cameras through one mirror beside them.

    Parameters
    ----------
    camera
        A rig.virtual_cameras item.

    Returns
    -------
    np.ndarray, shape (3,)
        Metres.
    """
    rise = VIRTUAL_LABEL_RISE * frustum_scale(camera) * (-1.0 if len(camera.sequence) > 1 else 1.0)
    # up is -y
    return camera.pose[:3, 3] - rise * camera.pose[:3, 1]


def virtual_label_sides(cameras: list) -> list[str]:
    """Which corner of each virtual camera's name sits at its anchor (viser's label anchor).

    Centred on the camera, but the leftmost's runs right and the rightmost's left, towards the rig,
    so that no name runs off the 3D view and the names of the cameras between do not run into each
    other. See virtual_label_anchor.

    Parameters
    ----------
    cameras : list
        rig.virtual_cameras' items.

    Returns
    -------
    list of str
        'top-...' for a camera through several mirrors, else 'bottom-...', then 'left', 'center'
        or 'right'.
    """
    xs = [float(camera.pose[0, 3]) for camera in cameras]
    sides = ["center"] * len(xs)
    if xs:
        left, right = int(np.argmin(xs)), int(np.argmax(xs))
        if xs[left] < 0:
            sides[left] = "left"
        if xs[right] > 0:
            sides[right] = "right"
    return [("top-" if len(camera.sequence) > 1 else "bottom-") + side
            for camera, side in zip(cameras, sides)]


def scene_points(rig: Rig) -> np.ndarray:
    """The points the first view must show.

    The camera and its name, the mirrors' corners, where the object is expected (in front of the
    mirrors, on the optical axis at 2 m without them), and the virtual cameras with their names'
    anchors.

    Parameters
    ----------
    rig : Rig

    Returns
    -------
    np.ndarray, shape (k, 3)
        Metres.
    """
    outlines = [o for o in (mirror_outline(rig.intrinsics, m) for m in rig.mirrors)
                if o is not None]
    points = [np.array([(0.0, 0.0, 0.0), CAMERA_LABEL])] + outlines
    centres = [o.mean(axis=0) for o in outlines]
    points.append((0.85 * np.mean(centres, axis=0) if centres else np.array([0.0, 0.0, 2.0]))[None])
    cameras = [camera for camera in rig.virtual_cameras() if camera.sequence]
    points += [np.array([camera.pose[:3, 3], virtual_label_anchor(camera)]) for camera in cameras]
    return np.concatenate(points)


def box_edges(half: np.ndarray) -> np.ndarray:
    """The edges of a box centred at the origin.

    Parameters
    ----------
    half : np.ndarray, shape (3,)
        Its half-sizes (metres).

    Returns
    -------
    np.ndarray, shape (12, 2, 3), float32
        Each edge's two ends (metres).
    """
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    pairs = [(i, j) for i in range(8) for j in range(i + 1, 8)
             if np.count_nonzero(corners[i] != corners[j]) == 1]
    return (corners[np.array(pairs)] * np.asarray(half, float)).astype(np.float32)


def beside_offset(result: DenseResult) -> np.ndarray:
    """Where the dense result is drawn beside the live cloud.

    One box width to the left (-x) and one box depth towards the camera (-z), with 10 cm between.

    Parameters
    ----------
    result : DenseResult

    Returns
    -------
    np.ndarray, shape (3,)
        The shift, metres.
    """
    size = np.asarray(result.high) - np.asarray(result.low)
    return np.array([-(size[0] + 0.1), 0.0, -(size[2] + 0.1)])


def home_pose(points: np.ndarray, fov: float, aspect: float,
              margin: float = 1.1) -> tuple[np.ndarray, np.ndarray]:
    """The camera pose that frames `points`, looking from HOME_DIRECTION.

    It looks at the middle of their bounding box, up -y, as near as keeps every point inside the
    view's middle 1 / `margin`.

    Parameters
    ----------
    points : (k, 3) ndarray
        Metres.
    fov : float
        The view's vertical field of view, radians.
    aspect : float
        Its width / height.
    margin : float
        At least 1.

    Returns
    -------
    position, look_at : (3,) ndarray
        Metres. The camera stands at least MIN_DISTANCE from the look-at point.
    """
    centre = (points.min(axis=0) + points.max(axis=0)) / 2
    direction = HOME_DIRECTION / np.linalg.norm(HOME_DIRECTION)
    right = np.cross(-direction, [0.0, -1.0, 0.0])
    right /= np.linalg.norm(right)
    down = np.cross(-direction, right)
    half_height = np.tan(fov / 2) / margin
    offsets = points - centre
    # a point at `offsets` is in view from `distance` along `direction` when its sideways offset is
    # within the half-width times its depth (distance - offsets . direction)
    needed = np.maximum(np.abs(offsets @ right) / (half_height * aspect),
                        np.abs(offsets @ down) / half_height)
    distance = max(float(np.max(needed + offsets @ direction)), MIN_DISTANCE)
    return centre + distance * direction, centre
