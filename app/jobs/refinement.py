"""The calibration from the object: the refinement of the calibrated planes, or the search for the
planes of mirrors with an outline and no markers, over frames of the object; and the frames the
markers are read on."""

from __future__ import annotations

import logging
import threading
from typing import TYPE_CHECKING

import numpy as np

from mirrorcore.base.errors import CalibrationError, MirrorscanError
from mirrorcore.calibration.colourgain import (
    ColourGains,
    estimate_gains,
    read_colour_frames,
    with_gains,
)
from mirrorcore.calibration.fit import calibration_depth, static_frames
from mirrorcore.calibration.refine import REFINE_FRAMES, refine_session
from mirrorcore.calibration.scene import calibrate_scene
from mirrorcore.geometry.plane import Plane
from mirrorcore.io.session import Session
from mirrorcore.rig.model import Rig
from mirrorcore.rig.pipeline import object_masks
from mirrorcore.sources import SessionSource

from ..results import (
    CalibrationRefused,
    CalibrationReport,
    CalibrationWork,
    FitsApplied,
    FramesUsed,
    NotFound,
)
from .runner import REFINE, Runner

if TYPE_CHECKING:
    from ..editor import SessionEditor

log = logging.getLogger("mirrorscan")
BUSY = "a refinement is already running"


def planes_key(session: Session) -> tuple:
    """What a calibration leaves: each mirror's id and plane (undo and redo find reports by it).

    Parameters
    ----------
    session : Session

    Returns
    -------
    tuple
        ((mirror id, plane), ...) in session order.
    """
    return tuple((m.id, m.plane) for m in session.mirrors)


class RefinementJob(Runner):
    """Calibration from the object (Jobs mixes it in).

    Attributes
    ----------
    refinements : dict of tuple to CalibrationReport
        Each calibration's report, by the planes it left (planes_key).
    fits : dict of tuple to FitsApplied
        Each markers fit's report, by the planes it left.
    refused : dict of int to str
        Mirror id -> "refine" or "scene", refused on it until one succeeds.
    """

    refinements: dict[tuple, CalibrationReport]
    fits: dict[tuple, FitsApplied]
    refused: dict[int, str]
    _marker_frames: tuple[tuple, np.ndarray] | None = None  # (recording, its frames)
    _object_planes: set[tuple[int, Plane]]  # (mirror id, plane) from the object
    # mirror id -> its boundary and markers when it was refused
    _refused_on: dict[int, tuple]

    def from_object(self, mirror_id: int, plane: Plane | None) -> bool:
        """Whether a refinement or search of this app gave the mirror this plane, or left it.

        A mirror held as it was while the others were found keeps its own.

        Parameters
        ----------
        mirror_id : int
        plane : Plane or None

        Returns
        -------
        bool
        """
        return plane is not None and (mirror_id, plane) in self._object_planes

    def refusals(self, session: Session) -> dict[int, str]:
        """What was refused lately on mirrors whose boundary and markers are as they were then.

        Parameters
        ----------
        session : Session
            The session as it is.

        Returns
        -------
        dict of int to str
            {mirror id: 'refine' or 'scene'}.
        """
        now = {m.id: (m.boundary, m.markers) for m in session.mirrors}
        return {
            i: kind for i, kind in self.refused.items() if now.get(i) == self._refused_on.get(i)
        }

    def report(self, key: tuple) -> CalibrationReport | FitsApplied | None:
        """The report of the calibration or markers fit that left the planes `key`.

        Parameters
        ----------
        key : tuple
            As planes_key gives it.

        Returns
        -------
        CalibrationReport, FitsApplied or None
        """
        return self.refinements.get(key) or self.fits.get(key)

    def start_refine(self, editor: "SessionEditor") -> threading.Thread:
        """Refine the planes of the session's calibrated mirrors from the agreement of the views.

        refine_session over object_frames, then the planes and marker offsets are applied (one undo
        step per mirror), with the mirrors' colour gains measured on the same frames when they
        have colour; the job's result is a CalibrationReport.

        Parameters
        ----------
        editor : SessionEditor

        Returns
        -------
        threading.Thread
            The job's thread.
        """
        depths, colours, used = self.object_frames()
        session, snapshot = editor.session, self.snapshot()
        return self._start(
            REFINE,
            lambda cancel: self._calibrate(editor, session, snapshot, (depths, colours), used,
                                           cancel, None),
            BUSY,
        )

    def start_scene(self, editor: "SessionEditor") -> threading.Thread:
        """Find the planes of the mirrors that have a boundary and no plane, without markers.

        calibrate_scene: a search in the first of object_frames, then the refinement over all of
        them, the other calibrated mirrors taking part as they are; the planes are applied as
        start_refine does.

        Parameters
        ----------
        editor : SessionEditor

        Returns
        -------
        threading.Thread
            The job's thread.

        Raises
        ------
        MirrorscanError
            When no mirror has a boundary and no plane.
        """
        session = editor.session
        todo = [i for i, m in enumerate(session.mirrors) if m.boundary and m.plane is None]
        if not todo:
            raise MirrorscanError(
                "no mirror has a boundary and no plane: draw a mirror's boundary first (a "
                "mirror with a plane is refined with Refine from the object)"
            )
        depths, colours, used = self.object_frames()
        snapshot = self.snapshot()
        return self._start(
            REFINE,
            lambda cancel: self._calibrate(editor, session, snapshot, (depths, colours), used,
                                           cancel, todo),
            BUSY,
        )

    def marker_frames(self) -> np.ndarray | None:
        """The frames the markers are read on.

        The background and MAX_MARKER_FRAMES frames spread over the recording that plays (the same
        whenever it is clicked, as `mirrorscan calibrate` reads them; read once per recording), else
        the last live frames with the background in use, both without what passes in front of it
        (static_frames).

        Returns
        -------
        np.ndarray, shape (k, H, W), float32, or None
            Metres; None before the first frame.
        """
        source = self.loop.source
        if isinstance(source, SessionSource) and source.session.frames:
            session = source.session
            key = (session.root, session.frames, session.background)
            cached = self._marker_frames
            if cached is None or cached[0] != key:
                try:
                    cached = self._marker_frames = (key, calibration_depth(session))
                # its files went bad: the frames as they play still serve
                except MirrorscanError as exc:
                    log.warning("the markers are read on the last frames: %s", exc)
                    return self._live_marker_frames()
            return cached[1]
        return self._live_marker_frames()

    def _live_marker_frames(self) -> np.ndarray | None:
        """The last live frames without what passes in front of the background, or None."""
        recent = self.loop.recent_depths()
        return None if recent is None else static_frames(recent, self.snapshot().background)

    def object_frames(self) -> tuple[np.ndarray, np.ndarray | None, FramesUsed]:
        """The frames a calibration from the object uses, their colour, and which they are.

        REFINE_FRAMES spread over the recording that plays (as `mirrorscan calibrate` picks them),
        else the last live frames.

        Returns
        -------
        depths : np.ndarray, shape (k, H, W), float32
            Metres.
        colours : np.ndarray, shape (k, H, W, 3), uint8, or None
            RGB registered to the depths; None without colour.
        used : FramesUsed
        """
        source = self.loop.source
        if isinstance(source, SessionSource) and source.session.frames:
            picks = source.session.spread_frames(REFINE_FRAMES)
            depths = source.session.read_frames(picks)
            return (depths, read_colour_frames(source.session, picks),
                    FramesUsed(tuple(picks), len(source.session.frames)))
        recent = self.loop.recent_frames()
        if recent is None:
            raise MirrorscanError("no frame yet to calibrate from")
        depths, colours = recent
        return depths, colours, FramesUsed(tuple(range(len(depths))))

    def _gains(self, session: Session, depths: np.ndarray, masks: np.ndarray,
               colours: np.ndarray | None, cancel) -> tuple[dict[int, tuple], ColourGains | None]:
        """The colour gains measured with a calibration's planes: ({mirror id: gain} of the
        mirrors measured, the result), or ({}, None) without colour."""
        if colours is None:
            return {}, None
        measured = estimate_gains(Rig.from_session(session), depths, masks, colours, cancel)
        coloured = with_gains(session, measured).mirrors
        return {coloured[m.index].id: coloured[m.index].colour_gain
                for m in measured.mirrors if m.gain is not None}, measured

    def _refuse(self, session: Session, ids: list[int], kind: str) -> None:
        """Mark the mirrors `ids` refused by `kind` ('refine' or 'scene') as they now are.

        See refusals.
        """
        self.refused.update(dict.fromkeys(ids, kind))
        self._refused_on.update(
            {m.id: (m.boundary, m.markers) for m in session.mirrors if m.id in ids}
        )

    def _calibrate(
        self,
        editor: "SessionEditor",
        session: Session,
        snapshot,
        frames: tuple[np.ndarray, np.ndarray | None],
        used: FramesUsed,
        cancel: threading.Event,
        search: list[int] | None,
    ) -> CalibrationReport | CalibrationRefused:
        """Refine the calibrated planes, or find those of the mirrors at `search`.

        `frames` are object_frames' depths and colours; `search` is None for a refinement, else
        0-based mirror indices.
        """
        depths, colours = frames
        self.progress(REFINE, 0.0, CalibrationWork(search is not None, used))
        masks = object_masks(snapshot.rig, depths, snapshot.backdrop, session.selection)
        work = CalibrationWork(search is not None, used, started=True)
        kind, ids = (
            ("refine", [m.id for m in session.mirrors if m.plane is not None])
            if search is None
            else ("scene", [session.mirrors[i].id for i in search])
        )
        try:
            if search is None:
                refined, result = refine_session(
                    session,
                    depths,
                    masks,
                    cancel=cancel,
                    progress=lambda f: self.progress(REFINE, f, work),
                )
            else:
                refined, result = calibrate_scene(
                    session,
                    depths,
                    masks,
                    np.random.default_rng(0),
                    search,
                    lambda f: self.progress(REFINE, f, work),
                    cancel,
                )
        except CalibrationError as exc:  # the mirrors it names, else all it was asked for
            named = [m.id for m in session.mirrors if m.id in ids and m.name in exc.mirrors]
            self._refuse(session, named or ids, kind)
            return CalibrationRefused(str(exc), exc.mirrors, search is not None)
        # a search: those it could not do
        missing = [session.mirrors[i].id for i, _ in result.refused]
        for mirror_id in ids:
            self.refused.pop(mirror_id, None)
        self._refuse(session, missing, kind)
        planes = {
            session.mirrors[r.index].id: (r.after, session.mirrors[r.index]) for r in result.mirrors
        }
        glass = {
            session.mirrors[r.index].id: (
                refined.mirrors[r.index].marker_offset,
                refined.mirrors[r.index].marker_offset_std,
            )
            for r in result.mirrors
        }
        gains, measured = self._gains(refined, depths, masks, colours, cancel)
        changed = bool(
            (search is not None or result.changed(session, refined) or gains)
            and editor.set_planes(
                planes, glass, what="refined plane" if search is None else "found plane",
                gains=gains,
            )
        )
        self._object_planes.update((i, editor.mirror(i).plane) for i in planes)
        # the lines under the report: the new planes' agreement
        self.start_agreement(depths)
        not_found = tuple(
            NotFound(session.mirrors[i].name, why.removeprefix(session.mirrors[i].name + ": "))
            for i, why in result.refused
        )
        report = CalibrationReport(
            tuple(result.mirrors), search is not None, result.compared, changed, used, not_found,
            measured,
        )
        if changed:
            self.refinements[planes_key(editor.session)] = report
        # no undo step: Undo and Redo keep the report that set them
        else:
            self.refinements.setdefault(planes_key(editor.session), report)
        return report
