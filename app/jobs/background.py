"""The background capture job: the per-pixel median of the next frames."""

from __future__ import annotations

import threading
from typing import Callable

import numpy as np

from mirrorcore.depth.ops import median_depth

from ..results import BackgroundCaptured, Collecting
from .runner import BACKGROUND, Runner


class BackgroundJob(Runner):
    """Background capture (Jobs mixes it in)."""

    def capture_background(
        self, n_frames: int, on_done: Callable[[np.ndarray], bool]
    ) -> threading.Thread:
        """The per-pixel median of the next `n_frames` frames, handed to on_done.

        Parameters
        ----------
        n_frames : int
        on_done : callable
            Called with the median depth, (H, W) metres; returns whether it waits for the
            technician's confirmation.

        Returns
        -------
        threading.Thread
            The job's thread.
        """

        def work(cancel: threading.Event) -> BackgroundCaptured:
            frames = self.loop.collect(
                n_frames,
                lambda k: self.progress(BACKGROUND, k / n_frames, Collecting(k, n_frames)),
                cancel=cancel,
            )
            return BackgroundCaptured(n_frames, bool(on_done(median_depth(np.stack(frames)))))

        return self._start(BACKGROUND, work, "a background capture is already running")
