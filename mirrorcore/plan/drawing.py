"""The plan's drawing: the layout seen from above and from the side, with every dimension a person
needs to build it, written as SVG and PNG (docs/planning.md, "The drawing and the report").

Lengths are labelled in millimetres and angles in degrees. Every dimension's text carries a
`data-key` in the SVG (e.g. "mirror 1 width", "mirror 1 / mirror 2 angle") for programs that read
the drawing back.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from mirrorcore.base.atomic import write_atomic
from mirrorcore.base.palette import source_colour
from mirrorcore.depth.files import write_colour_png
from mirrorcore.plan.measures import Measures, measure
from mirrorcore.plan.planread import Plan
from mirrorcore.plan.sheet import INK, LINE_GAP, TEXT_SCALE, Sheet, text_size

DRAWING_PNG = "drawing.png"
DRAWING_SVG = "drawing.svg"
PAGE = (2400, 1400)                  # pixels: A4 landscape at about 200 dpi
WALL = (120, 120, 120)
LIGHT = (170, 170, 170)
SUBJECT = (215, 215, 215)
_TOP = (20, 90, 1130, 1380)          # the panels' boxes on the page: x0, y0, x1, y1
_SIDE = (1170, 90, 2380, 900)
_FIGURES = (1170, 930, 2380, 1380)
_MARGIN = 130                        # pixels around a view, for its dimensions
_TITLE = 40                          # pixels of a panel's title


def mm(metres: float) -> str:
    """A length in whole millimetres."""
    return str(round(metres * 1000))


def degrees(value: float) -> str:
    """An angle to a tenth of a degree, without a trailing '.0'."""
    text = f"{round(value, 1) + 0.0:.1f}"
    return text.removesuffix(".0") + "°"


class _View:
    """A panel's mapping from metres (a, b: right and up on the page) to pixels."""

    def __init__(self, box, low, high):
        x0, y0, x1, y1 = box
        y0 += _TITLE
        span = np.maximum(np.asarray(high, float) - low, 1e-6)
        self.scale = min((x1 - x0 - 2 * _MARGIN) / span[0], (y1 - y0 - 2 * _MARGIN) / span[1])
        self.middle = (np.asarray(low, float) + high) / 2
        self.origin = np.array([(x0 + x1) / 2, (y0 + y1) / 2])

    def __call__(self, a, b) -> tuple[float, float]:
        return (float(self.origin[0] + (a - self.middle[0]) * self.scale),
                float(self.origin[1] - (b - self.middle[1]) * self.scale))


def drawing(plan: Plan, measures: Measures | None = None) -> Sheet:
    """Draw a plan's layout from above and from the side, with its dimensions.

    Parameters
    ----------
    plan : Plan
    measures : Measures, optional
        `measure(plan)` when not given.

    Returns
    -------
    Sheet
    """
    m = measure(plan) if measures is None else measures
    sheet = Sheet(*PAGE)
    subject = plan.subject.spec or f"a {plan.subject.kind}"
    sheet.label((PAGE[0] / 2, 40), [f"Mirror layout: {len(m.mirrors)} mirrors and {subject}. "
                                    "Lengths in mm, angles in degrees."],
                scale=0.95)
    for box, title in ((_TOP, "Top view (camera at the bottom, looking up the page)"),
                       (_SIDE, "Side view (from the camera's left, camera looking right)"),
                       (_FIGURES, "Predicted figures")):
        sheet.polyline([(box[0], box[1]), (box[2], box[1]), (box[2], box[3]), (box[0], box[3])],
                       LIGHT, 1, closed=True)
        sheet.text((box[0] + 12, box[1] + 12), [title])
    _top_view(sheet, plan, m)
    _side_view(sheet, plan, m)
    _figures(sheet, plan)
    return sheet


def write_drawing(plan: Plan, folder: str | Path | None = None,
                  measures: Measures | None = None) -> tuple[Path, Path]:
    """Write the drawing as drawing.png and drawing.svg.

    Parameters
    ----------
    plan : Plan
    folder : str or Path, optional
        Where to write them (the plan folder by default).
    measures : Measures, optional
        `measure(plan)` when not given.

    Returns
    -------
    (Path, Path)
        The PNG's and the SVG's paths.
    """
    folder = plan.folder if folder is None else Path(folder)
    sheet = drawing(plan, measures)
    png, svg = folder / DRAWING_PNG, folder / DRAWING_SVG
    write_colour_png(png, sheet.png())
    write_atomic(svg, sheet.svg().encode("utf-8"))
    return png, svg


def _colour(k: int) -> tuple[int, int, int]:
    """Mirror k's (0-based) RGB, as the browser colours its view."""
    return tuple(int(c) for c in source_colour(k + 1))


def _top_view(sheet: Sheet, plan: Plan, m: Measures) -> None:
    """The top view: the room, the camera, the subject, the mirrors and their dimensions."""
    room = plan.room
    outline = np.concatenate([m.subject_points[:, [0, 2]],
                              *[c.corners[:, [0, 2]] for c in m.mirrors],
                              [[-room.width / 2, 0], [room.width / 2, room.depth], [0, -0.25]]])
    view = _View(_TOP, outline.min(axis=0), outline.max(axis=0))
    w, d = room.width / 2, room.depth
    sheet.polyline([view(-w, 0), view(-w, d), view(w, d), view(w, 0)], WALL, 4)
    sheet.line(view(-w, 0), view(w, 0), LIGHT, 1, dashed=True)
    sheet.dimension(view(-w, d), view(w, d), mm(room.width), "room width", 40, WALL)
    sheet.dimension(view(w, 0), view(w, d), mm(room.depth), "room depth", 40, WALL)
    _field_of_view(sheet, plan, m, view)
    # the outlines first: no label is placed over one
    for k, mirror in enumerate(m.mirrors):
        outline = [view(x, z) for x, _, z in mirror.corners]
        sheet.polyline(outline, _colour(k), 6, closed=True)
        sheet.keep_clear(outline, closed=True)
    _subject_top(sheet, plan, m, view)
    camera = np.array(view(0, 0))
    for k, mirror in enumerate(m.mirrors):
        colour = _colour(k)
        a, b = (np.array(view(*s)) for s in mirror.sides)
        facing = np.array([mirror.normal[0], -mirror.normal[2]])
        left = np.array([(b - a)[1], -(b - a)[0]])
        left /= np.linalg.norm(left)
        sign = -1 if left @ facing > 0 else 1
        # beyond the outline (a leaning mirror's is a parallelogram seen from above)
        beyond = max(sign * (np.array(view(x, z)) - a) @ left for x, _, z in mirror.corners)
        sheet.dimension(tuple(a), tuple(b), mm(mirror.width), f"{mirror.name} width",
                        sign * (34 + max(beyond, 0)), colour)
        centre = np.array(view(mirror.centre[0], mirror.centre[2]))
        sheet.line(tuple(camera), tuple(centre), colour, 1, dashed=True)
        sheet.label(tuple(camera + (centre - camera) * 0.62), [mm(mirror.centre_distance)],
                    [f"{mirror.name} centre distance"], colour=colour)
        sheet.label(tuple(centre - facing * 120), [
            mirror.name, f"{mm(mirror.width)} x {mm(mirror.height)}",
            f"{degrees(mirror.to_axis)} to camera axis",
            f"edge {mm(mirror.edge_distance)} from camera"],
            [None, f"{mirror.name} size", f"{mirror.name} angle to axis",
             f"{mirror.name} edge distance"], colour=colour, bounds=_TOP)
    for pair in m.pairs:
        _pair_top(sheet, m, pair, view)
    sheet.label(tuple(camera + (0, 40)), ["camera"], bounds=_TOP)


def _field_of_view(sheet: Sheet, plan: Plan, m: Measures, view: _View) -> None:
    """The camera's icon and its horizontal field of view, up to its range or the walls."""
    cam = plan.camera
    for u in (0.0, cam.width - 1.0):
        # the point at the far end of the depth range on the image's side, on the floor's plan
        far = np.array([(u - cam.cx) / cam.fx, 0.0, 1.0]) * plan.max_depth
        far = np.array([far @ m.level.right, far @ m.level.forward])
        reach = np.linalg.norm(far)
        flat = far / reach
        limits = [reach, plan.room.depth / flat[1] if flat[1] > 0 else reach,
                  plan.room.width / 2 / abs(flat[0]) if flat[0] else reach]
        end = flat * min(limits)
        sheet.line(view(0, 0), view(*end), LIGHT, 1.5, dashed=True)
    c = np.array(view(0, 0))
    sheet.polyline([c + (-14, 10), c + (14, 10), c + (0, -16)], INK, 2, closed=True, fill=INK)


def _subject_top(sheet: Sheet, plan: Plan, m: Measures, view: _View) -> None:
    """The subject's outline in the top view, its size and place."""
    s = plan.subject
    flat = m.subject_points[:, [0, 2]]
    hull = [view(*p) for p in cv2.convexHull(flat.astype(np.float32))[:, 0]]
    sheet.polyline(hull, INK, 2, closed=True, fill=SUBJECT)
    sheet.keep_clear(hull, closed=True)
    low, high = flat.min(axis=0), flat.max(axis=0)
    centre = (low + high) / 2
    size = (mm(2 * s.radius) + " across" if s.kind != "mesh"
            else f"{mm(high[0] - low[0])} x {mm(high[1] - low[1])}")
    place = f"{mm(centre[1])} ahead" + ("" if abs(centre[0]) < 5e-4 else
                                         f", {mm(centre[0])} right")
    sheet.line(view(0, 0), view(*centre), INK, 1, dashed=True)
    beside = np.array(view(high[0], centre[1])) + (130, 0)
    sheet.label(tuple(beside), [f"subject: {s.spec or s.kind}", size, place],
                [None, "subject size", "subject position"], bounds=_TOP)


def _pair_top(sheet: Sheet, m: Measures, pair, view: _View) -> None:
    """Two neighbouring mirrors in the top view: their angle and gap."""
    a, b = m.mirrors[pair.first], m.mirrors[pair.second]
    names = f"{a.name} / {b.name}"
    if pair.apex is None:
        near = min(((p, q) for p in a.sides for q in b.sides),
                   key=lambda pq: np.linalg.norm(pq[0] - pq[1]))
        sheet.label(view(*(near[0] + near[1]) / 2), [f"gap {mm(pair.gap)}",
                                                     degrees(pair.angle)],
                    [f"{names} gap", f"{names} angle"], bounds=_TOP)
        return
    apex = np.array(view(*pair.apex))
    ends = []
    for mirror in (a, b):
        far = max(mirror.sides, key=lambda s: np.linalg.norm(s - pair.apex))
        ends.append(np.array(view(*far)) - apex)
    turns = [np.arctan2(e[1], e[0]) for e in ends]
    if abs(turns[1] - turns[0]) > np.pi:
        turns[int(turns[1] < turns[0])] += 2 * np.pi
    sheet.arc(tuple(apex), 60, min(turns), max(turns))
    middle = (turns[0] + turns[1]) / 2
    sheet.label(tuple(apex + 95 * np.array([np.cos(middle), np.sin(middle)])),
                [degrees(pair.angle), f"gap {mm(pair.gap)}"],
                [f"{names} angle", f"{names} gap"], bounds=_TOP)


def _side_view(sheet: Sheet, plan: Plan, m: Measures) -> None:
    """The side view: floor, wall and ceiling, the subject, the mirrors' heights."""
    room, h = plan.room, m.level.height
    points = np.concatenate([m.subject_points[:, [2, 1]],
                             *[c.corners[:, [2, 1]] for c in m.mirrors],
                             [[-0.25, 0], [room.depth, room.height or h]]])
    view = _View(_SIDE, points.min(axis=0), points.max(axis=0))
    top = room.height or points[:, 1].max()
    sheet.line(view(-0.25, 0), view(room.depth, 0), WALL, 4)
    sheet.line(view(room.depth, 0), view(room.depth, top), WALL, 4)
    if room.height is not None:
        sheet.line(view(-0.25, room.height), view(room.depth, room.height), WALL, 2, dashed=True)
        sheet.dimension(view(room.depth, 0), view(room.depth, room.height), mm(room.height),
                        "room height", -40, WALL)
    subject = points[:len(m.subject_points)]
    groups: dict[tuple, list[int]] = {}
    for k, mirror in enumerate(m.mirrors):
        zs = mirror.corners[:, 2]
        key = tuple(round(v * 1000) for v in (mirror.bottom, mirror.top, zs.min(), zs.max()))
        groups.setdefault(key, []).append(k)
    # the outlines first: no label is placed over one
    for outline, colour, fill in [(subject, INK, SUBJECT)] + [
            (m.mirrors[k[0]].corners[:, [2, 1]], _colour(k[0]), None) for k in groups.values()]:
        hull = [view(*p) for p in cv2.convexHull(outline.astype(np.float32))[:, 0]]
        sheet.polyline(hull, colour, 2 if fill else 4, closed=True, fill=fill)
        sheet.keep_clear(hull, closed=True)
    near = subject[:, 0].min()
    for k, (value, key) in enumerate(((subject[:, 1].min(), "subject bottom"),
                                      (subject[:, 1].max(), "subject top"))):
        # a subject standing on the floor has no bottom to measure
        if value >= 0.005:
            sheet.dimension(view(near, 0), view(near, value), mm(value), key, 30 + 60 * k)
    for g, members in enumerate(groups.values()):
        first = m.mirrors[members[0]]
        names = " and ".join(m.mirrors[k].name for k in members)
        colour = _colour(members[0])
        far = first.corners[:, 2].max()
        for value, what, offset in ((first.bottom, "bottom", 40), (first.top, "top", 100)):
            sheet.dimension(view(far, value), view(far, 0), mm(value), f"{names} {what}",
                            offset + 130 * g, colour)
        lines = [names] + ([] if abs(first.lean) < 0.05 else [
            f"leans {degrees(abs(first.lean))} {'back' if first.lean > 0 else 'forward'}"])
        sheet.label(view(first.centre[2], first.top + 0.12), lines,
                    [None] + [f"{names} lean"] * (len(lines) - 1), colour=colour, bounds=_SIDE)
    _camera_side(sheet, plan, m, view)


def _camera_side(sheet: Sheet, plan: Plan, m: Measures, view: _View) -> None:
    """The camera in the side view: its height, its tilt and its axis."""
    h, tilt = m.level.height, m.level.tilt
    c = np.array(view(0, h))
    d = np.array([np.cos(np.radians(tilt)), np.sin(np.radians(tilt))])
    n = np.array([-d[1], d[0]])
    sheet.polyline([c - 16 * d + 12 * n, c - 16 * d - 12 * n, c + 16 * d], INK, 2, closed=True,
                   fill=INK)
    reach = np.array([np.cos(np.radians(tilt)), -np.sin(np.radians(tilt))]) * plan.max_depth
    # the axis up to the sensor's range, the floor or the back wall, whichever comes first
    limits = [1.0, plan.room.depth / reach[0] if reach[0] > 0 else 1.0,
              h / -reach[1] if reach[1] < 0 else 1.0]
    end = np.array([0, h]) + reach * min(limits)
    sheet.line(tuple(c), view(*end), LIGHT, 1.5, dashed=True)
    sheet.dimension(view(0, 0), view(0, h), mm(h), "camera height", 40)
    text = "level" if abs(tilt) < 0.05 else f"{'down' if tilt > 0 else 'up'} {degrees(abs(tilt))}"
    sheet.label(tuple(c + (0, -50)), ["camera", f"tilt: {text}"], [None, "camera tilt"],
                bounds=_SIDE)


def _figures(sheet: Sheet, plan: Plan) -> None:
    """The predicted figures, the room and the camera; the views' lines in two columns when
    there are many (several mirrors in turn), in smaller letters when even these overflow."""
    p, room = plan.predicted, plan.room
    sheet.text((_FIGURES[0] + 30, _FIGURES[1] + 55), [
        f"Seen by one view or more: {p.coverage * 100:.0f} % of the subject's surface",
        f"Seen by two views or more: {p.coverage_2 * 100:.0f} %",
        f"Room {mm(room.width)} wide, {mm(room.depth)} deep"
        + ("" if room.height is None else f", {mm(room.height)} high"),
        f"Camera {plan.camera.width} x {plan.camera.height} pixels, range "
        f"{mm(plan.min_depth)}-{mm(plan.max_depth)}"], ["coverage", "coverage 2", "room", "camera"])
    lines = [f"{view}: {share * 100:.0f} % seen" + (
        "" if p.noise_mm[view] is None else f", noise {p.noise_mm[view]:.1f} mm")
        for view, share in p.per_view.items()]
    keys = [f"{view} view" for view in p.per_view]
    top = _FIGURES[1] + 55 + 5 * (text_size("0", TEXT_SCALE)[1] + LINE_GAP)
    room_for = (_FIGURES[3] - top - 10)
    columns = 1 if len(lines) * (text_size("0", TEXT_SCALE)[1] + LINE_GAP) <= room_for else 2
    rows = -(-len(lines) // columns)
    scale = TEXT_SCALE
    while scale > 0.4 and rows * (text_size("0", scale)[1] + LINE_GAP) > room_for:
        scale -= 0.05
    width = (_FIGURES[2] - _FIGURES[0] - 60) / 2
    for c in range(columns):
        chunk = slice(c * rows, (c + 1) * rows)
        sheet.text((_FIGURES[0] + 30 + c * width, top), lines[chunk], keys[chunk], scale)
