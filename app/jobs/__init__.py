"""The long jobs every tab shares, one of each kind at a time: dense reconstruction of the recent
frames, background capture, recording, the batch reconstruction of every frame of a recording, the
calibration from the object, the views' agreement after a fit, and the heat map of a frame. Each
runs on a worker thread (runner.Runner), reports JobProgress on the bus with a typed result
(mirrorscan.results), and can be cancelled."""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable

from ..events import EventBus
from ..results import DenseResult
from .agreement import AGREEMENT_FRAMES, AgreementJob
from .background import BackgroundJob
from .batch import BatchJob
from .dense import DenseJob, unplaned
from .heat import HEAT_LIMIT_MM, HEAT_POOL, HeatJob
from .recording import RecordingJob
from .refinement import RefinementJob, planes_key
from .runner import AGREEMENT, BACKGROUND, BATCH, DENSE, HEAT, RECORD, REFINE, Runner

if TYPE_CHECKING:
    from ..live import LiveLoop
    from ..state import Snapshot

__all__ = [
    "AGREEMENT",
    "AGREEMENT_FRAMES",
    "BACKGROUND",
    "BATCH",
    "DENSE",
    "HEAT",
    "HEAT_LIMIT_MM",
    "HEAT_POOL",
    "RECORD",
    "REFINE",
    "DenseResult",
    "Jobs",
    "planes_key",
    "unplaned",
]


class Jobs(
    DenseJob, BackgroundJob, RecordingJob, BatchJob, RefinementJob, AgreementJob, HeatJob, Runner
):
    """The shared jobs of one app.

    Parameters
    ----------
    loop : LiveLoop
        Gives the frames.
    snapshot : callable
        Returns the consistent state (Snapshot).
    bus : EventBus
        Carries their progress and results.
    """

    def __init__(self, loop: "LiveLoop", snapshot: Callable[[], "Snapshot"], bus: EventBus):
        Runner.__init__(self, bus)
        self.loop, self.snapshot = loop, snapshot
        self.dense_result = None
        self.agreement, self.disagreeing = None, ()
        self.refinements, self.fits, self.refused = {}, {}, {}
        self.recorder = self._tap = None
        self.batch_settings = None
        self._heat_rig, self._heat_pool = None, {}
        self._marker_frames, self._object_planes, self._refused_on = None, set(), {}
