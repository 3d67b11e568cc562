"""From a depth frame to the object's merged cloud: select the object, smooth its depth, run Algorithm 1."""
from __future__ import annotations

import numpy as np

from .cloud import Cloud
from .depthops import smooth_depth
from .reconstruct import reconstruct_raw
from .rig import Rig
from .selection import Selection, object_mask
from .session import Session


def object_cloud(rig: Rig, depth: np.ndarray, background: np.ndarray | None,
                 selection: Selection = Selection()) -> tuple[Cloud, np.ndarray]:
    """The object's source-labelled cloud of one frame, and the object mask it came from.

    depth, background : (H, W) float metres (background may be None) -> (Cloud, (H, W) bool mask)
    """
    mask = object_mask(rig.intrinsics, depth, background, selection)
    if selection.smooth:
        depth = smooth_depth(depth, mask)
    return reconstruct_raw(rig, depth, mask), mask


def session_selection(session: Session) -> Selection:
    """The session's object selection (session.json key 'selection'), defaults where it says nothing."""
    return Selection.from_json(session.extra.get("selection"), f"{session.path}: selection")
