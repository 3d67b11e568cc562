"""What the depth view shows: the depth frame colourised, with the object mask, the mirrors' boundaries and their
numbered markers drawn over it (OpenCV), as an RGB image for the browser."""
from __future__ import annotations

from typing import Sequence

import cv2
import numpy as np

from mirrorcore.palette import source_colour
from mirrorcore.session import SessionMirror


def colourise_depth(depth: np.ndarray, near: float, far: float) -> np.ndarray:
    """(H, W) metres -> (H, W, 3) uint8 RGB, turbo colour map from `near` (red) to `far` (blue); no reading is black."""
    scaled = np.clip((far - depth) / max(far - near, 1e-6), 0, 1)
    rgb = cv2.applyColorMap((scaled * 255).astype(np.uint8), cv2.COLORMAP_TURBO)[..., ::-1]
    rgb[depth <= 0] = 0
    return np.ascontiguousarray(rgb)


def draw_mask(rgb: np.ndarray, mask: np.ndarray, alpha: float = 0.55) -> np.ndarray:
    """Lighten the object's pixels (mask : (H, W) bool) so the selection shows over the depth colours (in place)."""
    rgb[mask] = (rgb[mask] * (1 - alpha) + 255 * alpha).astype(np.uint8)
    return rgb


def draw_polygon(rgb: np.ndarray, vertices, colour, closed: bool, selected: int | None = None) -> np.ndarray:
    """A polygon's edges (closed or still open) and its corners, the selected corner ringed in white (in place)."""
    if not len(vertices):
        return rgb
    pts = np.round(np.asarray(vertices, dtype=float)).astype(np.int32).reshape(-1, 1, 2)
    if len(vertices) >= 2:
        cv2.polylines(rgb, [pts], closed, colour, 2, cv2.LINE_AA)
    for k, (u, v) in enumerate(pts.reshape(-1, 2)):
        cv2.circle(rgb, (int(u), int(v)), 3 if closed else 4, colour, -1, cv2.LINE_AA)
        if k == selected:
            cv2.circle(rgb, (int(u), int(v)), 8, (255, 255, 255), 2, cv2.LINE_AA)
    return rgb


def draw_markers(rgb: np.ndarray, markers, colour, mirror_number: int) -> np.ndarray:
    """Numbered markers 'j.k' (mirror j, marker k) as rings in the mirror's colour (in place)."""
    for k, (u, v) in enumerate(markers, start=1):
        centre = (int(round(u)), int(round(v)))
        cv2.circle(rgb, centre, 6, (255, 255, 255), 2, cv2.LINE_AA)
        cv2.circle(rgb, centre, 6, colour, 1, cv2.LINE_AA)
        cv2.putText(rgb, f"{mirror_number}.{k}", (centre[0] + 8, centre[1] - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                    (255, 255, 255), 1, cv2.LINE_AA)
    return rgb


def draw_mirrors(rgb: np.ndarray, mirrors: Sequence[SessionMirror], drafts: dict | None = None,
                 selected_vertex: tuple[int, int] | None = None) -> np.ndarray:
    """Each mirror's boundary (its open draft while one is drawn) and numbered markers, in the mirror's source colour.
    drafts : {mirror index: vertices}; selected_vertex : (mirror index, vertex index) to ring (in place)."""
    drafts = drafts or {}
    for i, mirror in enumerate(mirrors):
        colour = tuple(int(c) for c in source_colour(i + 1))
        closed = i not in drafts
        picked = selected_vertex[1] if selected_vertex and selected_vertex[0] == i else None
        draw_polygon(rgb, mirror.boundary if closed else drafts[i], colour, closed, picked)
        draw_markers(rgb, mirror.markers, colour, i + 1)
    return rgb
