"""`mirrorscan simulate OUT`: a session folder rendered by the simulated rig, plus truth.json."""

from __future__ import annotations

import argparse

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.base.palette import MAX_MIRRORS
from mirrorcore.io.limits import MAX_FRAMES
from mirrorcore.io.outputs import check_output
from mirrorcore.sim.export import write_session
from mirrorcore.sim.layouts import kaleidoscope_scene, paper_scene
from mirrorcore.sim.render import MAX_BOUNCES
from mirrorcore.sim.scene import Scene
from mirrorcore.sim.scenefile import load_scene
from mirrorcore.sim.sensor import SensorModel
from mirrorcore.sim.simulator import Simulator

from .numbers import real, seed, whole

_LAYOUT_OPTIONS = ("object", "angle", "mirrors", "distance", "kaleidoscope")


def register(sub) -> None:
    """Add `mirrorscan simulate` to the command line; its parser's `run` default is `run`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The `mirrorscan` parser's subcommands.
    """
    p = sub.add_parser(
        "simulate", help="render a session folder with the simulated rig (and truth.json)"
    )
    p.add_argument("out", help="the session folder to create (must not exist, or be empty)")
    p.add_argument("--object", help="sphere (default), cylinder, box, figure or mesh:PATH")
    p.add_argument(
        "--angle", type=float, help="angle between the two mirrors, degrees (default 120)"
    )
    p.add_argument(
        "--mirrors",
        type=whole(2, MAX_MIRRORS),
        help=f"number of mirrors: 2 in a V (default), 3 to {MAX_MIRRORS} on an arc",
    )
    p.add_argument(
        "--distance",
        type=real(0.5, 100, "metres", above=True),
        help="camera to object, metres (default 2.0; 3.0 for the figure, which the camera sees "
        "whole only from there)",
    )
    p.add_argument(
        "--kaleidoscope",
        action="store_true",
        help="two mirrors hinged at the apex, 15 cm from the object, at --angle (default 120); "
        "below 90 degrees (72, say) views go on through two and three mirrors",
    )
    p.add_argument("--scene", help="a scene JSON file instead of the options above")
    p.add_argument(
        "--noise",
        choices=["none", "kinect", "kinect-noiseless"],
        default="kinect",
        help="sensor model (default kinect)",
    )
    p.add_argument("--frames", type=whole(1, MAX_FRAMES), default=1,
                   help="number of frames at 30 fps (default 1)")
    p.add_argument("--seed", type=seed, default=0, help="noise seed (default 0)")
    p.add_argument(
        "--bounces",
        type=whole(1, MAX_BOUNCES),
        help=f"the most reflections a ray may make, 1 to {MAX_BOUNCES} (default {MAX_BOUNCES}); a "
        "ray meeting one more mirror reads nothing",
    )
    p.add_argument(
        "--single-bounce",
        action="store_true",
        help="leave out rays that reflect off two mirrors (--bounces 1)",
    )
    p.add_argument(
        "--marker-offset",
        type=real(0, 50, "mm"),
        metavar="MM",
        help="the markers' faces this many millimetres in front of every mirror's reflecting "
        "surface, as stickers on the glass of an ordinary mirror (default 0, or the scene file's)",
    )
    p.add_argument(
        "--click-jitter",
        type=real(0, 50, "pixels"),
        metavar="PX",
        help="radial RMS error, pixels, of the session's marker clicks (seeded; default 0, or the "
        "scene file's)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Render a session folder with the simulated rig, plus truth.json.

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
        When an option is out of range or options contradict each other.
    """
    mesh = (
        args.object.removeprefix("mesh:")
        if args.object and args.object.startswith("mesh:")
        else None
    )
    check_output(args.out, tuple(p for p in (args.scene, mesh) if p))
    scene = _scene(args)
    offset = None if args.marker_offset is None else args.marker_offset / 1000
    scene = scene.with_markers(offset, args.click_jitter)
    if args.single_bounce and args.bounces not in (None, 1):
        raise MirrorscanError(
            f"--single-bounce means --bounces 1; drop one of them (got --bounces {args.bounces})"
        )
    bounces = 1 if args.single_bounce else MAX_BOUNCES if args.bounces is None else args.bounces
    rig = Simulator(scene, SensorModel.from_name(args.noise), args.seed, bounces)
    out = write_session(rig, args.out, args.frames, args.noise, progress=not args.quiet)
    print(
        f"wrote {out} ({args.frames} frame{'s' if args.frames != 1 else ''}, {len(scene.mirrors)} "
        "mirrors)"
    )
    # at 90 degrees or more no ray goes on through the second mirror
    if args.kaleidoscope and (args.angle is None or args.angle >= 90):
        print(
            f"note: hinged at {args.angle or 120:g} degrees the mirrors show no view through two "
            "of them; --angle 72 gives such views"
        )
    return 0


def _scene(args: argparse.Namespace) -> Scene:
    """The scene file, or the layout the options describe (the paper's V, a hinged pair, an arc)."""
    if args.scene is not None:
        given = [f"--{k}" for k in _LAYOUT_OPTIONS if getattr(args, k) not in (None, False)]
        if given:
            raise MirrorscanError(f"--scene describes the whole rig; drop {', '.join(given)}")
        return load_scene(args.scene)
    angle, distance = 120.0 if args.angle is None else args.angle, args.distance
    if not args.kaleidoscope:
        return paper_scene(angle, args.mirrors or 2, args.object or "sphere", distance)
    if args.mirrors not in (None, 2):
        raise MirrorscanError(
            f"--kaleidoscope: a hinged pair has 2 mirrors, got --mirrors {args.mirrors}"
        )
    return kaleidoscope_scene(angle, args.object or "sphere", distance)
