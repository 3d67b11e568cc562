"""What the long jobs give back, as typed results: the jobs (mirrorscan.jobs) make them, the bus
carries them (mirrorscan.events), and the wording (mirrorscan.wording) says them in the browser. No
prose is made here."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mirrorcore.calibration.fit import Calibration
from mirrorcore.calibration.markers import FitReview
from mirrorcore.calibration.colourgain import ColourGains
from mirrorcore.calibration.refine import MirrorRefinement
from mirrorcore.calibration.residuals import ViewAgreement
from mirrorcore.io.session import SessionMirror


@dataclass(frozen=True)
class Refused:
    """A job refused what it was asked (a MirrorscanError or an OSError).

    Attributes
    ----------
    reason : str
        The error's one line.
    """

    reason: str


@dataclass(frozen=True)
class Failed:
    """A job stopped on a bug.

    Attributes
    ----------
    error : str
        The exception's type name.
    message : str
        Its message.
    """

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
    vertices : np.ndarray, shape (n, 3), float32
        Metres, camera frame.
    sources : np.ndarray, shape (n,), uint8
        Each vertex's source label.
    faces : np.ndarray, shape (m, 3), int32, or None
        None for a carved cloud.
    method : str
        "carve", "paper" or "tsdf".
    low, high : np.ndarray, shape (3,)
        The box's corners, metres.
    voxel : float
        Metres.
    made : float
        When it was made (time.time()).
    source : str
        The name of the source whose frames it was made of.
    left_out : tuple of str
        The names of the mirrors with an outline and no plane, whose view is not in it.
    normals : np.ndarray, shape (n, 3), float32, or None
        The carved points' outward unit normals (mirrorcore.dense.normals); None for a mesh.
    colours : np.ndarray, shape (n, 3), uint8, or None
        Each vertex's colour where the session has colour; None draws the dense result's own.
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
    normals: np.ndarray | None = None
    colours: np.ndarray | None = None


@dataclass(frozen=True)
class DenseWork:
    """A dense reconstruction under way.

    Attributes
    ----------
    method : str
    frames : int
        The frames prepared.
    shape : tuple of int or None
        The volume's shape; None while the frames are prepared.
    """

    method: str
    frames: int
    shape: tuple[int, ...] | None = None


@dataclass(frozen=True)
class FramesUsed:
    """The frames a calibration from the object read.

    Attributes
    ----------
    picks : tuple of int
        The frames of a recording (numbered as in the header), or as many live frames.
    count : int or None
        The recording's frame count; None for the last `len(picks)` live frames.
    """

    picks: tuple[int, ...]
    count: int | None = None


@dataclass(frozen=True)
class CalibrationWork:
    """A calibration from the object under way.

    Attributes
    ----------
    search : bool
        A search (no markers) rather than a refinement.
    used : FramesUsed
    started : bool
        The frames are prepared.
    """

    search: bool
    used: FramesUsed
    started: bool = False


@dataclass(frozen=True)
class NotFound:
    """A mirror a search could not find while it found others.

    Attributes
    ----------
    name : str
    why : str
        The library's one-line why.
    """

    name: str
    why: str


@dataclass(frozen=True)
class CalibrationReport:
    """A calibration from the object that ended.

    Attributes
    ----------
    mirrors : tuple of MirrorRefinement
        Each mirror refined or found, in session order.
    search : bool
        The planes were searched for (no markers) rather than refined.
    compared : str
        "surfaces" or "sphere" (Refinement.compared).
    changed : bool
        A plane or a glass moved (an undo step was made).
    used : FramesUsed
        The frames it read.
    not_found : tuple of NotFound
        The mirrors a search could not find.
    gains : ColourGains or None
        The mirrors' colour gains measured with the planes (frames with colour), else None.
    """

    mirrors: tuple[MirrorRefinement, ...]
    search: bool
    compared: str
    changed: bool
    used: FramesUsed
    not_found: tuple[NotFound, ...] = ()
    gains: ColourGains | None = None


@dataclass(frozen=True)
class CalibrationRefused:
    """A calibration from the object refused.

    Attributes
    ----------
    reason : str
        The error's line.
    mirrors : tuple of str
        The names of the mirrors it is about.
    search : bool
        It was a search.
    """

    reason: str
    mirrors: tuple[str, ...]
    search: bool


@dataclass(frozen=True)
class MirrorAgreement:
    """One mirror's view against the others.

    Attributes
    ----------
    name : str
    found : ViewAgreement
        The figures.
    by_markers : bool
        Its plane comes from its markers (what the advice may send the technician back to).
    """

    name: str
    found: ViewAgreement
    by_markers: bool


@dataclass(frozen=True)
class AgreementReport:
    """How the mirrors' views agree with the planes as they are.

    Attributes
    ----------
    mirrors : tuple of MirrorAgreement
        One per mirror with a plane; empty when no mirror has one.
    """

    mirrors: tuple[MirrorAgreement, ...]


@dataclass(frozen=True)
class Checking:
    """An agreement check under way."""


@dataclass(frozen=True)
class Collecting:
    """A background capture under way.

    Attributes
    ----------
    done, total : int
        Frames collected, of all.
    """

    done: int
    total: int


@dataclass(frozen=True)
class BackgroundCaptured:
    """A background captured.

    Attributes
    ----------
    frames : int
        The frames it is the median of.
    waiting : bool
        It is used only once the technician confirms.
    """

    frames: int
    waiting: bool = False


@dataclass(frozen=True)
class Replay:
    """Where a recording that plays stands while it is recorded.

    Attributes
    ----------
    at, count : int
        Frame `at` of `count`.
    """

    at: int
    count: int


@dataclass(frozen=True)
class RecordingState:
    """A recording under way.

    Attributes
    ----------
    folder : Path
        Where it is written.
    taken : int
        Frames taken.
    written : int
        Frames on disk so far.
    replay : Replay or None
        The recording that plays, or None for a live source.
    replay_ended : bool
        The recording that plays came to its last frame.
    error : str or None
        Why the recorder stopped, or None.
    """

    folder: Path
    taken: int
    written: int
    replay: Replay | None = None
    replay_ended: bool = False
    error: str | None = None


@dataclass(frozen=True)
class Recorded:
    """A recording saved.

    Attributes
    ----------
    frames : int
    root : Path
        Its folder.
    dropped : int
        Frames dropped for a slow disk.
    """

    frames: int
    root: Path
    dropped: int = 0


@dataclass(frozen=True)
class BatchStarting:
    """A batch starting.

    Attributes
    ----------
    method : str
    """

    method: str


@dataclass(frozen=True, eq=False)
class Fit:
    """A markers fit of one mirror.

    Attributes
    ----------
    calibration : Calibration
    mirror : SessionMirror
        The mirror as fitted.
    review : FitReview
    replaces_object : bool
        It replaces a plane found from the object (the markers alone are less accurate).
    """

    calibration: Calibration
    mirror: SessionMirror
    review: FitReview
    replaces_object: bool = False

    @property
    def needs_confirmation(self) -> bool:
        """Whether it waits for Apply or Discard.

        A concern of the review, or a plane from the object it replaces, unless it is a refit of
        markers taken before.
        """
        return (self.review.needs_confirmation or self.replaces_object) and not self.review.refit


@dataclass(frozen=True, eq=False)
class FitsApplied:
    """Markers fits applied.

    Attributes
    ----------
    fits : tuple of Fit
    confirmed : tuple of int
        The ids of those applied on confirmation.
    discarded : tuple of str
        The names of the mirrors whose proposed planes were discarded.
    """

    fits: tuple[Fit, ...]
    confirmed: tuple[int, ...] = ()
    discarded: tuple[str, ...] = ()
