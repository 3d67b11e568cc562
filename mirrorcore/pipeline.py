"""From a depth frame to the object's merged cloud: select the object, smooth its depth (prepare_frame, which the
dense methods share), then Algorithm 1."""
from __future__ import annotations

import numpy as np

from .cloud import Cloud
from .depthops import smooth_depth
from .reconstruct import reconstruct_raw
from .rig import Rig
from .selection import Backdrop, Selection, object_mask


def prepare_frame(rig: Rig, depth: np.ndarray, background: np.ndarray | Backdrop | None,
                  selection: Selection = Selection()) -> tuple[np.ndarray, np.ndarray]:
    """The object's pixels and the depth the reconstruction uses: depth (H, W) float metres, background (H, W) float
    metres or its Backdrop or None -> (depth (H, W) float32 metres, smoothed on the object when selection.smooth;
    mask (H, W) bool)."""
    mask = object_mask(rig.intrinsics, depth, background, selection)
    depth = smooth_depth(depth, mask) if selection.smooth else depth
    return np.asarray(depth, np.float32), mask


def object_cloud(rig: Rig, depth: np.ndarray, background: np.ndarray | Backdrop | None,
                 selection: Selection = Selection()) -> tuple[Cloud, np.ndarray]:
    """The object's source-labelled cloud of one frame, and the object mask it came from.

    depth : (H, W) float metres; background as for prepare_frame -> (Cloud, (H, W) bool mask)
    """
    depth, mask = prepare_frame(rig, depth, background, selection)
    return reconstruct_raw(rig, depth, mask), mask
