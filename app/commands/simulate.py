"""`mirrorscan simulate OUT [...]`: a session folder rendered by the simulated rig, plus truth.json."""
from __future__ import annotations

import argparse

from mirrorcore.errors import MirrorscanError
from mirrorcore.outputs import check_output
from mirrorcore.sim.export import write_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.scene import load_scene
from mirrorcore.sim.sensor import SensorModel
from mirrorcore.sim.simulator import Simulator

_LAYOUT_OPTIONS = ("object", "angle", "mirrors", "distance")


def register(sub) -> None:
    p = sub.add_parser("simulate", help="render a session folder with the simulated rig (and truth.json)")
    p.add_argument("out", help="the session folder to create (must not exist, or be empty)")
    p.add_argument("--object", help="sphere (default), cylinder, box, figure or mesh:PATH")
    p.add_argument("--angle", type=float, help="angle between the two mirrors, degrees (default 120)")
    p.add_argument("--mirrors", type=int, help="number of mirrors: 2 in a V (default), 3 or more on an arc")
    p.add_argument("--distance", type=float, help="camera to object, metres (default 2.0)")
    p.add_argument("--scene", help="a scene JSON file instead of the options above")
    p.add_argument("--noise", choices=["none", "kinect", "kinect-noiseless"], default="kinect",
                   help="sensor model (default kinect)")
    p.add_argument("--frames", type=int, default=1, help="number of frames at 30 fps (default 1)")
    p.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    p.add_argument("--single-bounce", action="store_true", help="leave out rays that reflect off two mirrors")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    mesh = args.object.removeprefix("mesh:") if args.object and args.object.startswith("mesh:") else None
    check_output(args.out, tuple(p for p in (args.scene, mesh) if p))
    if args.scene is not None:
        given = [f"--{k}" for k in _LAYOUT_OPTIONS if getattr(args, k) is not None]
        if given:
            raise MirrorscanError(f"--scene describes the whole rig; drop {', '.join(given)}")
        scene = load_scene(args.scene)
    else:
        if args.distance is not None and args.distance <= 0.5:
            raise MirrorscanError(f"--distance: must be more than 0.5 m, got {args.distance:g}")
        scene = paper_scene(120.0 if args.angle is None else args.angle, args.mirrors or 2, args.object or "sphere",
                            2.0 if args.distance is None else args.distance)
    rig = Simulator(scene, SensorModel.from_name(args.noise), args.seed, two_bounces=not args.single_bounce)
    out = write_session(rig, args.out, args.frames, args.noise, progress=not args.quiet)
    print(f"wrote {out} ({args.frames} frame{'s' if args.frames != 1 else ''}, {len(scene.mirrors)} mirrors)")
    return 0
