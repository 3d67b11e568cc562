"""`mirrorscan calibrate SESSION [--frame I]`: fit every mirror's plane and write it into session.json."""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from mirrorcore.calibration import calibrate_session
from mirrorcore.depthio import require_readings
from mirrorcore.errors import CalibrationError
from mirrorcore.session import Session, load_session, save_session

MAX_MEDIAN_FRAMES = 30


def register(sub) -> None:
    p = sub.add_parser("calibrate", help="fit every mirror's plane from its markers; write it into session.json")
    p.add_argument("session", help="session folder")
    p.add_argument("--frame", type=int, default=None,
                   help="use this frame only (default: per-pixel median of the background and up to "
                        f"{MAX_MEDIAN_FRAMES} frames)")
    p.add_argument("--method", choices=["markers", "region"], default="markers",
                   help="markers: the mirror's 'markers'; region: the mirror's 'region' polygon (its frame)")
    p.add_argument("--seed", type=int, default=0, help="RANSAC seed")
    p.set_defaults(run=run)


def calibration_depth(session: Session, frame: int | None) -> np.ndarray:
    """(k, H, W) metres: the frame asked for, or the background and up to MAX_MEDIAN_FRAMES evenly spaced frames."""
    if frame is not None:
        return require_readings(session.read_frame(frame)[None], str(Path(session.root) / session.frames[frame]))
    picks = np.unique(np.linspace(0, len(session.frames) - 1, min(len(session.frames), MAX_MEDIAN_FRAMES)).astype(int))
    stack = [session.read_frame(int(i)) for i in picks] if session.frames else []
    background = session.read_background()
    if background is not None:
        stack.append(background)
    if not stack:
        raise CalibrationError(f"{session.path}: no frames and no background to calibrate from")
    return require_readings(np.stack(stack), f"{session.path}: the frames and the background")


def run(args: argparse.Namespace) -> int:
    session = load_session(args.session)
    if not session.mirrors:
        raise CalibrationError(f"{session.path}: the session has no mirrors")
    depth = calibration_depth(session, args.frame)
    session, results = calibrate_session(session, depth, np.random.default_rng(args.seed), method=args.method)
    for i, result in results:
        print(f"{session.mirrors[i].name}: plane {np.round(result.plane.abcd, 5).tolist()}  {result.summary()}")
    save_session(session)
    print(f"wrote {session.path}")
    return 0
