"""Benchmark of the browser tool's live loop with one tab attached (bench.tabs.HeadlessTab, a websocket client that
reads what a browser would): the built-in demo (walking figure, two mirrors, Kinect noise), its frames rendered
beforehand so that reading the source costs nothing.

serve_loop_fps     frames per second as fast as the loop goes, the tab looking at the 3D scene (the cloud each frame)
live_cpu_ms        the loop thread's CPU time per frame at the demo's 30 fps, the depth frame included: the larger
                   of the tab looking at the 3D scene (the cloud each frame, the depth frame once a second) and at
                   the depth frame (eight times a second, no cloud)
live_kb_per_frame  kilobytes the tab receives per frame over the websocket at 30 fps, looking at the 3D scene
live_points        points a frame carries to the tab (all of the cloud: none are dropped to save bandwidth)
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from app.demo import calibrated_session, demo_source
from app.server import MirrorscanApp
from bench.tabs import HeadlessTab
from mirrorcore.sources import StackSource

FRAMES = 60
FPS = 30.0


def demo_frames(n: int) -> StackSource:
    """The demo's first n frames, in memory."""
    source = demo_source()
    depth = np.stack([source.read(i).depth for i in range(n)])
    replay = StackSource("demo frames", source.intrinsics, depth, 1.0, np.arange(n) / FPS, fps=FPS)
    replay.background = source.background
    return replay


def paced(app: MirrorscanApp, tab: HeadlessTab, frames: int) -> tuple[float, float]:
    """Run `frames` frames at FPS; (mean CPU ms of the loop's thread per frame, kB the tab received per frame)."""
    cpu, received = 0.0, tab.bytes
    for _ in range(frames):
        start, used = time.perf_counter(), time.thread_time()
        app.loop.run_once()
        cpu += time.thread_time() - used
        time.sleep(max(0.0, 1 / FPS - (time.perf_counter() - start)))
    time.sleep(0.5)                                        # what is on its way reaches the tab
    return cpu / frames * 1e3, (tab.bytes - received) / frames / 1e3


def run() -> dict[str, float]:
    source = demo_frames(FRAMES)
    demo = demo_source()
    app = MirrorscanApp(calibrated_session(demo, Path("unused")), source, port=0, autosave=False)
    try:
        with HeadlessTab(app) as tab:
            for _ in range(10):                              # warm up: first frames build caches, grade markers
                app.loop.run_once()
            time.sleep(1.0)
            start = time.perf_counter()
            for _ in range(FRAMES):
                app.loop.run_once()
            fps = FRAMES / (time.perf_counter() - start)
            time.sleep(1.0)
            cpu_3d, kb_3d = paced(app, tab, FRAMES)
            tab.tab.look("depth")
            cpu_depth, _ = paced(app, tab, FRAMES)
            points = sum(len(p.offsets) for p in app.last_frame.parts)
    finally:
        app.stop()
    return {"serve_loop_fps": fps, "live_cpu_ms": max(cpu_3d, cpu_depth), "live_cpu_3d_view_ms": cpu_3d,
            "live_cpu_depth_view_ms": cpu_depth, "live_kb_per_frame": kb_3d, "live_points": float(points)}
