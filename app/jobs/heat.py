"""The heat map job: the mirrors' points of a live frame coloured by their distance to the direct
surface."""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING

import numpy as np

from mirrorcore.base.palette import heat_map_colours
from mirrorcore.calibration.agreement import heat_figures, local_means, surface_distances

from ..events import HeatChanged
from ..liveframe import frame_number
from .runner import HEAT, Runner

if TYPE_CHECKING:
    from ..liveframe import LiveFrame

HEAT_LIMIT_MM = 10.0  # the heat map's colours saturate at this distance to the direct surface
# heat maps whose distances the legend's figures pool: on the sphere at the true planes one frame's
# median spreads by 0.5 mm, ten frames' by 0.1 to 0.2 mm (tests/test_app_live.py, the heat map's
# pool)
HEAT_POOL = 10


class HeatJob(Runner):
    """Heat maps (Jobs mixes it in): one at a time, their figures pooled over HEAT_POOL frames."""

    _heat_rig = None  # the planes of the heat maps pooled
    # frame number -> (distances, sources), oldest first
    _heat_pool: dict[int, tuple[np.ndarray, np.ndarray]]

    def start_heat(self, frame: "LiveFrame") -> None:
        """The heat map of one live frame, on a worker; skipped while one runs.

        Its points, grey for the direct view and coloured by their distance to the direct surface
        for the mirrors' (white on it, red outside, blue inside, HEAT_LIMIT_MM and beyond saturated;
        dark grey where the camera does not see them), and each mirror view's figures, published as
        HeatChanged.

        Parameters
        ----------
        frame : LiveFrame
        """
        if self.running(HEAT):
            return

        def work(cancel: threading.Event) -> None:
            distances = surface_distances(frame.snapshot.rig, frame.cloud, frame.prepared_depth)
            sources = frame.cloud.sources
            local = local_means(
                distances, frame.cloud.pixel_index, sources, frame.prepared_depth.shape
            )
            colours = heat_map_colours(local, sources, HEAT_LIMIT_MM)
            pooled = self._pool_heat(
                frame.snapshot.rig,
                frame_number(frame.index, self.loop.source.frame_count),
                distances,
                sources,
            )
            figures = heat_figures(*(np.concatenate(parts) for parts in zip(*pooled)))
            self.bus.publish(
                HeatChanged(frame.index, frame.cloud.points, colours, figures, len(pooled), sources)
            )

        self._start(HEAT, work, "")

    def heat_wanted(self, frame: "LiveFrame") -> bool:
        """Whether a heat map of `frame` adds to the legend's pool.

        Not when the pool, not yet full, has this frame of a replay with these planes. A live
        camera's frames are all new.

        Parameters
        ----------
        frame : LiveFrame

        Returns
        -------
        bool
        """
        count = self.loop.source.frame_count
        if not count or frame.snapshot.rig is not self._heat_rig:
            return True
        return frame_number(frame.index, count) not in self._heat_pool or len(
            self._heat_pool
        ) >= min(HEAT_POOL, count)

    def _pool_heat(
        self, rig, number: int, distances: np.ndarray, sources: np.ndarray
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """The (distances, sources) of the last HEAT_POOL frames' heat maps with the same planes.

        This one (frame `number`, as the header counts it) last. A frame met again takes its place
        anew; a new calibration starts a new pool.
        """
        if self._heat_rig is not rig:
            self._heat_rig, self._heat_pool = rig, {}
        self._heat_pool.pop(number, None)
        self._heat_pool[number] = (distances, sources)
        while len(self._heat_pool) > HEAT_POOL:
            del self._heat_pool[next(iter(self._heat_pool))]
        return list(self._heat_pool.values())
