"""`mirrorscan calibrate SESSION [--frame I] [--method markers|region|scene] [--refine] [--refine-with W]`: fit every
mirror's plane, optionally refine it from the agreement of the views, and write it into session.json."""
from __future__ import annotations

import argparse

import numpy as np

from mirrorcore.calibration.fit import MAX_MARKER_FRAMES, calibrate_session, calibration_depth
from mirrorcore.base.errors import CalibrationError
from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.calibration.refine import REFINE_FRAMES, REFINE_WITH, refine_session
from mirrorcore.calibration.results import SAME_GLASS_MM, SAME_PLANE, Refinement
from mirrorcore.rig.model import Rig
from mirrorcore.calibration.scene import calibrate_scene, sentences
from mirrorcore.io.session import Session, load_session, save_session
from mirrorcore.base.words import listed

from . import percent_bar


def register(sub) -> None:
    p = sub.add_parser("calibrate", help="fit every mirror's plane (from its markers, its frame, or the object) and "
                                         "optionally refine it from the object; write it into session.json")
    p.add_argument("session", help="session folder")
    p.add_argument("--frame", type=int, default=None,
                   help="use this frame only (default: markers and region use the robust mean of the background and "
                        f"up to {MAX_MARKER_FRAMES} frames, each pixel's readings within 3 sigma of their median; "
                        f"scene and --refine up to {REFINE_FRAMES} frames)")
    p.add_argument("--method", choices=["markers", "region", "scene"], default=None,
                   help="markers (the default without --refine): the mirror's 'markers'; region: its 'region' "
                        "polygon (its frame); scene: no markers, the object seen directly and in each mirror (search, "
                        "then refinement)")
    p.add_argument("--refine", action="store_true",
                   help="refine the planes so that the object seen in the mirrors agrees with the object seen directly "
                        "(after --method, or alone on a session whose planes are set)")
    p.add_argument("--refine-with", choices=REFINE_WITH, default="auto",
                   help="what the refinement (and scene) compares: auto (default) the centres of the sphere seen "
                        "directly and in each mirror when the object is a sphere every view sees (a calibration "
                        "ball), else the surfaces where the views see the same part; sphere: the sphere or a refusal; "
                        "surfaces: the surfaces of any object")
    p.add_argument("--seed", type=int, default=0, help="RANSAC and search seed")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def object_frames(session: Session, frame: int | None) -> tuple[np.ndarray, np.ndarray]:
    """The frames the object-based steps use (the frame asked for, or up to REFINE_FRAMES evenly spaced) with the
    object's pixels as Algorithm 1 selects them -> depths (F, H, W) float32 metres as read, masks (F, H, W) bool."""
    if not session.frames:
        raise CalibrationError(f"{session.path}: the session has no frames with the object to calibrate from")
    picks = [frame] if frame is not None else session.spread_frames(REFINE_FRAMES)
    rig, background = Rig.from_session(session), session.read_background()
    depths = session.read_frames(picks)
    masks = np.stack([prepare_frame(rig, d, background, session.selection)[1] for d in depths])
    return depths, masks


def run(args: argparse.Namespace) -> int:
    session = load_session(args.session)
    if not session.mirrors:
        raise CalibrationError(f"{session.path}: the session has no mirrors")
    method = args.method or (None if args.refine else "markers")
    if args.refine_with != "auto" and not (args.refine or method == "scene"):
        raise CalibrationError(f"--refine-with {args.refine_with} applies to --refine or --method scene; add one")
    rng = np.random.default_rng(args.seed)
    loaded = session
    with percent_bar("refining", disable=args.quiet or not (args.refine or method == "scene")) as progress:
        session, result = _calibrate(session, method, args, rng, progress)
    changed = method is not None or result.changed(loaded, session)    # --refine alone may change nothing
    if result is not None:
        for report in result.mirrors:
            searched = method == "scene"
            print(f"{report.name}: {'found' if searched else 'refined'} plane "
                  f"{np.round(report.after.abcd, 5).tolist()}  {report.summary(searched, saved=changed)}")
        if method == "scene":
            _say_markers_unused([session.mirrors[r.index] for r in result.mirrors])
    if not changed:                                                     # as the browser says it
        print(f"nothing changed: the planes and the glass are already where this object puts them (within "
              f"{SAME_PLANE[0]} mm, {SAME_PLANE[1]}° and {SAME_GLASS_MM} mm of glass); {session.path} not written")
        return 0
    save_session(session)
    print(f"wrote {session.path}")
    if result is not None and result.refused:        # scene: the mirrors found are written, the others named
        names = listed(session.mirrors[i].name for i, _ in result.refused)
        raise CalibrationError(f"{names} not calibrated (the planes found are written): "
                               f"{sentences(why for _, why in result.refused)}")
    return 0


def _say_markers_unused(found: list) -> None:
    """After --method scene: the mirrors found that have markers, whose planes did not use them (a helper ran it on
    a session with markers and read no word of them)."""
    marked = [m.name for m in found if m.markers]
    if marked:
        print(f"{listed(marked)}: {'its plane was' if len(marked) == 1 else 'their planes were'} found from the "
              "object alone; the markers only read the glass (--method markers fits the planes to them)")


def _unset(session: Session) -> list[int] | None:
    """The mirrors `--method scene` searches: those without a plane, the others taking part as they are (a mirror the
    camera sees too little of, fitted from its markers first: the middle one of an arc of three); all (None) when
    every mirror has a plane."""
    unset = [i for i, m in enumerate(session.mirrors) if m.plane is None]
    return unset or None


def _calibrate(session: Session, method: str | None, args: argparse.Namespace, rng: np.random.Generator,
               progress) -> tuple[Session, Refinement | None]:
    """The method's planes (printed as they are fitted), then the refinement when asked (or always, for scene)."""
    if method == "scene":
        return calibrate_scene(session, *object_frames(session, args.frame), rng, _unset(session),
                               progress=progress, with_=args.refine_with)
    if method is not None:
        session, results = calibrate_session(session, calibration_depth(session, args.frame), rng, method=method)
        for i, fit in results:
            mirror = session.mirrors[i]
            print(f"{mirror.name}: plane {np.round(fit.plane.abcd, 5).tolist()}  {fit.summary(mirror.marker_names)}")
    if not args.refine:
        return session, None
    unset = [m.name for m in session.mirrors if m.plane is None]
    if method is None and unset:
        raise CalibrationError(f"{listed(unset)}: no plane to refine yet; fit the planes first and then refine them: "
                               f"mirrorscan calibrate {session.root} --method markers --refine")
    try:
        return refine_session(session, *object_frames(session, args.frame), range(len(session.mirrors)),
                              progress=progress, with_=args.refine_with)
    except CalibrationError as exc:
        if method is None:
            raise
        raise CalibrationError(f"{exc} (nothing written: without --refine, the {method} fit alone is written)") from exc
