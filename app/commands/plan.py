"""`mirrorscan plan -o PLAN_DIR`: search a rig's layout for a subject in a room (plan.json,
scene.json; docs/planning.md)."""

from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path

from mirrorcore.base.atomic import new_folder
from mirrorcore.base.errors import Cancelled, MirrorscanError
from mirrorcore.base.palette import MAX_MIRRORS
from mirrorcore.io.outputs import check_output
from mirrorcore.plan.planfile import PLAN_FILE, write_plan
from mirrorcore.plan.report import write_documents
from mirrorcore.plan.search import PlanResult, plan_rig
from mirrorcore.plan.setup import CAMERA_PRESETS, parse_room, plan_camera
from mirrorcore.plan.subject import SPEC_HELP, parse_spec
from mirrorcore.sim.render import MAX_BOUNCES

from ..plandesk import PlanDesk
from ..planapp import PlanApp
from . import ctrl_c_cancels, percent_bar, wording
from .numbers import real, whole
from .serve import wait_for_stop

log = logging.getLogger("mirrorscan")

DEFAULT_ROOM = "3.0,3.6"
DEFAULT_SIZE = "0.8,1.9"


def register(sub) -> None:
    """Add `mirrorscan plan` to the command line; its parser's `run` default is `run`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The `mirrorscan` parser's subcommands.
    """
    p = sub.add_parser("plan", help="search the mirrors' layout that sees most of a subject in "
                       "a room (plan.json, scene.json)")
    p.add_argument("-o", "--out", required=True, metavar="PLAN_DIR",
                   help="the plan folder to create (must not exist, or be empty)")
    p.add_argument("--subject", required=True, metavar="SPEC", help=SPEC_HELP)
    p.add_argument("--mirrors", type=whole(2, MAX_MIRRORS), required=True,
                   help="number of mirrors")
    p.add_argument("--mirror-size", default=DEFAULT_SIZE, metavar="W,H",
                   help=f"the largest mirror, width and height in metres (default "
                   f"{DEFAULT_SIZE}); the search may use smaller ones")
    p.add_argument("--room", default=DEFAULT_ROOM, metavar="W,D[,H]",
                   help=f"the room in metres: W wide centred on the camera, D deep from the "
                   f"camera forward, H high (default {DEFAULT_ROOM},2.5)")
    p.add_argument("--distance", type=real(0.1, 100, "metres", above=True),
                   help="camera to the subject's middle, metres (default: searched)")
    p.add_argument("--camera", default="kinect_v1",
                   help=f"{', '.join(CAMERA_PRESETS)} (default kinect_v1) or an Open3D "
                   "intrinsics JSON or OpenCV camera YAML file")
    p.add_argument("--camera-height", type=real(0, 10, "metres", above=True), default=1.0,
                   metavar="H", help="the camera's height above the floor, metres (default 1.0)")
    p.add_argument("--bounces", type=whole(1, MAX_BOUNCES), default=1,
                   help=f"the most mirrors a view goes through in turn, 1 to {MAX_BOUNCES} "
                   "(default 1)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--serve", action="store_true",
                   help="then show the plan in the browser: drag the mirrors, optimise, save "
                   "it again into PLAN_DIR, simulate it (127.0.0.1 only)")
    p.add_argument("--port", type=whole(0, 65535), default=8080,
                   help="with --serve: port (default 8080; the next free one if taken)")
    p.set_defaults(run=run)


def _size(text: str) -> tuple[float, float]:
    """`--mirror-size W,H` in metres; MirrorscanError otherwise."""
    try:
        w, h = (float(v) for v in text.split(","))
    except ValueError:
        raise MirrorscanError(f"--mirror-size: {text!r} must be W,H in metres") from None
    if not (0.05 <= w <= 10 and 0.05 <= h <= 10):
        raise MirrorscanError(f"--mirror-size: {text!r}: each side must be 0.05 to 10 metres")
    return w, h


def run(args: argparse.Namespace) -> int:
    """Search the layout and write the plan folder.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit status: 0; with --serve, 130 once stopped.

    Raises
    ------
    MirrorscanError
        A bad SPEC, size, room or camera; a room that cannot hold the subject.
    """
    kind, values = parse_spec(args.subject)
    check_output(args.out, (values,) if kind == "mesh" else ())
    size = _size(args.mirror_size)
    room = parse_room(args.room, args.camera_height)
    camera = plan_camera(args.camera)
    # the folder is made whole at the end, or not at all
    with new_folder(args.out) as work:
        with ctrl_c_cancels() as cancel, percent_bar("plan", args.quiet) as bar:
            try:
                result = plan_rig(args.subject, args.mirrors, size, room, camera,
                                  args.distance, args.bounces, progress=bar, cancel=cancel)
            except Cancelled:
                raise KeyboardInterrupt from None
        write_plan(result, work)
        write_documents(work)
    plan = json.loads((Path(args.out) / PLAN_FILE).read_text(encoding="utf-8"))
    wording.show(wording.plan_written(Path(args.out), plan), args.verbose)
    return serve(result, Path(args.out), args.port) if args.serve else 0


def serve(result: PlanResult, folder: Path, port: int) -> int:
    """Serve the plan in the browser on 127.0.0.1 until Ctrl-C, SIGTERM or SIGHUP.

    Returns
    -------
    int
        130.
    """
    logging.basicConfig(level=logging.INFO,
                        format="%(asctime)s %(name)s %(levelname)s: %(message)s")
    app = PlanApp(PlanDesk(result), folder, port=port)
    log.info("the plan is at %s (Ctrl-C to stop)", app.guard.url)
    try:
        wait_for_stop()
        return 130
    finally:
        app.stop()
