"""The live cloud as it travels to a browser tab: at most MAX_POINTS points a frame, one part per source (a single
colour each), positions as float16 offsets from the part's centre (6 bytes a point instead of 12) wherever that
keeps every point within 0.3 mm; float32 where a part is too large for it."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirrorcore.cloud import Cloud

MAX_POINTS = 60_000          # points sent per frame, all sources together (evenly strided)
FLOAT16_EXTENT = 1.0         # metres: offsets below this round to float16 within 2^-12 m (0.24 mm)


@dataclass(frozen=True, eq=False)
class SourcePart:
    """One source's points of a frame: centre (3,) float64 metres, camera frame; offsets (n, 3) float16 (or float32)
    metres from the centre."""

    source: int
    centre: np.ndarray
    offsets: np.ndarray


def downsample(cloud: Cloud, max_points: int) -> Cloud:
    """Every k-th point so that at most max_points remain (the order is row-major, so this thins evenly)."""
    step = max(1, int(np.ceil(len(cloud) / max_points)))
    return cloud if step == 1 else cloud.select(slice(None, None, step))


def stream_parts(cloud: Cloud, n_sources: int, max_points: int = MAX_POINTS) -> list[SourcePart]:
    """The parts of sources 0..n_sources-1 (empty ones included, so that a source that left the view is cleared)."""
    cloud = downsample(cloud, max_points)
    order = np.argsort(cloud.sources, kind="stable")
    bounds = np.searchsorted(cloud.sources[order], np.arange(n_sources + 1))
    parts = []
    for j in range(n_sources):
        points = cloud.points[order[bounds[j]:bounds[j + 1]]]
        if not len(points):
            parts.append(SourcePart(j, np.zeros(3), np.zeros((0, 3), np.float16)))
            continue
        centre = (points.min(axis=0).astype(np.float64) + points.max(axis=0)) / 2
        offsets = points - centre.astype(np.float32)
        small = np.abs(offsets).max() < FLOAT16_EXTENT
        parts.append(SourcePart(j, centre, offsets.astype(np.float16 if small else np.float32)))
    return parts
