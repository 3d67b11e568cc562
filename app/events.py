"""What happens in the browser tool, as events on one bus: the live loop, the session editor and the
long jobs publish; the tabs (and their panels) subscribe. Panels never call each other: they publish
and subscribe here."""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, TypeVar

if TYPE_CHECKING:
    import numpy as np

    from mirrorcore.sources import DepthSource

    from .liveframe import LiveFrame
    from .results import DenseResult
    from .state import Snapshot

log = logging.getLogger("mirrorscan")
E = TypeVar("E")


@dataclass(frozen=True, eq=False)
class FrameReady:
    """The live loop processed a frame (on the loop's thread: subscribers must be quick).

    Attributes
    ----------
    frame : LiveFrame
    """

    frame: "LiveFrame"


@dataclass(frozen=True, eq=False)
class SessionChanged:
    """The session (or its background) changed.

    Attributes
    ----------
    snapshot : Snapshot
        The new consistent state.
    """

    snapshot: "Snapshot"


@dataclass(frozen=True, eq=False)
class LoopChanged:
    """The live loop was paused, resumed or moved to another frame or source.

    Attributes
    ----------
    paused : bool
    source : DepthSource
    """

    paused: bool
    source: "DepthSource"


@dataclass(frozen=True, eq=False)
class JobProgress:
    """A long job shared by every tab moved on.

    The jobs are jobs.DENSE, BACKGROUND, RECORD, BATCH, REFINE, AGREEMENT and HEAT.

    Attributes
    ----------
    job : str
        The job's kind.
    fraction : float or None
        Done, in [0, 1], or None when it is not running.
    status : str
        Markdown for a panel (mirrorscan.wording.jobs.status of `result`).
    result : object
        The typed progress or result (mirrorscan.results, mirrorcore.batch), what panels decide
        on.
    """

    job: str
    fraction: float | None
    status: str
    result: object = None

    @property
    def percent(self) -> float:
        """The fraction done as a progress bar's value, to 0.1 %.

        Rounded because a screen reader reads out every digit.
        """
        return round(100.0 * (self.fraction or 0.0), 1)


@dataclass(frozen=True, eq=False)
class DenseChanged:
    """A dense reconstruction finished (or was cleared).

    Attributes
    ----------
    result : DenseResult or None
        None when cleared.
    """

    result: "DenseResult | None"


@dataclass(frozen=True, eq=False)
class HeatChanged:
    """The heat map of a live frame.

    Attributes
    ----------
    index : int
        The live frame's index.
    points : np.ndarray, shape (n, 3), float32
        Metres.
    colours : np.ndarray, shape (n, 3), uint8
    figures : dict
        Per view seen in a mirror (source label): the median distance (mm) and the share of its
        points compared (mirrorcore.calibration.agreement.heat_figures) over the heat maps of the
        last `frames` frames with the same planes.
    frames : int
    sources : np.ndarray, shape (n,), uint8, or None
        Each point's source label, 0 the camera's; None: not told apart.
    """

    index: int
    points: "np.ndarray"
    colours: "np.ndarray"
    figures: dict
    frames: int = 1
    sources: "np.ndarray | None" = None


class EventBus:
    """Publish / subscribe by event type.

    publish() calls the subscribers of the event's type on the calling thread, in order of
    subscription; one that raises is logged and the others still run.
    """

    def __init__(self):
        self._lock = threading.Lock()
        self._subscribers: dict[type, list[Callable[[Any], None]]] = {}

    def subscribe(self, kind: type[E], callback: Callable[[E], None]) -> Callable[[], None]:
        """Call callback(event) for every published event of type `kind`.

        Parameters
        ----------
        kind : type
        callback : callable

        Returns
        -------
        callable
            The function that unsubscribes.
        """
        with self._lock:
            self._subscribers.setdefault(kind, []).append(callback)

        def unsubscribe() -> None:
            with self._lock:
                if callback in self._subscribers.get(kind, []):
                    self._subscribers[kind].remove(callback)

        return unsubscribe

    def publish(self, event: object) -> None:
        """Call the subscribers of the event's type, in order, on the calling thread.

        One that raises is logged and the others still run.

        Parameters
        ----------
        event : object
        """
        with self._lock:
            callbacks = list(self._subscribers.get(type(event), []))
        for callback in callbacks:
            try:
                callback(event)
            except Exception:  # noqa: BLE001 - one broken tab must not stop the others
                log.exception("%s failed in %r", type(event).__name__, callback)
