"""Algorithm 1 of the paper: the merged, source-labelled cloud of one depth frame (reproject, then reflect the pixels
seen in a mirror through its plane)."""
from __future__ import annotations

import numpy as np

from .camera import check_depth_shape
from .cloud import Cloud
from .rig import Rig


def reconstruct_raw(rig: Rig, depth: np.ndarray, mask: np.ndarray | None = None) -> Cloud:
    """Paper Algorithm 1, vectorised.

    A pixel inside mirror j's boundary whose point lies behind plane j (n.P + d < 0) is reflected through plane j
    (paper eq. 3) and labelled j; mirrors are tried in session order and the first that applies wins (the algorithm's
    `break`). Every other pixel is direct (label 0), including pixels inside a boundary but in front of its mirror
    (the real object, a marker on the glass). Pixels inside the boundary of a mirror with no plane yet are left out
    unless an earlier mirror took them: their true position is unknown.

    depth : (H, W) float metres, 0 = no reading; mask : optional (H, W) bool, the pixels to use (the object)
    returns the Cloud of the used pixels with a reading, in row-major pixel order.
    """
    intr = rig.intrinsics
    depth = check_depth_shape(intr, depth)
    keep = depth > 0 if mask is None else (mask & (depth > 0))
    index = np.flatnonzero(keep)
    # points as three contiguous rows (3, n): numpy's per-row products are several times faster than on (n, 3)
    xyz = np.empty((3, len(index)), dtype=np.float32)
    xyz[2] = depth.reshape(-1)[index]
    rays = intr.rays.reshape(2, -1)
    xyz[0] = rays[0, index] * xyz[2]
    xyz[1] = rays[1, index] * xyz[2]
    sources = np.zeros(len(index), dtype=np.uint8)
    bits = rig.inside_bits.reshape(-1)[index]
    unassigned = np.ones(len(index), dtype=bool)
    for j, mirror in enumerate(rig.mirrors, start=1):
        if mirror.plane is None:
            continue
        n = mirror.plane.n.astype(np.float32)
        distance = n[0] * xyz[0] + n[1] * xyz[1] + n[2] * xyz[2] + np.float32(mirror.plane.d)
        reflect = unassigned & (distance < 0) & ((bits >> np.uint32(j - 1)) & np.uint32(1)).astype(bool)
        step = np.where(reflect, np.float32(-2) * distance, np.float32(0))  # eq. 3, zero where not reflected
        for k in range(3):
            xyz[k] += step * n[k]
        sources += reflect.view(np.uint8) * np.uint8(j)
        unassigned &= ~reflect
    if rig.uncalibrated_bits:
        kept = ~unassigned | ((bits & np.uint32(rig.uncalibrated_bits)) == 0)
        return Cloud(xyz.T[kept], sources[kept], index[kept], intr.width)
    return Cloud(xyz.T, sources, index, intr.width)
