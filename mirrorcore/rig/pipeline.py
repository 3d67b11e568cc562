"""From a depth frame to the object's merged cloud: select the object, smooth its depth
(prepare_frame, which the dense methods share), then Algorithm 1."""
from __future__ import annotations

import numpy as np

from mirrorcore.rig.cloud import Cloud
from mirrorcore.depth.ops import local_quadratic_depth, smooth_depth
from mirrorcore.base.palette import source_orders
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.rig.model import Rig
from mirrorcore.depth.selection import Backdrop, Selection, object_mask


def prepare_frame(rig: Rig, depth: np.ndarray, background: np.ndarray | Backdrop | None,
                  selection: Selection = Selection()) -> tuple[np.ndarray, np.ndarray]:
    """The object's pixels and the depth the reconstruction uses.

    Parameters
    ----------
    rig : Rig
    depth : (H, W) float
        Metres, as measured.
    background : (H, W) float, Backdrop or None
        Metres, the scene without the object, or its Backdrop.
    selection : Selection
        How the object is found.

    Returns
    -------
    depth : (H, W) float32
        Metres, smoothed on the object when selection.smooth.
    mask : (H, W) bool
        The object's pixels.
    """
    mask = object_mask(rig.intrinsics, depth, background, selection)
    if selection.smooth:
        smoothed = smooth_depth(depth, mask)
        depth = _smooth_through_mirrors(rig, depth, smoothed,
                                        mask) if len(rig.reflection_table.chains) else smoothed
    return np.asarray(depth, np.float32), mask


def object_masks(rig: Rig, depths: np.ndarray, background: np.ndarray | Backdrop | None,
                 selection: Selection = Selection()) -> np.ndarray:
    """The object's pixels in each of several frames: prepare_frame's masks, no depth smoothed.

    Parameters
    ----------
    rig : Rig
    depths : (F, H, W) float
        Metres, as measured.
    background : (H, W) float, Backdrop or None
        Metres, the scene without the object, or its Backdrop.
    selection : Selection
        How the object is found.

    Returns
    -------
    (F, H, W) bool array
    """
    return np.stack([object_mask(rig.intrinsics, d, background, selection) for d in depths])


def _smooth_through_mirrors(rig: Rig, depth: np.ndarray, smoothed: np.ndarray,
                            mask: np.ndarray) -> np.ndarray:
    """The object's pixels seen through two or more mirrors, fitted by local quadratic surfaces over
    the pixels of their own view (depthops.local_quadratic_depth), the others as smoothed: their
    (virtual) depths are longer, so a structured-light camera's noise is larger there (1.3 to 1.6
    times at 60 to 90 degrees between two mirrors), and a fit over 9 x 9 pixels brings them to the
    error of the views through one mirror where an average over as many
    would sag on curved surfaces. depth, smoothed : (H, W) float metres, raw and smooth_depth's;
    mask : (H, W) bool -> (H, W) float32 metres."""
    cloud = reconstruct_raw(rig, smoothed, mask)
    through = source_orders(cloud.sources) >= 2
    if not through.any():
        return smoothed
    labels = np.full(mask.shape, -1, np.int32)
    labels.reshape(-1)[cloud.pixel_index] = cloud.sources
    return local_quadratic_depth(depth, smoothed, cloud.pixel_index[through], labels)


def object_cloud(rig: Rig, depth: np.ndarray, background: np.ndarray | Backdrop | None,
                 selection: Selection = Selection(),
                 colour: np.ndarray | None = None) -> tuple[Cloud, np.ndarray]:
    """The object's source-labelled cloud of one frame, and the object mask it came from.

    Parameters
    ----------
    rig, depth, background, selection
        As for prepare_frame.
    colour : (H, W, 3) uint8, optional
        The frame's colour registered to the depth image (see reconstruct_raw).

    Returns
    -------
    cloud : Cloud
    mask : (H, W) bool
    """
    depth, mask = prepare_frame(rig, depth, background, selection)
    return reconstruct_raw(rig, depth, mask, colour), mask
