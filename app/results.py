"""What the long jobs give back, as typed results: the jobs (mirrorscan.jobs) make them, the bus
carries them (mirrorscan.events), and the wording (mirrorscan.wording) says them in the browser. No
prose is made here."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mirrorcore.calibration.fit import Calibration
from mirrorcore.calibration.markers import FitReview
from mirrorcore.calibration.refine import MirrorRefinement
from mirrorcore.calibration.residuals import ViewAgreement
from mirrorcore.io.session import SessionMirror


@dataclass(frozen=True)
class Refused:
    """A job refused what it was asked (a MirrorscanError or an OSError): `reason` is the error's
    one line."""

    reason: str


@dataclass(frozen=True)
class Failed:
    """A job stopped on a bug: the exception's type name and message."""

    error: str
    message: str


@dataclass(frozen=True)
class Cancelled:
    """A job cancelled before its end."""


@dataclass(frozen=True, eq=False)
class DenseResult:
    """A dense reconstruction.

    Attributes
    ----------
    vertices : (n, 3) float32 metres, camera frame.
    sources : (n,) uint8, each vertex's source label.
    faces : (m, 3) int32, or None for a carved cloud.
    method : "carve", "paper" or "tsdf".
    low, high : (3,) metres, the box's corners.
    voxel : metres.
    made : when it was made (time.time()).
    source : the name of the source whose frames it was made of.
    left_out : the mirrors with an outline and no plane, whose view is not in it (names).
    """

    vertices: np.ndarray
    sources: np.ndarray
    faces: np.ndarray | None
    method: str
    low: np.ndarray
    high: np.ndarray
    voxel: float
    made: float
    source: str
    left_out: tuple[str, ...] = ()


@dataclass(frozen=True)
class DenseWork:
    """A dense reconstruction under way: its method, the frames prepared, the volume's shape (None
    while the frames are prepared)."""

    method: str
    frames: int
    shape: tuple[int, ...] | None = None


@dataclass(frozen=True)
class FramesUsed:
    """The frames a calibration from the object read: `picks` of a recording of `count` frames
    (numbered as in the header), or the last `len(picks)` live frames (`count` None)."""

    picks: tuple[int, ...]
    count: int | None = None


@dataclass(frozen=True)
class CalibrationWork:
    """A calibration from the object under way: a search (`search`) or a refinement, over `used`;
    `started` once the frames are prepared."""

    search: bool
    used: FramesUsed
    started: bool = False


@dataclass(frozen=True)
class NotFound:
    """A mirror a search could not find while it found others: its name and the library's one-line
    why."""

    name: str
    why: str


@dataclass(frozen=True)
class CalibrationReport:
    """A calibration from the object that ended.

    Attributes
    ----------
    mirrors : each mirror refined or found, in session order.
    search : the planes were searched for (no markers) rather than refined.
    compared : "surfaces" or "sphere" (Refinement.compared).
    changed : a plane or a glass moved (an undo step was made).
    used : the frames it read.
    not_found : the mirrors a search could not find.
    """

    mirrors: tuple[MirrorRefinement, ...]
    search: bool
    compared: str
    changed: bool
    used: FramesUsed
    not_found: tuple[NotFound, ...] = ()


@dataclass(frozen=True)
class CalibrationRefused:
    """A calibration from the object refused: the error's line, the mirrors it is about (names), and
    whether it was a search."""

    reason: str
    mirrors: tuple[str, ...]
    search: bool


@dataclass(frozen=True)
class MirrorAgreement:
    """One mirror's view against the others: its name, the figures, and whether its plane comes from
    its markers (what the advice may send the technician back to)."""

    name: str
    found: ViewAgreement
    by_markers: bool


@dataclass(frozen=True)
class AgreementReport:
    """How the mirrors' views agree with the planes as they are: one entry per mirror with a plane
    (empty when no mirror has one)."""

    mirrors: tuple[MirrorAgreement, ...]


@dataclass(frozen=True)
class Checking:
    """An agreement check under way."""


@dataclass(frozen=True)
class Collecting:
    """A background capture under way: `done` of `total` frames collected."""

    done: int
    total: int


@dataclass(frozen=True)
class BackgroundCaptured:
    """A background captured from `frames` frames; `waiting`: it is used only once the technician
    confirms."""

    frames: int
    waiting: bool = False


@dataclass(frozen=True)
class Replay:
    """Where a recording that plays stands while it is recorded: frame `at` of `count`."""

    at: int
    count: int


@dataclass(frozen=True)
class RecordingState:
    """A recording under way.

    Attributes
    ----------
    folder : where it is written.
    taken : frames taken; written : frames on disk so far.
    replay : the recording that plays, or None for a live source.
    replay_ended : the recording that plays came to its last frame.
    error : why the recorder stopped, or None.
    """

    folder: Path
    taken: int
    written: int
    replay: Replay | None = None
    replay_ended: bool = False
    error: str | None = None


@dataclass(frozen=True)
class Recorded:
    """A recording saved: its frames, its folder, and the frames dropped for a slow disk."""

    frames: int
    root: Path
    dropped: int = 0


@dataclass(frozen=True)
class BatchStarting:
    """A batch starting with `method`."""

    method: str


@dataclass(frozen=True, eq=False)
class Fit:
    """A markers fit of one mirror: the Calibration, the SessionMirror as fitted, its FitReview, and
    whether it replaces a plane found from the object (the markers alone are less accurate)."""

    calibration: Calibration
    mirror: SessionMirror
    review: FitReview
    replaces_object: bool = False

    @property
    def needs_confirmation(self) -> bool:
        """Whether it waits for Apply or Discard: a concern of the review, or a plane from the
        object it replaces, unless it is a refit of markers taken before."""
        return (self.review.needs_confirmation or self.replaces_object) and not self.review.refit


@dataclass(frozen=True, eq=False)
class FitsApplied:
    """Markers fits applied (Fit each); the ids of those applied on confirmation; the names of the
    mirrors whose proposed planes were discarded."""

    fits: tuple[Fit, ...]
    confirmed: tuple[int, ...] = ()
    discarded: tuple[str, ...] = ()
