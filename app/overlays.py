"""What the depth view shows: the depth frame colourised, with the object mask, the mirrors' boundaries and their
numbered markers drawn over it (OpenCV), as an RGB image for the browser."""
from __future__ import annotations

from typing import Sequence

import cv2
import numpy as np

from mirrorcore.palette import source_color
from mirrorcore.session import MirrorSpec


def colorize_depth(depth: np.ndarray, near: float, far: float) -> np.ndarray:
    """(H, W) metres -> (H, W, 3) uint8 RGB, turbo colour map from `near` (red) to `far` (blue); no reading is black."""
    scaled = np.clip((far - depth) / max(far - near, 1e-6), 0, 1)
    rgb = cv2.applyColorMap((scaled * 255).astype(np.uint8), cv2.COLORMAP_TURBO)[..., ::-1]
    rgb[depth <= 0] = 0
    return np.ascontiguousarray(rgb)


def draw_mask(rgb: np.ndarray, mask: np.ndarray, alpha: float = 0.55) -> np.ndarray:
    """Lighten the object's pixels (mask : (H, W) bool) so the selection shows over the depth colours (in place)."""
    rgb[mask] = (rgb[mask] * (1 - alpha) + 255 * alpha).astype(np.uint8)
    return rgb


def draw_mirrors(rgb: np.ndarray, mirrors: Sequence[MirrorSpec]) -> np.ndarray:
    """Draw each mirror's boundary (closed polygon) and numbered markers in the mirror's source colour (in place)."""
    for j, mirror in enumerate(mirrors, start=1):
        colour = tuple(int(c) for c in source_color(j))
        if len(mirror.boundary) >= 2:
            pts = np.round(np.asarray(mirror.boundary)).astype(np.int32).reshape(-1, 1, 2)
            cv2.polylines(rgb, [pts], len(mirror.boundary) >= 3, colour, 2, cv2.LINE_AA)
        for k, (u, v) in enumerate(mirror.markers, start=1):
            centre = (int(round(u)), int(round(v)))
            cv2.circle(rgb, centre, 5, (255, 255, 255), 2, cv2.LINE_AA)
            cv2.circle(rgb, centre, 5, colour, 1, cv2.LINE_AA)
            cv2.putText(rgb, f"{j}.{k}", (centre[0] + 7, centre[1] - 5), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                        (255, 255, 255), 1, cv2.LINE_AA)
    return rgb
