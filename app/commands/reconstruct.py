"""`mirrorscan reconstruct SESSION -o OUT [--frame I|all] [--method raw]`: the merged cloud of frames as PLY."""
from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

from tqdm import tqdm

from mirrorcore.errors import MirrorscanError
from mirrorcore.pipeline import object_cloud, session_selection
from mirrorcore.ply import write_ply
from mirrorcore.rig import Rig
from mirrorcore.session import Session, load_session


def register(sub) -> None:
    p = sub.add_parser("reconstruct", help="the object's merged cloud (Algorithm 1) as PLY")
    p.add_argument("session", help="session folder (calibrated: run `mirrorscan calibrate` first)")
    p.add_argument("-o", "--output", required=True, help="PLY file, or a new folder of PLY files with --frame all")
    p.add_argument("--frame", default="0", help="frame index (0-based, negative from the end) or 'all'")
    p.add_argument("--method", choices=["raw"], default="raw",
                   help="raw: the paper's Algorithm 1 (space carving arrives with its own issue)")
    p.set_defaults(run=run)


def calibrated_rig(session: Session) -> Rig:
    """The session's rig, refusing mirrors that cannot reconstruct (no plane or no boundary)."""
    if not session.mirrors:
        raise MirrorscanError(f"{session.path}: the session has no mirrors")
    for m in session.mirrors:
        if m.plane is None:
            raise MirrorscanError(f"{session.path}: {m.name} has no plane; run `mirrorscan calibrate {session.root}`")
        if not m.boundary:
            raise MirrorscanError(f"{session.path}: {m.name} has no boundary polygon")
    return Rig.from_session(session)


def run(args: argparse.Namespace) -> int:
    session = load_session(args.session)
    rig = calibrated_rig(session)
    selection = session_selection(session)
    background = session.read_background()
    out = Path(args.output)
    if args.frame != "all":
        try:
            index = int(args.frame)
        except ValueError:
            raise MirrorscanError(f"--frame: expected an integer or 'all', got {args.frame!r}") from None
        cloud, _ = object_cloud(rig, session.read_frame(index), background, selection)
        write_ply(out, cloud.points, cloud.sources)
        print(f"wrote {out}: {len(cloud)} points " + ", ".join(f"{k} {v}" for k, v in
                                                                  cloud.counts(len(rig.mirrors)).items()))
        return 0
    if out.exists():
        raise MirrorscanError(f"{out}: already exists; give a new folder for --frame all")
    out.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:  # write into a hidden folder, rename it at the end: a failure or Ctrl-C leaves no half-written folder
        for i in tqdm(range(len(session.frames)), desc="reconstruct", unit="frame"):
            cloud, _ = object_cloud(rig, session.read_frame(i), background, selection)
            write_ply(work / f"{Path(session.frames[i]).stem}.ply", cloud.points, cloud.sources)
        work.rename(out)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"wrote {len(session.frames)} PLY files into {out}")
    return 0
