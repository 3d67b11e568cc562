"""What the depth frame shows, in two layers: the frame itself (depth in grey, near bright, the
object tinted), made once per frame and shared by every tab, and a tab's overlay (mirror outlines,
numbered markers coloured by their residual, drafts, picks), redrawn only when what it shows
changes. Drawn with OpenCV as RGB images for the browser."""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mirrorcore.depth.ops import masked_copy

# the object's pixels, a warm light yellow over the grey depth
OBJECT_TINT = np.array([255, 214, 120], np.float32)
NO_READING = (24, 24, 32)                             # pixels with no depth reading
HALO = (16, 16, 16)                                   # dark edge under every line and mark
WHITE = (255, 255, 255)
QUALITY_COLOURS = {"good": (60, 200, 80), "fair": (255, 176, 0), "poor": (235, 50, 40),
                   "unknown": (235, 235, 235)}
FONT = cv2.FONT_HERSHEY_SIMPLEX
MARKER_HALO = 8                                       # pixels: the radius of a marker's dark disc
HANDLE_RADIUS = 4                                     # pixels: an outline corner's coloured disc
# pixels: how much farther a label's second places are
LABEL_STEP = 8
# the shaded relief of the depth frame (relief): grey levels a surface turned fully to the light
# gains, the light's direction (camera axes: x right, y down, z forward; from the surface towards
# it), the box (pixels) the depth is smoothed over, and the focal length (pixels) of a Kinect v1
RELIEF_GAIN = 70.0
RELIEF_LIGHT = np.array([-0.5, -0.8, -1.0])
RELIEF_SMOOTH = 15
RELIEF_FOCAL = 580.0


def depth_range(depth: np.ndarray) -> tuple[float, float]:
    """The depth frame's grey scale: the 1st and 99th percentiles of its readings.

    Read on a 1-in-16 sample.

    Parameters
    ----------
    depth : np.ndarray, shape (H, W)
        Metres; 0 where there is no reading.

    Returns
    -------
    near, far : float
        Metres; (0.5, 4.5) without readings. `far` is at least 1 cm beyond `near`.
    """
    sample = depth[::4, ::4]
    valid = sample[sample > 0]
    if not len(valid):
        return 0.5, 4.5
    near, far = np.percentile(valid, [1, 99])
    return float(near), float(max(far, near + 0.01))


# The object's tint of each grey level: 45 % grey, 55 % OBJECT_TINT (cv2.addWeighted's rounding).
TINTED = np.clip(np.rint(0.45 * np.arange(256)[:, None] + 0.55 * OBJECT_TINT), 0, 255).astype(
    np.uint8)


def relief(depth: np.ndarray, focal: float = RELIEF_FOCAL) -> np.ndarray:
    """Shaded relief of the depth frame: how much more or less light each pixel's surface takes.

    The surface's normal comes from the depth's gradients (Sobel on the depth smoothed over its
    readings only, so that holes leave no rim), as metric slopes (dz/du * focal / z); the light
    comes from above and to the left of the camera (RELIEF_LIGHT). A surface facing the camera
    squarely gets 0; one turned towards the light up to about +1, away from it down to about -1.
    A crease where two surfaces of the same depth meet (the floor and its reflection at a mirror's
    foot) shows, as does a step in depth (a dark or bright rim).

    Parameters
    ----------
    depth : np.ndarray, shape (H, W), float
        Metres; 0 where there is no reading.
    focal : float, optional
        The camera's focal length, pixels.

    Returns
    -------
    np.ndarray, shape (H, W), float32
        0 where there is no reading.
    """
    depth = depth.astype(np.float32, copy=False)
    size = (RELIEF_SMOOTH, RELIEF_SMOOTH)
    weight = cv2.max(cv2.blur((depth > 0).astype(np.float32), size), 1e-6)
    smooth = cv2.divide(cv2.blur(depth, size), weight)
    # Sobel's 3x3 kernel sums 8 pixels' differences: slopes as dz/du * focal / z
    scale = cv2.divide(focal / 8.0, cv2.max(smooth, 1e-3))
    slope_u = cv2.multiply(cv2.Sobel(smooth, cv2.CV_32F, 1, 0, ksize=3), scale)
    slope_v = cv2.multiply(cv2.Sobel(smooth, cv2.CV_32F, 0, 1, ksize=3), scale)
    lx, ly, lz = (float(c) for c in RELIEF_LIGHT / np.linalg.norm(RELIEF_LIGHT))
    # the unit normal (slope_u, slope_v, -1) / n against the light, less a square-on surface's
    norm = cv2.magnitude(cv2.magnitude(slope_u, slope_v), np.ones_like(slope_u))
    shade = cv2.divide(cv2.addWeighted(slope_u, lx, slope_v, ly, -lz), norm)
    shade = cv2.add(shade, lz)
    shade[depth <= 0] = 0.0
    return shade


def depth_layer(depth: np.ndarray, mask: np.ndarray, near: float, far: float,
                focal: float = RELIEF_FOCAL) -> np.ndarray:
    """The depth frame as the tab shows it: grey from white (near) to dark (far), in relief.

    The grey of the depth plus RELIEF_GAIN times its shaded relief (`relief`): edges of depth and
    creases show on any background. The object's pixels are tinted (looked up in TINTED, only where
    the mask holds); no reading is dark blue-black.

    Parameters
    ----------
    depth : (H, W) ndarray
        Metres; 0 where there is no reading.
    mask : (H, W) bool ndarray
        The object.
    near, far : float
        Metres: the grey scale's ends (depth_range).
    focal : float, optional
        The camera's focal length, pixels.

    Returns
    -------
    (H, W, 3) uint8 ndarray
        RGB.
    """
    scale = 215.0 / max(far - near, 1e-6)
    # near -> 235, far -> 20, then lit or shaded
    lit = cv2.addWeighted(depth.astype(np.float32, copy=False), -scale, relief(depth, focal),
                          RELIEF_GAIN, 235.0 + near * scale)
    # clipped to 0 below (convertScaleAbs takes absolute values), saturated above
    grey = cv2.convertScaleAbs(cv2.max(lit, 0.0))
    none = depth <= 0
    channels = []
    for c in range(3):
        channel = grey.copy()
        masked_copy(cv2.LUT(grey, TINTED[:, c]), mask, channel)
        channel[none] = NO_READING[c]
        channels.append(channel)
    return cv2.merge(channels)


@dataclass(frozen=True)
class MarkerMark:
    """A marker as drawn.

    Attributes
    ----------
    uv : tuple of float
        Its pixel (u, v).
    label : str
        '2.3'.
    quality : str
        What colours its centre: 'good', 'fair', 'poor' or 'unknown'.
    picked : bool
        Ringed.
    flagged : bool
        Crossed: flagged by a fit proposal.
    """

    uv: tuple[float, float]
    label: str
    quality: str = "unknown"
    picked: bool = False
    flagged: bool = False


@dataclass(frozen=True)
class MirrorMarks:
    """One mirror as drawn.

    Attributes
    ----------
    colour : tuple of int
        RGB.
    outline : tuple of (float, float)
        Its vertices, pixels.
    closed : bool
        False for an open draft.
    markers : tuple of MarkerMark
    picked_corner : int or None
    selected : bool
        Drawn wider, on top.
    """

    colour: tuple[int, int, int]
    outline: tuple[tuple[float, float], ...]
    closed: bool
    markers: tuple[MarkerMark, ...] = ()
    picked_corner: int | None = None
    selected: bool = False


class Overlay:
    """A tab's overlay image, drawn from its marks.

    Labels are placed so that they do not cover each other or a marker.

    Parameters
    ----------
    shape : tuple of int
        (H, W) of the depth frame.

    Attributes
    ----------
    image : np.ndarray, shape (H, W, 4), uint8
        RGBA.
    """

    def __init__(self, shape: tuple[int, int]):
        self.image = np.zeros((*shape, 4), np.uint8)
        self._labels: list[tuple[int, int, int, int]] = []
        # the image's colours and where it is drawn (alpha), as OpenCV's masked copy takes them
        self._rgb = np.zeros((*shape, 3), np.uint8)
        self._drawn = np.zeros(shape, np.uint8)

    def over(self, base: np.ndarray) -> np.ndarray:
        """The overlay over the base image: the drawn pixels copied over.

        Parameters
        ----------
        base : np.ndarray, shape (H, W, 3), uint8

        Returns
        -------
        np.ndarray, shape (H, W, 3), uint8
            A new image.
        """
        out = base.copy()
        cv2.copyTo(self._rgb, self._drawn, out)
        return out

    def draw(self, mirrors: list[MirrorMarks],
             region: tuple[tuple[tuple[float, float], ...], bool] | None) -> None:
        """Redraw everything: the mirrors (selected last, on top) and the region of interest.

        Markers are drawn above every outline, labels last of all.

        Parameters
        ----------
        mirrors : list of MirrorMarks
        region : (vertices, closed) or None
            The region of interest: its vertices (pixels) and whether it is closed.
        """
        self.image[:] = 0
        self._labels = []
        ordered = sorted(mirrors, key=lambda m: m.selected)
        for mirror in ordered:
            width = 3 if mirror.selected else 2
            self._polygon(mirror.outline, mirror.colour, mirror.closed, mirror.picked_corner, width)
        if region is not None:
            self._polygon(region[0], WHITE, region[1], None, 2)
        # markers above every outline, labels last of all
        for mirror in ordered:
            for marker in mirror.markers:
                self._marker(marker, mirror.colour)
        self._labels = [_marker_box(marker.uv) for mirror in ordered for marker in mirror.markers]
        for mirror in ordered:
            for marker in mirror.markers:
                self._label(marker.uv, marker.label)
        self._rgb[:] = self.image[..., :3]
        self._drawn[:] = self.image[..., 3]

    def _rgba(self, colour) -> tuple[int, int, int, int]:
        """An RGB colour as opaque RGBA."""
        return (int(colour[0]), int(colour[1]), int(colour[2]), 255)

    def _polygon(self, vertices, colour, closed: bool, picked: int | None, thickness: int) -> None:
        """Draw an outline (closed or open) with its corners, the picked one ringed."""
        if not len(vertices):
            return
        pts = np.round(np.asarray(vertices, float)).astype(np.int32).reshape(-1, 1, 2)
        if len(vertices) >= 2:
            cv2.polylines(self.image, [pts], closed, self._rgba(HALO), thickness + 2, cv2.LINE_AA)
            cv2.polylines(self.image, [pts], closed, self._rgba(colour), thickness, cv2.LINE_AA)
        # a handle: the colour in a dark ring in a white one, seen on any background
        for k, (u, v) in enumerate(pts.reshape(-1, 2)):
            cv2.circle(self.image, (int(u), int(v)), HANDLE_RADIUS + 3, self._rgba(WHITE), -1,
                       cv2.LINE_AA)
            cv2.circle(self.image, (int(u), int(v)), HANDLE_RADIUS + 1, self._rgba(HALO), -1,
                       cv2.LINE_AA)
            cv2.circle(self.image, (int(u), int(v)), HANDLE_RADIUS, self._rgba(colour), -1,
                       cv2.LINE_AA)
            if k == picked:
                cv2.circle(self.image, (int(u), int(v)), HANDLE_RADIUS + 7, self._rgba(WHITE), 2,
                           cv2.LINE_AA)

    def _marker(self, marker: MarkerMark, colour) -> None:
        """Draw a marker: centre coloured by its quality, ringed if picked, crossed if flagged."""
        centre = (int(round(marker.uv[0])), int(round(marker.uv[1])))
        cv2.circle(self.image, centre, MARKER_HALO, self._rgba(HALO), -1, cv2.LINE_AA)
        cv2.circle(self.image, centre, 7, self._rgba(colour), 2, cv2.LINE_AA)
        cv2.circle(self.image, centre, 4, self._rgba(QUALITY_COLOURS[marker.quality]), -1,
                   cv2.LINE_AA)
        if marker.picked:
            cv2.circle(self.image, centre, 12, self._rgba(WHITE), 2, cv2.LINE_AA)
        if marker.flagged:
            for sign in (1, -1):
                cv2.line(self.image, (centre[0] - 11, centre[1] - 11 * sign),
                         (centre[0] + 11, centre[1] + 11 * sign),
                         self._rgba(QUALITY_COLOURS["poor"]), 3, cv2.LINE_AA)

    def _label(self, uv, text: str) -> None:
        """A label on a dark box beside its marker, where it covers no other label and no marker.

        At the first of eight places around it, then eight a little farther (LABEL_STEP), that
        covers no other label and no marker, else at the one that covers least of them (two mirrors'
        markers meet at a hinge).
        """
        (w, h), base = cv2.getTextSize(text, FONT, 0.45, 1)
        u, v = int(round(uv[0])), int(round(uv[1]))
        rows, cols = self.image.shape[:2]
        places = []
        ring = ((11, -11), (11, 15 + h), (-11 - w, -11), (-11 - w, 15 + h), (-w // 2, -14),
                (-w // 2, 20 + h), (14, 4), (-14 - w, 4))
        farther = tuple((du + int(np.sign(du)) * LABEL_STEP, dv + int(np.sign(dv)) * LABEL_STEP)
                        for du, dv in ring)
        for du, dv in ring + farther:
            x0, y0 = min(max(u + du, 0), cols - w - 4), min(max(v + dv, h + 3), rows - 4)
            box = (x0 - 2, y0 - h - 3, x0 + w + 2, y0 + base)
            places.append((sum(_overlap(box, other) for other in self._labels), (x0, y0), box))
            if not places[-1][0]:
                break
        _, (x0, y0), box = min(places, key=lambda place: place[0])
        self._labels.append(box)
        cv2.rectangle(self.image, box[:2], box[2:], self._rgba(HALO), -1)
        cv2.putText(self.image, text, (x0, y0), FONT, 0.45, self._rgba(WHITE), 1, cv2.LINE_AA)


def _marker_box(uv) -> tuple[int, int, int, int]:
    """The box (x0, y0, x1, y1) pixels that a marker drawn at uv covers.

    Its ring's halo, as Overlay._marker draws it.
    """
    u, v = int(round(uv[0])), int(round(uv[1]))
    return (u - MARKER_HALO, v - MARKER_HALO, u + MARKER_HALO + 1, v + MARKER_HALO + 1)


def _overlap(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> int:
    """The area (pixels) where boxes a and b (x0, y0, x1, y1) overlap, 0 when they do not."""
    return max(0, min(a[2], b[2]) - max(a[0], b[0])) * max(0, min(a[3], b[3]) - max(a[1], b[1]))
