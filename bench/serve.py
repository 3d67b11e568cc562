"""Benchmark of the browser tool's live loop without a browser: the built-in demo (walking figure, two mirrors,
Kinect noise) read, selected, reconstructed and sent to the scene, frame after frame, as fast as it goes."""
from __future__ import annotations

import time
from pathlib import Path

from app.demo import calibrated_session, demo_source
from app.server import MirrorscanApp

FRAMES = 60


def run() -> dict[str, float]:
    source = demo_source()
    app = MirrorscanApp(calibrated_session(source, Path("unused")), source, port=0, autosave=False)
    try:
        for _ in range(5):                 # warm up: first frames build caches
            app.loop.run_once()
        start = time.perf_counter()
        for _ in range(FRAMES):
            app.loop.run_once()
        elapsed = time.perf_counter() - start
    finally:
        app.stop()
    return {"serve_loop_fps": FRAMES / elapsed}
