"""The thread runner of the long jobs: one job of each kind at a time, each on a worker thread of
its own, that can be cancelled and publishes its typed result on the bus once it is over."""

from __future__ import annotations

import logging
import threading
import time
from typing import Callable

from mirrorcore.base.errors import Cancelled as CancelledError
from mirrorcore.base.errors import MirrorscanError

from ..events import EventBus, JobProgress
from ..results import Cancelled, Failed, Refused
from ..wording.jobs import say, status

log = logging.getLogger("mirrorscan")
DENSE, BACKGROUND, RECORD, BATCH = "dense", "background", "record", "batch"
REFINE, AGREEMENT, HEAT = "refine", "agreement", "heat"


class Runner:
    """Runs one job of each kind at a time; starting a kind while one runs is refused by name.

    Parameters
    ----------
    bus : EventBus
        Carries the jobs' progress and results.
    """

    def __init__(self, bus: EventBus):
        self.bus = bus
        # kind -> its cancel event, while it runs
        self._running: dict[str, threading.Event] = {}
        self._threads: dict[str, threading.Thread] = {}  # kind -> its last thread
        self._lock = threading.Lock()

    def running(self, kind: str) -> bool:
        """Whether a job of `kind` runs.

        Parameters
        ----------
        kind : str

        Returns
        -------
        bool
        """
        with self._lock:
            return kind in self._running

    def cancel(self, kind: str) -> None:
        """Ask the job of `kind` that runs, if any, to stop.

        Parameters
        ----------
        kind : str
        """
        with self._lock:
            event = self._running.get(kind)
        if event is not None:
            event.set()

    def progress(self, kind: str, fraction: float | None, result: object) -> None:
        """Publish how a job stands (JobProgress): `result` typed, and its words beside it.

        The words are wording.jobs.status of the result.

        Parameters
        ----------
        kind : str
        fraction : float or None
            The fraction done, if known.
        result : object
            The typed progress or result.
        """
        self.bus.publish(JobProgress(kind, fraction, status(result), result))

    def _start(
        self, kind: str, work: Callable[[threading.Event], object], busy: str
    ) -> threading.Thread:
        """Run work(cancel) on a thread of its own; refused with `busy` while one of `kind` runs.

        Its typed result (or Refused, Failed, Cancelled) is published once the job is over, so that
        a button enabled by it can start the next one at once; a result of None publishes nothing.
        """
        with self._lock:
            if kind in self._running:
                raise MirrorscanError(busy)
            cancel = self._running[kind] = threading.Event()

        def run() -> None:
            result = None
            try:
                result = work(cancel)
            except CancelledError:
                result = Cancelled()
            except (MirrorscanError, OSError) as exc:
                result = Refused(str(exc))
            except Exception as exc:  # noqa: BLE001 - a bug must still end the job with a result
                log.exception("%s failed", kind)
                result = Failed(type(exc).__name__, str(exc))
            finally:
                with self._lock:
                    self._running.pop(kind, None)
            if result is not None:
                log.info("%s: %s", kind, say(result)[0].plain)  # once, however many tabs tell it
                self.progress(kind, None, result)

        thread = threading.Thread(target=run, name=f"mirrorscan-{kind}", daemon=True)
        with self._lock:
            self._threads[kind] = thread
        thread.start()
        return thread

    def stop(self, timeout: float = 10.0) -> None:
        """Cancel every running job and wait up to `timeout` seconds in all for them to end.

        A job left in native code when the process exits aborts it.

        Parameters
        ----------
        timeout : float, optional
        """
        with self._lock:
            events, threads = list(self._running.values()), list(self._threads.values())
        for event in events:
            event.set()
        end = time.monotonic() + timeout
        for thread in threads:
            thread.join(max(0.0, end - time.monotonic()))
