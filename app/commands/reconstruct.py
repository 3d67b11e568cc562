"""`mirrorscan reconstruct SESSION -o OUT [--frame I|all] [--method raw|paper|carve|tsdf]`: the merged cloud of frames
(Algorithm 1), a carved cloud (Algorithm 2 as written, or the consistent carving) or a fused mesh, as PLY."""
from __future__ import annotations

import argparse
import signal
import threading
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from tqdm import tqdm

from mirrorcore.atomic import new_folder
from mirrorcore.dense import METHODS, DenseOptions, dense_volume, reconstruct_dense
from mirrorcore.dense.carve import CarveResult
from mirrorcore.depthio import require_readings
from mirrorcore.errors import Cancelled, MirrorscanError
from mirrorcore.outputs import check_output
from mirrorcore.palette import MAX_ORDER, source_name
from mirrorcore.pipeline import object_cloud, prepare_frame
from mirrorcore.ply import write_ply
from mirrorcore.rig import Rig
from mirrorcore.session import Session, load_session


def register(sub) -> None:
    p = sub.add_parser("reconstruct", help="the object's merged cloud (Algorithm 1) as PLY")
    p.add_argument("session", help="session folder (calibrated: run `mirrorscan calibrate` first)")
    p.add_argument("-o", "--output", required=True, help="PLY file, or a new folder of PLY files with --frame all")
    p.add_argument("--frame", default="0", help="frame index (0-based, negative from the end) or 'all'")
    p.add_argument("--method", choices=["raw", *METHODS], default="raw",
                   help="raw: the paper's Algorithm 1; paper: its Algorithm 2 as written (carved cloud); carve: the "
                        "consistent carving (cloud); tsdf: fusion of every view of --frames frames (mesh)")
    p.add_argument("--voxel", type=float, default=DenseOptions.voxel, help="dense methods: voxel edge, metres")
    p.add_argument("--margin", type=float, default=DenseOptions.margin,
                   help="dense methods: metres added around the raw cloud's bounding box")
    p.add_argument("--bounds", type=float, nargs=6, metavar=("X0", "Y0", "Z0", "X1", "Y1", "Z1"),
                   help="dense methods: the box in metres (camera frame) instead of the automatic one")
    p.add_argument("--threshold", type=float, help="paper, carve: th in metres (default: the voxel size)")
    p.add_argument("--truncation", type=float, help="tsdf: truncation in metres (default: 3 voxels)")
    p.add_argument("--frames", type=int, default=1, help="tsdf: fuse this many frames from --frame on (static object)")
    add_bounces_option(p)
    p.set_defaults(run=run)


def add_bounces_option(p) -> None:
    """--bounces, for the commands that reconstruct (reconstruct, serve)."""
    p.add_argument("--bounces", type=int, help=f"follow a camera ray through at most this many mirrors in turn, 1 to "
                                               f"{MAX_ORDER} (default: the session's setting, {MAX_ORDER} unless set)")


def calibrated_rig(session: Session, bounces: int | None = None) -> Rig:
    """The session's rig followed through `bounces` mirrors (default: the session's setting), refusing mirrors that
    cannot reconstruct (no plane or no boundary)."""
    if not session.mirrors:
        raise MirrorscanError(f"{session.path}: the session has no mirrors")
    for m in session.mirrors:
        if m.plane is None:
            raise MirrorscanError(f"{session.path}: {m.name} has no plane; run `mirrorscan calibrate {session.root}`")
        if not m.boundary:
            raise MirrorscanError(f"{session.path}: {m.name} has no boundary polygon")
    return Rig.from_session(session, bounces)


def read_scan_frame(session: Session, index: int) -> np.ndarray:
    """Frame `index` as (H, W) metres, refused when it has no reading at all (nothing to scan in it). `--frame all`
    reads frames as they are: a recording may begin with blank frames while the camera starts."""
    return require_readings(session.read_frame(index), str(Path(session.root) / session.frames[index]))


def run(args: argparse.Namespace) -> int:
    session = load_session(args.session)
    rig = calibrated_rig(session, args.bounces)
    selection = session.selection
    background = session.read_background()
    out = check_output(args.output, (args.session,))   # never over a session's files or its own input
    if args.frame != "all":
        try:
            index = int(args.frame)
        except ValueError:
            raise MirrorscanError(f"--frame: expected an integer or 'all', got {args.frame!r}") from None
        if args.method != "raw":
            return run_dense(args, rig, session, index, background, selection, out)
        cloud, _ = object_cloud(rig, read_scan_frame(session, index), background, selection)
        write_ply(out, cloud.points, cloud.sources)
        print(f"wrote {out}: {len(cloud)} points " + ", ".join(
            f"{source_name(k)} {v}" for k, v in cloud.source_counts(len(rig.mirrors)).items()))
        return 0
    if args.method != "raw":
        raise MirrorscanError(f"--frame all: only with --method raw; {args.method} makes one result from one frame "
                              "(tsdf: --frames N fuses N frames)")
    with new_folder(out) as work:   # a failure or Ctrl-C leaves no half-written folder
        for i in tqdm(range(len(session.frames)), desc="reconstruct", unit="frame"):
            cloud, _ = object_cloud(rig, session.read_frame(i), background, selection)
            write_ply(work / f"{Path(session.frames[i]).stem}.ply", cloud.points, cloud.sources)
    print(f"wrote {len(session.frames)} PLY files into {out}")
    return 0


def run_dense(args: argparse.Namespace, rig: Rig, session: Session, index: int, background, selection,
              out: Path) -> int:
    """Carve or fuse frames index.. (see mirrorcore.dense) with a progress bar; Ctrl-C cancels, nothing is written."""
    count = args.frames if args.method == "tsdf" else 1
    if count < 1:
        raise MirrorscanError(f"--frames: expected a positive number, got {count}")
    first = index % len(session.frames) if -len(session.frames) <= index < len(session.frames) else index
    if first + count > len(session.frames):
        raise MirrorscanError(f"--frames: the session has {len(session.frames)} frames, "
                              f"{first} + {count} is past the end")
    prepared = [prepare_frame(rig, read_scan_frame(session, i), background, selection)
                for i in range(first, first + count)]
    depths, masks = (np.stack(a) for a in zip(*prepared))
    options = DenseOptions(args.voxel, args.margin, None if args.bounds is None else
                           (tuple(args.bounds[:3]), tuple(args.bounds[3:])), args.threshold, args.truncation)
    volume = dense_volume(rig, depths[0], masks[0], options)
    with tqdm(total=1.0, desc=args.method, unit="volume", bar_format="{l_bar}{bar}| {elapsed}") as bar, \
            _ctrl_c_cancels() as cancel:
        try:
            result = reconstruct_dense(rig, depths, masks, volume, args.method, options,
                                       progress=lambda f: bar.update(f - bar.n), cancel=cancel)
        except Cancelled:
            raise KeyboardInterrupt from None
    shape = "x".join(map(str, volume.shape))
    if isinstance(result, CarveResult):
        points, sources = result.surface_points()
        write_ply(out, points, sources)
        print(f"wrote {out}: {len(points)} surface voxels of a {shape} volume ({volume.voxel * 1e3:g} mm)")
    else:
        mesh = result.mesh()
        write_ply(out, mesh.vertices, mesh.sources, mesh.faces)
        print(f"wrote {out}: mesh of {len(mesh.vertices)} vertices, {len(mesh.faces)} faces from {count} frame(s), "
              f"{shape} volume ({volume.voxel * 1e3:g} mm)")
    return 0


@contextmanager
def _ctrl_c_cancels():
    """While inside, Ctrl-C sets the yielded threading.Event (the computation stops at its next slab) instead of
    interrupting at an arbitrary point; the previous handler is restored on the way out."""
    event = threading.Event()
    previous = signal.signal(signal.SIGINT, lambda *_: event.set())
    try:
        yield event
    finally:
        signal.signal(signal.SIGINT, previous)
