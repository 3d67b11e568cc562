"""`mirrorscan truth SESSION`: a simulated session against the simulator's truth.

How far a simulated session's planes (and a cloud of one of its frames) are from the simulator's
truth, as the README's accuracy tables give them.
"""

from __future__ import annotations

import argparse
import json

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.base.palette import source_name
from mirrorcore.io.ply import read_ply_colours
from mirrorcore.io.session import TRUTH_FILE
from mirrorcore.io.sessionfile import load_session
from mirrorcore.sim.colourtruth import WITHIN_LEVELS, colour_errors, has_scene_colour
from mirrorcore.sim.truth import frame_time, plane_errors, surface_error, true_mirrors
from mirrorcore.sources import session_truth

from . import wording
from .wording.accuracy import no_mirrors


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add `mirrorscan truth` to the command line; its parser's `run` default is `run`.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The `mirrorscan` parser's subcommands.
    """
    parser = subparsers.add_parser(
        "truth",
        help="compare a simulated session's planes, and a cloud of it, with the simulator's truth",
        description=f"Needs the {TRUTH_FILE} that `mirrorscan simulate` and a recording of the "
        "simulated source (`mirrorscan record sim`, the browser's Record) write. Per mirror: its "
        "plane's offset from the true plane at the object's middle (mm, along the normal; > 0: "
        "too far from the camera), its tilt (degrees) and its glass beside the true one (mm). "
        "With --cloud: the cloud's distances to the objects' true surfaces at that frame (mm), "
        "and, when its colours are the scene's, per source, its colours against the albedo each "
        "point's pixel sees: mean bias per channel, RMSE (levels of 255), ratio to the direct "
        f"view's RMSE, shares within {WITHIN_LEVELS} levels.",
    )
    parser.add_argument(
        "session",
        metavar="SESSION",
        help="a session folder written by `mirrorscan simulate` or recorded from the simulator",
    )
    parser.add_argument(
        "--cloud", metavar="CLOUD.ply", help="a cloud of the session (`mirrorscan reconstruct`)"
    )
    parser.add_argument(
        "--frame",
        type=int,
        default=0,
        help="the frame the cloud is of (default %(default)s; a walking figure moves)",
    )
    parser.add_argument(
        "--json", action="store_true", help="print one JSON object instead of a summary"
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Print (or with --json write one JSON object of) a simulated session's errors from its truth.

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
    MirrorscanError
        When the session has no truth file, or, with --cloud, no frame --frame.
    """
    session = load_session(args.session)
    truth = session_truth(session)
    if truth is None:
        raise MirrorscanError(
            f"{args.session}: no {TRUTH_FILE}: only a session `mirrorscan simulate` wrote, or one "
            "recorded from the simulated source, has a truth to compare with"
        )
    scene, fps = truth
    if args.cloud is not None and not 0 <= args.frame < len(session.frames):
        # as reconstruct and calibrate say it
        raise MirrorscanError(
            f"{session.path}: no frame {args.frame}; the session has {len(session.frames)} (0 to "
            f"{len(session.frames) - 1})"
        )
    planes = plane_errors(session, scene)
    surface, colour, coloured = None, None, None
    if args.cloud is not None:
        points, sources, colours = read_ply_colours(args.cloud)
        t = frame_time(session, args.frame, fps)
        surface = surface_error(points, scene, t)
        if has_scene_colour(colours, sources):
            true_planes = [m.plane for m in true_mirrors(session, scene)]
            colour = colour_errors(points, sources, colours, scene, true_planes, t)
        coloured = colours is not None
    names = [m.name for m in session.mirrors]
    if args.json:
        cloud = {}
        if surface is not None:
            cloud = {"cloud": args.cloud, "frame": args.frame, **vars(surface),
                     "colour": None if colour is None else [
                         {**vars(e), "name": "all points" if e.source is None
                          else source_name(e.source, names)} for e in colour]}
        print(json.dumps({"session": args.session, "planes": [vars(p) for p in planes],
                          **cloud}))
    else:
        if not planes:
            wording.show(no_mirrors(args.session), args.verbose)
        for plane in planes:
            wording.show(wording.plane_error(plane), args.verbose)
        if surface is not None:
            wording.show(wording.surface_error(surface, args.cloud), args.verbose)
            wording.show(wording.no_scene_colour(args.cloud, coloured) if colour is None
                         else wording.colour_error(colour, args.cloud, names), args.verbose)
    return 0
