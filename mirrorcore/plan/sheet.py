"""A drawing sheet: lines, outlines, dimension lines and labels on a page of pixels, rendered the
same to SVG (markup written here) and to an anti-aliased PNG (OpenCV).

Labels are placed where they overlap no label placed before them (tried around their anchor,
nearest first), on a white ground so that lines under them do not hide them. Text is measured
with OpenCV's Hershey font; the SVG stretches its own font to the same widths (`textLength`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from html import escape

import cv2
import numpy as np

FONT = cv2.FONT_HERSHEY_SIMPLEX
INK = (40, 40, 40)
WHITE = (255, 255, 255)
TEXT_SCALE = 0.75           # Hershey scale of ordinary labels: letters 16 px high
LINE_GAP = 8                # pixels between the lines of a label
PAD = 4                     # pixels of white ground around a label
ARROW = (14.0, 5.0)         # an arrowhead's length and half-width, pixels
DASH = (12.0, 8.0)          # a dashed line's stroke and gap, pixels
# how far (pixels) a label moves from its anchor to find room, nearest first
_STEPS = (0, 10, 24, 44, 70, 100, 140, 190)
_DIRECTIONS = ((0, 0), (0, -1), (0, 1), (1, 0), (-1, 0), (1, -1), (-1, -1), (1, 1), (-1, 1))

Point = tuple[float, float]


def text_size(text: str, scale: float) -> tuple[int, int]:
    """Width and height (pixels) of one line; a degree sign takes a space's width."""
    (w, h), _ = cv2.getTextSize(text.replace("°", " ") or " ", FONT, scale, _thickness(scale))
    return w, h


def _thickness(scale: float) -> int:
    """The Hershey stroke (pixels) of text at `scale`: bold from TEXT_SCALE's size up."""
    return 2 if scale >= 0.7 else 1


@dataclass
class Label:
    """A placed label: its box's top-left corner, its lines and their keys (SVG `data-key`)."""

    x: float
    y: float
    lines: list[str]
    keys: list[str | None]
    scale: float
    colour: tuple[int, int, int]
    width: float
    height: float

    def overlaps(self, other: "Label") -> bool:
        """Whether the two boxes, each with its white ground, touch."""
        return not (self.x + self.width + PAD <= other.x - PAD
                    or other.x + other.width + PAD <= self.x - PAD
                    or self.y + self.height + PAD <= other.y - PAD
                    or other.y + other.height + PAD <= self.y - PAD)


@dataclass
class Sheet:
    """A page of `width` x `height` pixels, white, drawn on in order.

    Attributes
    ----------
    width, height : int
        Pixels.
    shapes : list of tuple
        (points, colour, width, dashed, fill) of each line, in drawing order.
    labels : list of Label
        The placed labels, drawn over the shapes.
    obstacles : list of Label
        Small boxes along lines that labels keep off (`keep_clear`).
    """

    width: int
    height: int
    shapes: list[tuple] = field(default_factory=list)
    labels: list[Label] = field(default_factory=list)
    obstacles: list[Label] = field(default_factory=list)

    def keep_clear(self, points, closed: bool = False, step: float = 12.0):
        """Keep labels placed from now on off a line through points (pixels)."""
        points = [np.asarray(p, float) for p in points]
        if closed:
            points.append(points[0])
        for a, b in zip(points, points[1:]):
            for t in np.linspace(0, 1, max(2, int(np.linalg.norm(b - a) / step) + 1)):
                x, y = a + (b - a) * t
                self.obstacles.append(Label(x - 2, y - 2, [], [], 0, INK, 4, 4))

    # ------------------------------------------------------------------ shapes
    def line(self, p: Point, q: Point, colour=INK, width: float = 2, dashed: bool = False):
        """A straight line from p to q."""
        self.shapes.append(([p, q], colour, width, dashed, None))

    def polyline(self, points, colour=INK, width: float = 2, closed: bool = False,
                 fill=None, dashed: bool = False):
        """A line through points (closed: back to the first; fill: its inside's colour)."""
        points = [tuple(map(float, p)) for p in points]
        if closed:
            points.append(points[0])
        self.shapes.append((points, colour, width, dashed, fill))

    def arrowhead(self, tip: Point, tail: Point, colour=INK):
        """A filled arrowhead at `tip`, pointing away from `tail`."""
        tip, tail = np.asarray(tip, float), np.asarray(tail, float)
        d = tip - tail
        d /= max(np.linalg.norm(d), 1e-9)
        n = np.array([-d[1], d[0]])
        length, half = ARROW
        points = [tip, tip - d * length + n * half, tip - d * length - n * half]
        self.polyline(points, colour, 1, closed=True, fill=colour)

    def dimension(self, p: Point, q: Point, text: str, key: str | None = None,
                  offset: float = 0.0, colour=INK):
        """A dimension line between p and q, moved `offset` pixels to its left (from p to q),
        with extension lines, arrowheads at both ends and its text at its middle."""
        p, q = np.asarray(p, float), np.asarray(q, float)
        d = q - p
        n = np.array([d[1], -d[0]]) / max(np.linalg.norm(d), 1e-9)
        a, b = p + n * offset, q + n * offset
        if offset:
            grow = n * 6 * np.sign(offset)
            self.line(tuple(p), tuple(a + grow), colour, 1)
            self.line(tuple(q), tuple(b + grow), colour, 1)
        self.line(tuple(a), tuple(b), colour, 1.5)
        if np.linalg.norm(b - a) > 2.5 * ARROW[0]:
            self.arrowhead(tuple(a), tuple(b), colour)
            self.arrowhead(tuple(b), tuple(a), colour)
        self.label(tuple((a + b) / 2), [text], [key], colour=colour)

    def arc(self, centre: Point, radius: float, start: float, end: float, colour=INK,
            width: float = 1.5):
        """An arc of `radius` pixels from angle `start` to `end` (radians, on the page)."""
        turn = np.linspace(start, end, 40)
        c = np.asarray(centre, float)
        self.polyline(c + radius * np.stack([np.cos(turn), np.sin(turn)], axis=1), colour, width)

    # ------------------------------------------------------------------ labels
    def label(self, anchor: Point, lines: list[str], keys: list[str | None] | None = None,
              scale: float = TEXT_SCALE, colour=INK, bounds=None, leader: bool = True):
        """Place a label on `anchor` or, when that overlaps another label, nearest around it.

        Parameters
        ----------
        anchor : (float, float)
            Pixels: where the label's middle goes when there is room.
        lines : list of str
        keys : list of str or None, optional
            One per line: the SVG's `data-key` of the line's text (for programs that read it).
        scale : float
            Hershey scale.
        colour : (int, int, int)
            RGB.
        bounds : (x0, y0, x1, y1), optional
            Pixels the label stays inside (the sheet by default).
        leader : bool
            Draw a thin line from the anchor to a label that moved away from it.
        """
        keys = keys or [None] * len(lines)
        sizes = [text_size(t, scale) for t in lines]
        w = max(s[0] for s in sizes)
        h = sum(s[1] for s in sizes) + LINE_GAP * (len(lines) - 1)
        x0, y0, x1, y1 = bounds or (0, 0, self.width, self.height)
        first = None
        for step in _STEPS:
            for dx, dy in _DIRECTIONS:
                if step == 0 and (dx, dy) != (0, 0) or step and (dx, dy) == (0, 0):
                    continue
                x = anchor[0] - w / 2 + dx * (step + w / 2)
                y = anchor[1] - h / 2 + dy * (step + h / 2)
                x = min(max(x, x0 + PAD), x1 - w - PAD)
                y = min(max(y, y0 + PAD), y1 - h - PAD)
                box = Label(x, y, list(lines), list(keys), scale, colour, w, h)
                first = first or box
                if not any(box.overlaps(other) for other in self.labels + self.obstacles):
                    return self._place(box, anchor, leader)
        return self._place(first, anchor, leader)

    def text(self, corner: Point, lines: list[str], keys: list[str | None] | None = None,
             scale: float = TEXT_SCALE, colour=INK) -> Label:
        """A label with its top-left corner at `corner` (pixels), placed there whatever it
        overlaps."""
        sizes = [text_size(t, scale) for t in lines]
        box = Label(corner[0], corner[1], list(lines), list(keys or [None] * len(lines)), scale,
                    colour, max(s[0] for s in sizes),
                    sum(s[1] for s in sizes) + LINE_GAP * (len(lines) - 1))
        self.labels.append(box)
        return box

    def _place(self, box: Label, anchor: Point, leader: bool) -> Label:
        cx, cy = box.x + box.width / 2, box.y + box.height / 2
        far = abs(cx - anchor[0]) > box.width / 2 + 4 or abs(cy - anchor[1]) > box.height / 2 + 4
        if leader and far:
            nx = min(max(anchor[0], box.x), box.x + box.width)
            ny = min(max(anchor[1], box.y), box.y + box.height)
            self.line(anchor, (nx, ny), box.colour, 1)
        self.labels.append(box)
        return box

    # --------------------------------------------------------------- rendering
    def svg(self) -> str:
        """The sheet as an SVG document (text)."""
        out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{self.width}" '
               f'height="{self.height}" viewBox="0 0 {self.width} {self.height}" '
               'xml:space="preserve">',
               f'<rect width="{self.width}" height="{self.height}" fill="white"/>']
        for shape in self.shapes:
            out.append(_svg_shape(shape))
        for box in self.labels:
            out.append(f'<rect x="{box.x - PAD:.1f}" y="{box.y - PAD:.1f}" '
                       f'width="{box.width + 2 * PAD:.1f}" height="{box.height + 2 * PAD:.1f}" '
                       f'fill="white" fill-opacity="0.88"/>')
            y = box.y
            for text, key in zip(box.lines, box.keys):
                w, h = text_size(text, box.scale)
                data = "" if key is None else f' data-key="{escape(key)}"'
                weight = ' font-weight="bold"' if _thickness(box.scale) > 1 else ""
                out.append(f'<text x="{box.x:.1f}" y="{y + h:.1f}" font-family="DejaVu Sans, '
                           f'Arial, sans-serif" font-size="{h * 1.36:.1f}"{weight} '
                           f'textLength="{w}" lengthAdjust="spacingAndGlyphs" '
                           f'fill="{_hex(box.colour)}"{data}>{escape(text)}</text>')
                y += h + LINE_GAP
        out.append("</svg>")
        return "\n".join(out) + "\n"

    def png(self) -> np.ndarray:
        """The sheet as an (height, width, 3) uint8 RGB image."""
        image = np.full((self.height, self.width, 3), 255, np.uint8)
        for shape in self.shapes:
            _draw_shape(image, shape)
        for box in self.labels:
            x0, y0 = int(box.x - PAD), int(box.y - PAD)
            x1, y1 = int(box.x + box.width + PAD), int(box.y + box.height + PAD)
            patch = image[max(y0, 0):y1, max(x0, 0):x1]
            patch[:] = (patch * 0.12 + 255 * 0.88).astype(np.uint8)
            y = box.y
            for text in box.lines:
                h = text_size(text, box.scale)[1]
                _put_text(image, text, (box.x, y + h), box.scale, box.colour)
                y += h + LINE_GAP
        return image


def _hex(colour) -> str:
    """An RGB triple as an SVG colour, '#rrggbb'."""
    return "#" + "".join(f"{int(c):02x}" for c in colour)


def _svg_shape(shape: tuple) -> str:
    """One of Sheet.shapes as an SVG polyline."""
    points, colour, width, dashed, fill = shape
    coords = " ".join(f"{x:.1f},{y:.1f}" for x, y in points)
    dash = f' stroke-dasharray="{DASH[0]:g},{DASH[1]:g}"' if dashed else ""
    return (f'<polyline points="{coords}" stroke="{_hex(colour)}" stroke-width="{width}" '
            f'fill="{"none" if fill is None else _hex(fill)}" stroke-linejoin="round"{dash}/>')


def _draw_shape(image: np.ndarray, shape: tuple) -> None:
    """Draw one of Sheet.shapes on an RGB image, anti-aliased."""
    shift = 4          # cv2 draws at 1/16 pixel
    points, colour, width, dashed, fill = shape
    pts = np.round(np.asarray(points) * 16).astype(np.int32)
    if fill is not None:
        cv2.fillPoly(image, [pts], fill, cv2.LINE_AA, shift)
    for a, b in (_dashes(points) if dashed else zip(points, points[1:])):
        cv2.line(image, (round(a[0] * 16), round(a[1] * 16)), (round(b[0] * 16), round(b[1] * 16)),
                 colour, max(1, round(width)), cv2.LINE_AA, shift)


def _dashes(points) -> list[tuple[Point, Point]]:
    """The strokes of a dashed line through points."""
    out = []
    for a, b in zip(points, points[1:]):
        a, b = np.asarray(a, float), np.asarray(b, float)
        length = np.linalg.norm(b - a)
        for s in np.arange(0, length, DASH[0] + DASH[1]):
            e = min(s + DASH[0], length)
            out.append((tuple(a + (b - a) * s / length), tuple(a + (b - a) * e / length)))
    return out


def _put_text(image: np.ndarray, text: str, origin: Point, scale: float, colour) -> None:
    """One line of text at its baseline's start; a degree sign drawn as a small ring."""
    x, y = origin
    thickness = _thickness(scale)
    for k, piece in enumerate(text.split("°")):
        if k:
            w, h = text_size("°", scale)
            ring = max(2, round(scale * 4))
            cv2.circle(image, (round(x + w / 2), round(y - text_size("0", scale)[1] + ring)),
                       ring, colour, 1, cv2.LINE_AA)
            x += w
        if piece:
            cv2.putText(image, piece, (round(x), round(y)), FONT, scale, colour, thickness,
                        cv2.LINE_AA)
            x += text_size(piece, scale)[0]
