"""Benchmark of the browser tool's live loop with one tab attached.

The tab is bench.tabs.HeadlessTab, a websocket client that reads what a browser would; the built-in
demo (walking figure, two mirrors, Kinect noise), its frames and colour images rendered beforehand
so that reading the source costs nothing. The tab shows the cloud in true colour (its default).

serve_loop_fps : frames per second as fast as the loop goes, the tab looking at the 3D scene (the
    cloud each frame)
live_cpu_ms : the loop thread's CPU time per frame at the demo's 30 fps, the depth frame included:
    the larger of the tab looking at the 3D scene (the cloud each frame, the depth frame once a
    second) and at the depth frame (eight times a second, no cloud)
live_kb_per_frame : kilobytes the tab receives per frame over the websocket at 30 fps, looking at
    the 3D scene, the cloud in true colour (each point's colour, 3 bytes, beside its 6-byte offset)
live_points : points a frame carries to the tab (all of the cloud: none are dropped to save
    bandwidth)
click_ms : from a click on the depth frame (a marker added) until the depth frame that shows it is
    sent to the tab, the demo running at 30 fps meanwhile (median of 10 clicks; the page's part,
    decoding and drawing, is measured in Chromium by the browser tests)
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np

from mirrorscan.demo import calibrated_session, demo_source
from mirrorscan.jobs import AGREEMENT
from mirrorscan.server import MirrorscanApp
from mirrorscan.bench.tabs import HeadlessTab, wait_for
from mirrorcore.sources import StackSource

FRAMES = 60
FPS = 30.0


def demo_frames(n: int) -> StackSource:
    """The demo's first n frames, in memory.

    Parameters
    ----------
    n : int

    Returns
    -------
    StackSource
        At FPS frames a second, with the demo's background and its colour images.
    """
    source = demo_source()
    frames = [source.read(i) for i in range(n)]
    depth = np.stack([frame.depth for frame in frames])
    colour = np.stack([frame.colour for frame in frames])
    replay = StackSource("demo frames", source.intrinsics, depth, 1.0, np.arange(n) / FPS,
                         colour, fps=FPS)
    replay.background = source.background
    return replay


def paced(app: MirrorscanApp, tab: HeadlessTab | None, frames: int) -> tuple[float, float]:
    """Run `frames` frames of the app's live loop at FPS.

    Parameters
    ----------
    app : MirrorscanApp
    tab : HeadlessTab or None
        The tab whose received bytes are counted.
    frames : int

    Returns
    -------
    cpu_ms : float
        Mean CPU ms of the loop's thread per frame.
    kb : float
        kB the tab received per frame; 0 without a tab.
    """
    cpu, received = 0.0, tab.bytes if tab else 0
    for _ in range(frames):
        start, used = time.perf_counter(), time.thread_time()
        app.loop.run_once()
        cpu += time.thread_time() - used
        time.sleep(max(0.0, 1 / FPS - (time.perf_counter() - start)))
    if tab is None:
        return cpu / frames * 1e3, 0.0
    time.sleep(0.5)  # what is on its way reaches the tab
    return cpu / frames * 1e3, (tab.bytes - received) / frames / 1e3


def run() -> dict[str, float]:
    """The served app with one headless tab: the loop's rate, CPU and bytes per frame, and click_ms.

    Returns
    -------
    dict of str to float
        {figure name: value}.
    """
    source = demo_frames(FRAMES)
    demo = demo_source()
    app = MirrorscanApp(calibrated_session(demo, Path("unused")), source, port=0, autosave=False)
    try:
        with HeadlessTab(app) as tab:
            # warm up: the first frames build caches, grade markers and check the views'
            # agreement (on a worker)
            for _ in range(10):
                app.loop.run_once()
            wait_for(lambda: not app.jobs.running(AGREEMENT), 60, "the agreement")
            time.sleep(1.0)
            start = time.perf_counter()
            for _ in range(FRAMES):
                app.loop.run_once()
            fps = FRAMES / (time.perf_counter() - start)
            time.sleep(1.0)
            cpu_3d, kb_3d = paced(app, tab, FRAMES)
            tab.tab.look("depth")
            cpu_depth, _ = paced(app, tab, FRAMES)
            click = click_ms(app, tab.tab)
            points = sum(len(p.offsets) for p in app.last_frame.parts())
    finally:
        app.stop()
    return {
        "serve_loop_fps": fps,
        "live_cpu_ms": max(cpu_3d, cpu_depth),
        "live_cpu_3d_view_ms": cpu_3d,
        "live_cpu_depth_view_ms": cpu_depth,
        "live_kb_per_frame": kb_3d,
        "live_points": float(points),
        "click_ms": click,
    }


def click_ms(app: MirrorscanApp, tab, clicks: int = 10) -> float:
    """Median ms from a click adding a marker until the tab is sent a depth frame showing it.

    The tab is in its markers mode on mirror 1, looking at the depth frame, while another thread
    runs the live loop at FPS.

    Parameters
    ----------
    app : MirrorscanApp
    tab : Tab
        The app's Tab of a connected HeadlessTab.
    clicks : int, optional

    Returns
    -------
    float
    """
    target: list[tuple[int, int]] = []  # the pixel clicked last
    sent: list[float] = []  # when a depth frame showing it was sent
    show = tab.screen.show

    def show_and_note(rgb: np.ndarray) -> None:
        if target and tab.overlay.image[target[-1][1], target[-1][0], 3] > 0:
            sent.append(time.perf_counter())
        show(rgb)

    tab.screen.show = show_and_note
    tab.state.mirror_id, tab.state.mode = app.editor.session.mirrors[0].id, "markers"
    u, v = np.mean(np.array(app.editor.session.mirrors[0].boundary), axis=0)
    stop = threading.Event()

    def run_live() -> None:
        while not stop.is_set():
            paced(app, None, 1)

    live = threading.Thread(target=run_live)
    live.start()
    delays = []
    try:
        for k in range(clicks):
            time.sleep(0.3)
            # on mirror 1's glass, apart
            pixel = (int(u) + 30 * (k % 5) - 60, int(v) - 60 + 45 * (k // 5))
            assert tab.overlay.image[pixel[1], pixel[0], 3] == 0, (
                f"pixel {pixel} is drawn on already"
            )
            target.append(pixel)
            clicked = time.perf_counter()
            tab._clicked(*pixel)
            drawn = wait_for(
                lambda: [t for t in sent if t > clicked], 5, "the depth frame showing the marker"
            )
            delays.append((drawn[0] - clicked) * 1e3)
    finally:
        stop.set()
        live.join()
        tab.screen.show = show
    return float(np.median(delays))
