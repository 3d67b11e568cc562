"""The live loop: read a frame from the source, select the object, run Algorithm 1, hand the result to the view;
on its own thread, with pause, single steps, and a measured frame rate."""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from mirrorcore.cloud import Cloud
from mirrorcore.pipeline import object_cloud
from mirrorcore.sources import DepthSource

from .state import SharedState, Snapshot


@dataclass(frozen=True, eq=False)
class LiveFrame:
    """One processed frame: its index, depth (H, W) metres, object mask (H, W) bool, merged cloud, and the snapshot
    (session, rig) it was processed with; process_ms is the time from reading to the cloud."""

    index: int
    depth: np.ndarray
    mask: np.ndarray
    cloud: Cloud
    snapshot: Snapshot
    process_ms: float


def process_frame(snapshot: Snapshot, index: int, depth: np.ndarray) -> LiveFrame:
    t0 = time.perf_counter()
    cloud, mask = object_cloud(snapshot.rig, depth, snapshot.background, snapshot.selection)
    return LiveFrame(index, depth, mask, cloud, snapshot, (time.perf_counter() - t0) * 1e3)


class RateMeter:
    """Frames per second over a sliding window of the last `window` frame times."""

    def __init__(self, window: int = 30):
        self._times: list[float] = []
        self._window = window

    def tick(self, now: float) -> None:
        self._times = (self._times + [now])[-self._window:]

    @property
    def fps(self) -> float:
        if len(self._times) < 2:
            return 0.0
        return (len(self._times) - 1) / max(self._times[-1] - self._times[0], 1e-9)


class LiveLoop:
    """Runs source -> process_frame -> on_frame on a daemon thread, at most at the source's frame rate.

    on_frame(LiveFrame) is called on the loop's thread; an exception in it or in the source is passed to on_error
    and the loop goes on with the next frame after a short pause (a camera may come back).
    """

    def __init__(self, source: DepthSource, state: SharedState, on_frame: Callable[[LiveFrame], None],
                 on_error: Callable[[Exception], None] = lambda exc: None):
        self.source, self.state, self.on_frame, self.on_error = source, state, on_frame, on_error
        self.rate = RateMeter()
        self.index = 0
        self._paused = threading.Event()
        self._step = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="mirrorscan-live", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._step.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5)

    @property
    def paused(self) -> bool:
        return self._paused.is_set()

    def pause(self, paused: bool) -> None:
        (self._paused.set if paused else self._paused.clear)()
        self._step.set()  # wake the loop

    def step(self) -> None:
        """Process exactly one more frame while paused."""
        self._step.set()

    def run_once(self) -> LiveFrame:
        """Read and process the next frame on the calling thread (also what the thread does each turn)."""
        frame = process_frame(self.state.current, self.index, self.source.read(self.index).depth)
        self.index += 1
        self.on_frame(frame)
        self.rate.tick(time.perf_counter())
        return frame

    def _run(self) -> None:
        period = 1.0 / self.source.fps
        while not self._stop.is_set():
            if self._paused.is_set():
                self._step.wait()
                if self._stop.is_set():
                    break
                if not self._step.is_set():
                    continue
            self._step.clear()
            started = time.perf_counter()
            try:
                self.run_once()
            except Exception as exc:  # noqa: BLE001 - a bad frame or a lost camera must not end the loop
                self.on_error(exc)
                self._stop.wait(0.5)
            self._stop.wait(max(0.0, period - (time.perf_counter() - started)))
