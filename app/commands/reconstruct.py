"""`mirrorscan reconstruct SESSION -o OUT`.

The merged cloud of frames, a carved cloud or a fused mesh, as PLY (or GLB by OUT's suffix).

--method raw is the paper's Algorithm 1, paper its Algorithm 2 as written, carve the consistent
carving, tsdf a fused mesh; with `--frame all`, one PLY per frame and a manifest, on this machine's
cores or a Dask cluster (mirrorcore.batch).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from tqdm import tqdm

from mirrorcore.base.budget import check_memory
from mirrorcore.base.errors import Cancelled, MirrorscanError
from mirrorcore.base.palette import MAX_ORDER
from mirrorcore.batch import read_depth
from mirrorcore.batch.executor import WORKERS_PER_CORE
from mirrorcore.batch.job import COLOURS
from mirrorcore.batch.manifest import LOCK_FILE, MANIFEST_FILE
from mirrorcore.dense import METHODS, DenseOptions, dense_volume, reconstruct_dense
from mirrorcore.dense.carve import CarveResult
from mirrorcore.depth.files import require_readings
from mirrorcore.io.glb import write_result
from mirrorcore.io.outputs import check_output
from mirrorcore.io.session import Session
from mirrorcore.io.sessionfile import load_session
from mirrorcore.rig.model import Rig, calibrated_rig
from mirrorcore.rig.pipeline import object_cloud, prepare_frame

from . import ctrl_c_cancels, wording
from .numbers import real, whole
from .reconstruct_batch import run_all

# bytes a pixel of each frame fused takes: its prepared depth (float32) and mask, listed and
# stacked
PREPARED_BYTES = 10
# and with colour frames: the colour (RGB) listed and stacked, and packed for fusion (RGB1)
COLOUR_BYTES = 10
# the dense methods' voxel edge: from a tenth of a millimetre to a metre
VOXEL_METRES = (1e-4, 1.0)
# the largest length or coordinate in metres (margin, box, threshold, truncation)
LENGTH_METRES = 100.0


def register(sub) -> None:
    """Add `mirrorscan reconstruct` to the command line; its parser's `run` default is `run`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The `mirrorscan` parser's subcommands.
    """
    p = sub.add_parser("reconstruct", help="the object's merged cloud (Algorithm 1) as PLY")
    p.add_argument("session", help="session folder (calibrated: run `mirrorscan calibrate` first)")
    p.add_argument(
        "-o",
        "--output",
        required=True,
        help="PLY file (GLB when it ends in .glb), or with --frame all a folder of PLY files "
        "(new, or one this command made: it goes on)",
    )
    p.add_argument(
        "--frame", default="0", help="frame index (0-based, negative from the end) or 'all'"
    )
    p.add_argument(
        "--method",
        choices=["raw", *METHODS],
        default="raw",
        help="raw: Algorithm 1 (cloud); paper: Algorithm 2 as written (carved cloud); carve: "
        "consistent carving (cloud); tsdf: fusion of --frames frames (mesh)",
    )
    p.add_argument(
        "--voxel",
        type=real(*VOXEL_METRES, "metres"),
        default=DenseOptions.voxel,
        help=f"dense methods: voxel edge, metres ({VOXEL_METRES[0]:g} to {VOXEL_METRES[1]:g})",
    )
    p.add_argument(
        "--margin",
        type=real(0, LENGTH_METRES, "metres"),
        default=DenseOptions.margin,
        help="dense methods: metres added around the raw cloud's bounding box",
    )
    p.add_argument(
        "--bounds",
        type=real(-LENGTH_METRES, LENGTH_METRES, "metres"),
        nargs=6,
        metavar=("X0", "Y0", "Z0", "X1", "Y1", "Z1"),
        help="dense methods: the box in metres (camera frame) instead of the automatic one",
    )
    p.add_argument(
        "--threshold",
        type=real(0, LENGTH_METRES, "metres", above=True),
        help="paper, carve: th in metres (default: the voxel size)"
    )
    p.add_argument(
        "--truncation",
        type=real(0, LENGTH_METRES, "metres", above=True),
        help="tsdf: truncation in metres (default: 3 voxels)"
    )
    p.add_argument(
        "--frames",
        type=whole(1),
        default=1,
        help="tsdf: fuse this many frames from --frame on (static object)",
    )
    p.add_argument(
        "--temporal",
        type=whole(0),
        default=0,
        metavar="N",
        help="smooth each frame's depth with its N neighbours on each side where the scene is "
        "static (moving people; default 0: off)",
    )
    p.add_argument(
        "--colour",
        choices=COLOURS,
        default="scene",
        help="the points' red, green, blue: scene (default): the scene's colour when the session "
        "has colour frames, each mirror's colour gain undone; source: the source colours",
    )
    batch = p.add_argument_group(
        "--frame all (one PLY per frame and manifest.json in the folder OUT; a rerun does only "
        "the frames missing)"
    )
    batch.add_argument(
        "--workers",
        type=int,
        help="local worker processes (default: one per core; 1: in this process, without Dask; "
        f"at most {WORKERS_PER_CORE} per core)",
    )
    batch.add_argument(
        "--scheduler",
        metavar="tcp://HOST:8786",
        help="run on this existing Dask cluster (the session and OUT on a file system all workers "
        "share)",
    )
    batch.add_argument(
        "--frames-per-task",
        type=whole(1),
        metavar="N",
        help="frames in one Dask task (default 8 raw, 1 dense; the last tasks are smaller)",
    )
    batch.add_argument(
        "--overwrite",
        action="store_true",
        help="redo every frame when OUT was made with another calibration or options",
    )
    add_bounces_option(p)
    p.set_defaults(run=run)


def read_scan_frame(session: Session, index: int, temporal: int = 0) -> np.ndarray:
    """Frame `index` as depth, smoothed with `temporal` neighbours (batch.read_depth).

    Refused when it has no reading at all (nothing to scan in it). `--frame all` reads frames as
    they are: a recording may begin with blank frames while the camera starts.

    Parameters
    ----------
    session : Session
    index : int
        The frame's index.
    temporal : int, optional
        Neighbours on each side to smooth with.

    Returns
    -------
    np.ndarray, shape (H, W)
        Metres.

    Raises
    ------
    MirrorscanError
        When every pixel of the frame is 0.
    """
    return require_readings(
        read_depth(session, index, temporal), str(Path(session.root) / session.frames[index])
    )


def add_bounces_option(p) -> None:
    """Add --bounces, for the commands that reconstruct (reconstruct, serve).

    Parameters
    ----------
    p : argparse.ArgumentParser
    """
    p.add_argument(
        "--bounces",
        type=whole(1, MAX_ORDER),
        help=f"follow a camera ray through at most this many mirrors in turn, 1 to {MAX_ORDER} "
        f"(default: the session's setting, {MAX_ORDER} unless set)",
    )


def run(args: argparse.Namespace) -> int:
    """Reconstruct one frame (a merged cloud, or a dense result) or every frame, as PLY.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit status: 0; see run_all for --frame all.

    Raises
    ------
    MirrorscanError
        When --frame is neither an integer nor 'all', or the output is a batch's record.
    """
    session = load_session(args.session)
    rig = calibrated_rig(session, args.bounces)
    selection = session.selection
    background = session.read_background()
    # never over a session's files or its own input
    out = check_output(args.output, (args.session,))
    if args.frame != "all":
        try:
            index = int(args.frame)
        except ValueError:
            raise MirrorscanError(
                f"--frame: expected an integer or 'all', got {args.frame!r}"
            ) from None
        _not_over_a_batch_record(out)
        if args.method != "raw":
            return run_dense(args, rig, session, index, background, selection, out)
        depth = read_scan_frame(session, index, args.temporal)
        colour = session.read_colour(index) if args.colour == "scene" else None
        cloud, _ = object_cloud(rig, depth, background, selection, colour)
        _refuse_empty(out, len(cloud), "object's cloud", "the background and the depth range")
        rgb = None if cloud.rgb is None else np.ascontiguousarray(cloud.rgb)
        write_result(out, cloud.points, cloud.sources, colours=rgb)
        counts = cloud.source_counts(len(rig.mirrors))
        wording.show(wording.cloud_written(out, len(cloud), counts,
                                           wording.colours_line(args.colour, session)),
                     args.verbose)
        return 0
    return run_all(args, out, _dense_options(args))


def _not_over_a_batch_record(out: Path) -> None:
    """Refuse one frame over a batch folder's manifest or lock (a rerun goes on from them)."""
    if out.name in (MANIFEST_FILE, LOCK_FILE) and out.exists():
        raise MirrorscanError(
            f"{out}: would write over the record of the batch in {out.parent} (a rerun goes on "
            "from it); write the output elsewhere"
        )


def run_dense(
    args: argparse.Namespace,
    rig: Rig,
    session: Session,
    index: int,
    background,
    selection,
    out: Path,
) -> int:
    """Carve or fuse the frames from `index` on (mirrorcore.dense) with a progress bar.

    The bar is cleared at the end (a refusal stays one line); Ctrl-C cancels, nothing is
    written then.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    rig : Rig
    session : Session
    index : int
        The first frame (negative: from the end).
    background : np.ndarray, shape (H, W), or None
        Metres.
    selection : Selection
        The object's selection.
    out : Path
        The PLY file to write.

    Returns
    -------
    int
        The exit status: 0.

    Raises
    ------
    MirrorscanError
        When --frames is below 1 or runs past the session's end; MemoryBudgetError when its
        frames would not fit in the memory budget.
    """
    count = args.frames if args.method == "tsdf" else 1
    first = (
        index % len(session.frames)
        if -len(session.frames) <= index < len(session.frames)
        else index
    )
    if first + count > len(session.frames):
        raise MirrorscanError(
            f"--frames: the session has {len(session.frames)} frames, {first} + {count} is past "
            "the end"
        )
    pixel_bytes = PREPARED_BYTES + (COLOUR_BYTES if session.colour_frames else 0)
    check_memory(float(count) * session.camera.width * session.camera.height * pixel_bytes,
                 f"--frames {count}: {count:,} frames of "
                 f"{session.camera.width}x{session.camera.height} at once")
    prepared = [
        prepare_frame(rig, read_scan_frame(session, i, args.temporal), background, selection)
        for i in range(first, first + count)
    ]
    depths, masks = (np.stack(a) for a in zip(*prepared))
    colours = [session.read_colour(i) if args.colour == "scene" else None
               for i in range(first, first + count)]
    options = _dense_options(args)
    volume = dense_volume(rig, depths[0], masks[0], options)
    with (
        tqdm(
            total=1.0,
            desc=args.method,
            unit="volume",
            leave=False,
            bar_format="{l_bar}{bar}| {elapsed}",
        ) as bar,
        ctrl_c_cancels() as cancel,
    ):
        try:
            result = reconstruct_dense(
                rig,
                depths,
                masks,
                volume,
                args.method,
                options,
                progress=lambda f: bar.update(f - bar.n),
                cancel=cancel,
                colours=None if colours[0] is None else np.stack(colours),
            )
        except Cancelled:
            raise KeyboardInterrupt from None
    if isinstance(result, CarveResult):
        points, sources = result.surface_points()
        _refuse_empty(out, len(points), "carved surface", "--voxel, --bounds and --margin")
        write_result(out, points, sources, colours=result.colours)
        message = wording.carved_written(out, len(points), volume.shape, volume.voxel)
    else:
        mesh = result.mesh()
        _refuse_empty(out, len(mesh.vertices), "mesh", "--voxel, --bounds and --margin")
        write_result(out, mesh.vertices, mesh.sources, mesh.faces, colours=mesh.colours)
        message = wording.mesh_written(
            out, len(mesh.vertices), len(mesh.faces), count, volume.shape, volume.voxel
        )
    wording.show(message, args.verbose)
    return 0


def _refuse_empty(out: Path, count: int, what: str, check: str) -> None:
    """Refuse to write an empty result (MirrorscanError naming the file) when `count` is 0."""
    if count == 0:
        raise MirrorscanError(f"{out}: the {what} is empty, nothing written; check {check}")


def _dense_options(args: argparse.Namespace) -> DenseOptions:
    """The dense options of the command line (metres)."""
    return DenseOptions(
        args.voxel,
        args.margin,
        None if args.bounds is None else (tuple(args.bounds[:3]), tuple(args.bounds[3:])),
        args.threshold,
        args.truncation,
    )
