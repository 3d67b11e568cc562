"""`mirrorscan calibrate SESSION`: fit every mirror's plane and write it into session.json.

Options: --frame I, --method markers|region|scene, --refine (from the agreement of the views),
--refine-with auto|sphere|surfaces. A session with colour frames also gets each mirror's colour
gain, measured on the object frames with the planes just fitted.
"""

from __future__ import annotations

import argparse

import numpy as np

from mirrorcore.base.errors import CalibrationError
from mirrorcore.base.words import listed, sentences
from mirrorcore.calibration.colourgain import (
    ColourGains,
    estimate_gains,
    read_colour_frames,
    with_gains,
)
from mirrorcore.calibration.fit import MAX_MARKER_FRAMES, calibrate_session, calibration_depth
from mirrorcore.calibration.refine import REFINE_FRAMES, REFINE_WITH, Refinement, refine_session
from mirrorcore.calibration.scene import calibrate_scene
from mirrorcore.io.session import Session
from mirrorcore.io.sessionfile import load_session, save_session
from mirrorcore.io.sessionlock import SessionLock
from mirrorcore.rig.model import Rig
from mirrorcore.rig.pipeline import object_masks

from . import percent_bar, wording
from .wording.calibration import colour_gain
from .numbers import seed


def register(sub) -> None:
    """Add `mirrorscan calibrate` to the command line; its parser's `run` default is `run`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The `mirrorscan` parser's subcommands.
    """
    p = sub.add_parser(
        "calibrate",
        help="fit every mirror's plane (from its markers, its frame, or the object), optionally "
        "refine it; write it into session.json",
    )
    p.add_argument("session", help="session folder")
    p.add_argument(
        "--frame",
        type=int,
        default=None,
        help="use this frame only (default: markers and region the robust mean of the background "
        f"and up to {MAX_MARKER_FRAMES} frames; scene and --refine up to {REFINE_FRAMES} frames)",
    )
    p.add_argument(
        "--method",
        choices=["markers", "region", "scene"],
        default=None,
        help="markers (default without --refine): fit to the markers; region: to the region "
        "polygon; scene: search from the object, no markers",
    )
    p.add_argument(
        "--refine",
        action="store_true",
        help="refine the planes until the object in the mirrors agrees with the object seen "
        "directly (after --method; alone, the mirrors without a plane are fitted from their "
        "markers first)",
    )
    p.add_argument(
        "--refine-with",
        choices=REFINE_WITH,
        default="auto",
        help="what --refine and scene compare: sphere: a calibration ball's centres (refused "
        "without one); surfaces: any object's shared surfaces; auto (default): sphere if every "
        "view sees one",
    )
    p.add_argument("--seed", type=seed, default=0, help="RANSAC and search seed")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def object_frames(session: Session, frame: int | None) -> tuple[np.ndarray, np.ndarray]:
    """The frames the object-based steps use, with the object's pixels as Algorithm 1 selects them.

    Parameters
    ----------
    session : Session
        The session; its frames, background and selection are read.
    frame : int or None
        The frame asked for, or None for up to REFINE_FRAMES frames evenly spaced.

    Returns
    -------
    depths : (F, H, W) float32
        Metres, as read.
    masks : (F, H, W) bool
        The object's pixels.

    Raises
    ------
    CalibrationError
        When the session has no frames.
    """
    if not session.frames:
        raise CalibrationError(
            f"{session.path}: the session has no frames with the object to calibrate from"
        )
    picks = _picks(session, frame)
    rig, background = Rig.from_session(session), session.read_background()
    depths = session.read_frames(picks)
    masks = object_masks(rig, depths, background, session.selection)
    return depths, masks


def _picks(session: Session, frame: int | None) -> np.ndarray:
    """The frames the object-based steps use: `frame`, or up to REFINE_FRAMES evenly spaced."""
    return np.array([frame]) if frame is not None else session.spread_frames(REFINE_FRAMES)


def colour_gains(session: Session, frame: int | None) -> tuple[Session, ColourGains | None]:
    """Measure the mirrors' colour gains on the object frames, with the session's planes.

    Parameters
    ----------
    session : Session
    frame : int or None
        As for object_frames.

    Returns
    -------
    (Session, ColourGains or None)
        The session with each measured mirror's colour_gain (colourgain.with_gains) and what was
        measured; the session as it is and None without colour frames.
    """
    if not session.colour_frames:
        return session, None
    colours = read_colour_frames(session, _picks(session, frame))
    measured = estimate_gains(Rig.from_session(session), *object_frames(session, frame), colours)
    return with_gains(session, measured), measured


def run(args: argparse.Namespace) -> int:
    """Calibrate the session's mirrors and write their planes into session.json.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit status: 0.

    Raises
    ------
    CalibrationError
        When the session has no mirrors, --refine-with is given without --refine or --method
        scene, or mirrors could not be calibrated (the planes found are written first).
    """
    # one writer at a time: refused while another program edits the session
    with SessionLock(args.session, "mirrorscan calibrate"):
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    """`run` under the session's lock."""
    session = load_session(args.session)
    if not session.mirrors:
        raise CalibrationError(f"{session.path}: the session has no mirrors")
    method = args.method or _default_method(session, args.refine)
    if args.refine_with != "auto" and not (args.refine or method == "scene"):
        raise CalibrationError(
            f"--refine-with {args.refine_with} applies to --refine or --method scene; add one"
        )
    rng = np.random.default_rng(args.seed)
    loaded = session
    refining = args.refine or method == "scene"
    with percent_bar("refining", disable=args.quiet or not refining) as progress:
        session, result = _calibrate(session, method, args, rng, progress)
    fitted = session
    session, gains = colour_gains(session, args.frame)
    # --refine alone may change nothing
    changed = method is not None or result.changed(loaded, fitted) or session != fitted
    if result is not None:
        for report in result.mirrors:
            wording.show(wording.refined(report, method == "scene", saved=changed), args.verbose)
        if method == "scene":
            marked = [
                m.name for m in (session.mirrors[r.index] for r in result.mirrors) if m.markers
            ]
            if marked:
                wording.show(wording.markers_unused(marked), args.verbose)
    for measured in gains.mirrors if gains is not None else ():
        if session.mirrors[measured.index].plane is not None:
            wording.show(colour_gain(measured, gains.frames), args.verbose)
    if not changed:
        wording.show(wording.unchanged(session.path), args.verbose)
        return 0
    save_session(session)
    print(f"wrote {session.path}")
    if result is not None and result.refused:
        # scene: the mirrors found are written, the others named
        names = listed(session.mirrors[i].name for i, _ in result.refused)
        raise CalibrationError(
            f"{names} not calibrated (the planes found are written): "
            f"{sentences(why for _, why in result.refused)}"
        )
    return 0


def _default_method(session: Session, refine: bool) -> str | None:
    """The method without --method: markers, or with --refine none when every mirror has a plane
    (the planes are refined as they are; otherwise the mirrors without one are fitted first)."""
    if refine and all(m.plane is not None for m in session.mirrors):
        return None
    return "markers"


def _unset(session: Session) -> list[int] | None:
    """The mirrors `--method scene` searches.

    Those without a plane, the others taking part as they are (a mirror the camera sees too little
    of, fitted from its markers first: the middle one of an arc of three); None (all) when every
    mirror has a plane."""
    unset = [i for i, m in enumerate(session.mirrors) if m.plane is None]
    return unset or None


def _calibrate(
    session: Session,
    method: str | None,
    args: argparse.Namespace,
    rng: np.random.Generator,
    progress,
) -> tuple[Session, Refinement | None]:
    """The method's planes, printed as they are fitted, then the refinement when asked.

    --method scene always refines.
    """
    if method == "scene":
        return calibrate_scene(
            session,
            *object_frames(session, args.frame),
            rng,
            _unset(session),
            progress=progress,
            with_=args.refine_with,
        )
    if method is not None:
        # --refine alone fits only the mirrors without a plane; the others start where they are
        fit = _unset(session) if args.refine and args.method is None else None
        session, results = calibrate_session(
            session, calibration_depth(session, args.frame), rng, fit, method=method
        )
        for i, fit in results:
            mirror = session.mirrors[i]
            wording.show(wording.fitted(mirror.name, fit, mirror.marker_names), args.verbose)
    if not args.refine:
        return session, None
    try:
        return refine_session(
            session,
            *object_frames(session, args.frame),
            range(len(session.mirrors)),
            progress=progress,
            with_=args.refine_with,
        )
    except CalibrationError as exc:
        if method is None:
            raise
        raise CalibrationError(
            f"{exc} (nothing written: without --refine, the {method} fit alone is written)"
        ) from exc
