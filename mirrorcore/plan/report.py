"""The plan's text report (report.txt): the layout in the words and numbers a technician builds
from, and the figures the plan predicts (docs/planning.md, "The drawing and the report")."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mirrorcore.base.atomic import write_atomic
from mirrorcore.plan.drawing import degrees, mm, write_drawing
from mirrorcore.plan.measures import Measures, measure
from mirrorcore.plan.planread import Plan, load_plan

REPORT_FILE = "report.txt"


def report(plan: Plan, measures: Measures | None = None) -> str:
    """The report's text.

    Parameters
    ----------
    plan : Plan
    measures : Measures, optional
        `measure(plan)` when not given.

    Returns
    -------
    str
        Lines ending in a newline; lengths in mm, angles in degrees.
    """
    m = measure(plan) if measures is None else measures
    level, cam = m.level, plan.camera
    tilt = "level" if abs(level.tilt) < 0.05 else (
        f"{degrees(abs(level.tilt))} {'down' if level.tilt > 0 else 'up'}")
    subject = plan.subject.spec or f"a {plan.subject.kind}"
    lines = [f"Mirror layout: {len(m.mirrors)} mirrors and {subject}.",
             "Lengths in mm, angles in degrees. Positions are taken from the floor under the "
             "camera: x to the camera's right, height above the floor, z forward along the floor.",
             "", "Camera",
             f"  {mm(level.height)} above the floor, tilt {tilt}"
             + ("" if abs(level.roll) < 0.05 else f", roll {degrees(level.roll)}"),
             f"  {cam.width} x {cam.height} pixels, fx {cam.fx:g}, fy {cam.fy:g}, depth range "
             f"{mm(plan.min_depth)} to {mm(plan.max_depth)}", "", "Mirrors"]
    for mirror in m.mirrors:
        c = mirror.centre
        upright = ("upright" if abs(mirror.lean) < 0.05 else
                   f"its top leaning {degrees(abs(mirror.lean))} "
                   + ("away from" if mirror.lean > 0 else "towards") + " the camera")
        lines += [f"  {mirror.name}: {mm(mirror.width)} wide x {mm(mirror.height)} high",
                  f"    bottom edge {mm(mirror.bottom)} above the floor, top {mm(mirror.top)}",
                  f"    face at {degrees(mirror.to_axis)} to the camera's axis, {upright}",
                  f"    centre at x {mm(c[0])}, height {mm(c[1])}, z {mm(c[2])}: "
                  f"{mm(mirror.centre_distance)} from the camera along the floor",
                  f"    nearer side edge {mm(mirror.edge_distance)} from the camera",
                  "    corners (x, height, z): " + "; ".join(
                      f"({mm(x)}, {mm(y)}, {mm(z)})" for x, y, z in mirror.corners)]
    if m.pairs:
        lines += ["", "Between neighbouring mirrors (left to right from the camera)"]
    for pair in m.pairs:
        a, b = m.mirrors[pair.first].name, m.mirrors[pair.second].name
        apex = "" if pair.apex is None else (
            f"; their faces meet at x {mm(pair.apex[0])}, z {mm(pair.apex[1])}")
        lines.append(f"  {a} and {b}: {degrees(pair.angle)} between their faces, gap "
                     f"{mm(pair.gap)} between their edges{apex}")
    lines += ["", "Subject", "  " + _subject(plan, m), "", "Room",
              f"  {mm(plan.room.width)} wide (centred on the camera), {mm(plan.room.depth)} deep "
              "(from the camera forward)"
              + ("" if plan.room.height is None else f", {mm(plan.room.height)} high")]
    p = plan.predicted
    lines += ["", "Predicted",
              f"  seen by one view or more: {p.coverage * 100:.1f} % of the subject's surface",
              f"  seen by two views or more: {p.coverage_2 * 100:.1f} %",
              f"  {'view':<30} {'seen':>7} {'noise':>9}"]
    lines += [f"  {view:<30} {share * 100:>5.1f} % "
              + ("     -" if p.noise_mm[view] is None else f"{p.noise_mm[view]:>6.1f} mm")
              for view, share in p.per_view.items()]
    if plan.search:
        lines += ["", "Search settings"]
        lines += [f"  {key}: {json.dumps(value)}" for key, value in plan.search.items()]
    return "\n".join(lines) + "\n"


def _subject(plan: Plan, m: Measures) -> str:
    """One line: the subject's kind, size and place."""
    s, points = plan.subject, m.subject_points
    low, high = points.min(axis=0), points.max(axis=0)
    middle = (low + high) / 2
    size = (f"{mm(2 * s.radius)} across" if s.kind != "mesh" else
            f"{mm(high[0] - low[0])} wide x {mm(high[2] - low[2])} deep ({s.path.name})")
    kind = s.kind if s.spec is None else f"{s.kind} ({s.spec})"
    return (f"{kind} {size}, from {mm(low[1])} to {mm(high[1])} above the floor, its middle "
            f"at x {mm(middle[0])}, z {mm(middle[2])} "
            f"({mm(float(np.hypot(middle[0], middle[2])))} from the camera)")


def write_report(plan: Plan, folder: str | Path | None = None,
                 measures: Measures | None = None) -> Path:
    """Write report.txt into `folder` (the plan folder by default) and return its path."""
    path = (plan.folder if folder is None else Path(folder)) / REPORT_FILE
    write_atomic(path, report(plan, measures).encode("utf-8"))
    return path


def write_documents(folder: str | Path) -> list[Path]:
    """Read a plan folder's plan.json and write its drawing (PNG, SVG) and report.txt beside it.

    Parameters
    ----------
    folder : str or Path
        The plan folder.

    Returns
    -------
    list of Path
        drawing.png, drawing.svg and report.txt.

    Raises
    ------
    FileFormatError
        plan.json (or the subject's mesh) refused, in one line naming the file and the key.
    """
    plan = load_plan(folder)
    measures = measure(plan)
    return [*write_drawing(plan, measures=measures), write_report(plan, measures=measures)]
