"""The jobs of the plan served in the browser: the search from the layout as it stands
(*Optimise*), and the simulated rig of the layout (*Simulate*)."""

from __future__ import annotations

import threading
import time
from typing import Callable

from mirrorcore.base.progress import Progress

from ..plandesk import PlanDesk
from .runner import Runner

OPTIMISE, SIMULATE = "optimise", "simulate"


class PlanJobs(Runner):
    """One search and one simulated rig at a time, each on a worker thread; their end (cancelled,
    refused, failed) is published on the bus as a JobProgress."""

    def optimise(self, desk: PlanDesk, progress: Progress,
                 on_done: Callable[[float, float], None]) -> threading.Thread:
        """Search from the desk's layout; on_done(coverage before, seconds) once it is kept.

        Parameters
        ----------
        desk : PlanDesk
        progress : callable
            Called with the fraction done.
        on_done : callable
            Called on the job's thread with the coverage before and the seconds taken.

        Returns
        -------
        threading.Thread
        """

        def work(cancel: threading.Event) -> None:
            before = desk.coverage.coverage
            began = time.monotonic()
            desk.optimise(progress, cancel)
            on_done(before, time.monotonic() - began)

        return self._start(OPTIMISE, work, "the search already runs")

    def simulate(self, start: Callable[[], None]) -> threading.Thread:
        """Start the simulated rig of the layout (`start`, on the job's thread)."""

        def work(cancel: threading.Event) -> None:
            start()

        return self._start(SIMULATE, work, "the simulated rig is being started")
