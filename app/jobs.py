"""The long jobs every tab shares, one of each kind at a time: dense reconstruction of the recent frames, background
capture, recording, the batch reconstruction of every frame of a recording, the refinement of the planes from the
object, the views' agreement after a fit, and the heat map of a frame. Each runs on a worker thread, reports
JobProgress on the bus, can be cancelled, and publishes its result (DenseChanged, HeatChanged; the background through
the app; the recorded session; the refined planes through the editor)."""
from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np

from mirrorcore.calibration.agreement import heat_figures, local_means, surface_distances
from mirrorcore.batch import BatchJob, BatchProgress, BatchReport, BatchRun, Where, exports_folder
from mirrorcore.calibration.fit import calibration_depth, static_frames
from mirrorcore.dense import DenseOptions, dense_volume, reconstruct_dense
from mirrorcore.dense.carve import CarveResult
from mirrorcore.depth.ops import median_depth
from mirrorcore.base.errors import CalibrationError, Cancelled, MirrorscanError
from mirrorcore.geometry.plane import Plane
from mirrorcore.base.palette import heat_map_colours
from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.calibration.fixing import MIN_AGREEMENTS
from mirrorcore.calibration.refine import REFINE_FRAMES, refine_session
from mirrorcore.calibration.residuals import ViewAgreement, view_agreement
from mirrorcore.calibration.results import (CAMERA_MEAN_EXPLAINS, MEAN_EXPLAINS, METHOD_BIAS,
                                            NOISE_EXPLAINS)
from mirrorcore.calibration.scene import calibrate_scene
from mirrorcore.io.session import SESSION_FILE, Session, save_session
from mirrorcore.sources import SessionSource
from mirrorcore.sources.record import Recorder, new_recording_folder
from mirrorcore.base.words import listed

from .events import DenseChanged, EventBus, FrameReady, HeatChanged, JobProgress
from .live import frame_number
from .recording import LiveTap

if TYPE_CHECKING:
    from .editor import SessionEditor
    from .live import LiveFrame, LiveLoop
    from .state import Snapshot

log = logging.getLogger("mirrorscan")
DENSE, BACKGROUND, RECORD, BATCH = "dense", "background", "record", "batch"
REFINE, AGREEMENT, HEAT = "refine", "agreement", "heat"
CHECKING = "checking how the views agree…"
NO_AGREEMENT = ("No mirror has a plane yet, so no view can be compared with another: fit the planes from markers, or "
                "find them from the object.")       # it said "no view sees what another sees" (a helper)
NOT_DONE, FAILED = "not done", "failed"   # the first words of a job's last status when it was refused, or hit a bug
CANCELLED = "cancelled"      # the last status of a job cancelled
GLASS_ADVICE = "The glass is measured on"    # the first words of a refinement's advice to type the glass in
REFINED = "Planes refined"   # the first words of a refinement's report when it applied new planes...
FOUND = "Planes found from the object"     # ... and of a calibration without markers
UNDO_NOTE = "Undo restores the previous planes."     # the last words of a refinement's headline...
FOUND_CHECK = ": check the heat map and the agreement below"     # after the planes found, in the report
NOT_FOUND = " ⚠ not found: "                  # a report's line of a mirror a search could not find: its why follows
NOT_FOUND_HEAD = " not found (why below)"      # ... and in its headline, after the names of those mirrors
UNDO_FOUND = "Undo takes the planes found back."     # ... and of planes found where there were none
UNCHANGED = ("Nothing changed: the planes and the glass are already where this object puts them (no undo step; Undo "
             "still takes back the step before).")
HEAT_LIMIT_MM = 10.0      # the heat map's colours saturate at this distance to the direct surface
HEAT_POOL = 10            # heat maps whose distances the legend's figures pool: on the sphere at the true planes
                          # one frame's median spreads by 0.5 mm (-1.8 to +0.5 mm over 40 frames), ten frames' by
                          # 0.1 to 0.2 mm
AGREEMENT_FRAMES = 5      # frames the agreement lines pool: one frame's figures of the walking figure spread by 0.4
                          # mm (RMS) and 0.5 mm (mean) from click to click, five frames' by 0.2 and 0.2 to 0.3 mm
                          # (0.2 s a frame)


@dataclass(frozen=True, eq=False)
class DenseResult:
    """A dense reconstruction: vertices (n, 3) float32 metres, camera frame; sources (n,) uint8; faces (m, 3) int32
    or None (a carved cloud); the method; the box's corners low, high (3,) metres; voxel in metres; a one-line
    description; when it was made (time.time()); the name of the source whose frames it was made of."""

    vertices: np.ndarray
    sources: np.ndarray
    faces: np.ndarray | None
    method: str
    low: np.ndarray
    high: np.ndarray
    voxel: float
    summary: str
    made: float
    source: str


def batch_status(p: BatchProgress) -> str:
    """One line: frames done of all, the rate, the time left, failures and retries, the dashboard link."""
    left = "" if p.seconds_left is None else f", {p.seconds_left:.0f} s left"
    extra = "".join(f", {n} {what}" for n, what in ((p.failed, "failed"), (len(p.retried), "retried")) if n)
    link = f" · [Dask dashboard]({p.dashboard})" if p.dashboard else ""
    return f"{p.done:,} of {p.total:,} frames, {p.fps:.1f} fps{left}{extra}{link}"


def batch_summary(report: BatchReport) -> str:
    """One line: how the batch ended and where its files are."""
    how = "stopped" if report.cancelled else "done"
    failed = f"; failed: frames {', '.join(map(str, sorted(report.failed)))}" if report.failed else ""
    return f"batch {how}: {report.kept + report.written:,} of {report.total:,} frames in `{report.out}`{failed}"


class Jobs:
    """The shared jobs of one app. Starting a job while one of its kind runs is refused by name."""

    def __init__(self, loop: "LiveLoop", snapshot: Callable[[], "Snapshot"], bus: EventBus):
        self.loop, self.snapshot, self.bus = loop, snapshot, bus
        self.dense_result: DenseResult | None = None
        self.agreement = ""        # the last report of how the mirrors' views agree (a tab opening later shows it)
        self.disagreeing: tuple[str, ...] = ()     # ... and the mirrors it flags (their names)
        self.refinements: dict[tuple, str] = {}    # each refinement's report, by the planes it left (planes_key)
        self.fits: dict[tuple, str] = {}           # each markers fit's report, by the planes it left (an undo of a
                                                   # mirror's removal had brought back a refinement's alone: a helper)
        self.refused: dict[int, str] = {}  # mirror id -> "refine" or "scene": refused on it, until one succeeds
        self.recorder: Recorder | None = None
        self._tap: LiveTap | None = None
        self._running: dict[str, threading.Event] = {}      # kind -> its cancel event, while it runs
        self._threads: dict[str, threading.Thread] = {}     # kind -> its last thread
        self._lock = threading.Lock()
        self.batch_settings: tuple[str, int, int] | None = None   # the last batch's method, temporal, workers
        self._heat_rig = None                # the planes of the heat maps the legend pools (one job at a time)...
        self._heat_pool: dict[int, tuple[np.ndarray, np.ndarray]] = {}   # ... by frame number, oldest first
        self._marker_frames: tuple[tuple, np.ndarray] | None = None     # (recording, its frames): marker_frames
        self._object_planes: set[tuple[int, Plane]] = set()    # (mirror id, plane) a refinement or search gave
        self._refused_on: dict[int, tuple] = {}     # mirror id -> its boundary and markers when it was refused

    def from_object(self, mirror_id: int, plane: Plane | None) -> bool:
        """Whether a refinement or search (of this app) gave mirror `mirror_id` this plane, or left it as it was
        (a mirror held while the others were found keeps its own: its markers' plane had been taken for one found
        from the object, and the glass it lacked was not asked for: a helper)."""
        return plane is not None and (mirror_id, plane) in self._object_planes

    def refusals(self, session: Session) -> dict[int, str]:
        """{mirror id: 'refine' or 'scene'}: what was refused lately on a mirror whose boundary and markers are still
        as they were then (a search refused for an outline drawn too narrow was no longer offered once it was
        drawn again: a helper)."""
        now = {m.id: (m.boundary, m.markers) for m in session.mirrors}
        return {i: kind for i, kind in self.refused.items() if now.get(i) == self._refused_on.get(i)}

    def running(self, kind: str) -> bool:
        with self._lock:
            return kind in self._running

    def cancel(self, kind: str) -> None:
        with self._lock:
            event = self._running.get(kind)
        if event is not None:
            event.set()

    def _start(self, kind: str, work: Callable[[threading.Event], str | None], busy: str) -> threading.Thread:
        """Run work(cancel) on a thread of its own; its returned text (or how it failed) is the job's last status,
        published once the job is over, so that a button enabled by it can start the next one at once."""
        with self._lock:
            if kind in self._running:
                raise MirrorscanError(busy)
            cancel = self._running[kind] = threading.Event()

        def run() -> None:
            status = None
            try:
                status = work(cancel)
            except Cancelled:
                status = CANCELLED
            except (MirrorscanError, OSError) as exc:
                status = f"{NOT_DONE}: {exc}"
            except Exception as exc:  # noqa: BLE001 - a bug must still end the job with a status, never a blank one
                log.exception("%s failed", kind)
                status = f"{FAILED}: {type(exc).__name__}: {exc}"
            finally:
                with self._lock:
                    self._running.pop(kind, None)
            if status is not None:
                log.info("%s: %s", kind, status.split("\n\n")[0])    # once, however many tabs tell it
                self.bus.publish(JobProgress(kind, None, status))
        thread = threading.Thread(target=run, name=f"mirrorscan-{kind}", daemon=True)
        with self._lock:
            self._threads[kind] = thread
        thread.start()
        return thread

    def stop(self, timeout: float = 10.0) -> None:
        """Cancel every running job and wait up to `timeout` seconds in all for them to end (the server stops: a
        job left in native code when the process exits aborts it)."""
        with self._lock:
            events, threads = list(self._running.values()), list(self._threads.values())
        for event in events:
            event.set()
        end = time.monotonic() + timeout
        for thread in threads:
            thread.join(max(0.0, end - time.monotonic()))

    # ------------------------------------------------------------------ dense reconstruction
    def start_dense(self, method: str, options: DenseOptions, frames: int) -> threading.Thread:
        """Carve or fuse the last `frames` frames (1 for carving) with the current calibration."""
        depths = self.loop.recent_depths()
        if depths is None:
            raise MirrorscanError("no frame yet")
        snapshot, source = self.snapshot(), self.loop.source.name
        return self._start(DENSE, lambda cancel: self._dense(snapshot, source, depths[-frames:], method, options,
                                                             cancel),
                           "a dense reconstruction is already running; cancel it first")

    def _dense(self, snapshot, source: str, depths: np.ndarray, method: str, options: DenseOptions,
               cancel: threading.Event) -> str:
        self.bus.publish(JobProgress(DENSE, 0.0, f"{method}: preparing {len(depths)} frame(s)"))
        prepared = [prepare_frame(snapshot.rig, d, snapshot.backdrop, snapshot.session.selection) for d in depths]
        volume = dense_volume(snapshot.rig, *prepared[-1], options)   # refuses boxes of too many voxels
        shape = "x".join(map(str, volume.shape))
        result = reconstruct_dense(snapshot.rig, np.stack([p[0] for p in prepared]),
                                   np.stack([p[1] for p in prepared]), volume, method, options,
                                   lambda f: self.bus.publish(JobProgress(DENSE, f, f"{method}: {shape} voxels")),
                                   cancel)
        low = np.asarray(volume.origin) - volume.voxel / 2
        high = low + volume.voxel * np.asarray(volume.shape)
        if isinstance(result, CarveResult):
            points, sources = result.surface_points()
            dense = DenseResult(points, sources, None, method, low, high, volume.voxel,
                                f"{method}: {len(points):,} surface voxels of {volume.voxel * 1e3:.1f} mm", time.time(),
                                source)
        else:
            mesh = result.mesh()
            dense = DenseResult(mesh.vertices, mesh.sources, mesh.faces, method, low, high, volume.voxel,
                                f"tsdf: mesh of {len(mesh.vertices):,} vertices, {len(mesh.faces):,} faces",
                                time.time(), source)
        if missing := left_out(snapshot.session):          # a sphere's 519 voxels, said as done (a helper)
            dense = replace(dense, summary=f"{dense.summary}; ⚠ {missing}")
        self.dense_result = dense
        self.bus.publish(DenseChanged(dense))
        return dense.summary

    # ------------------------------------------------------------------ calibration from the object
    def start_refine(self, editor: "SessionEditor") -> threading.Thread:
        """Refine the planes of the session's calibrated mirrors from the agreement of the views (mirrorcore.calibration.refine.
        refine_session) over object_frames, then apply the planes and marker offsets (one undo step per mirror); the
        per-mirror report is the job's last status."""
        depths, used = self.object_frames()
        session, snapshot = editor.session, self.snapshot()
        return self._start(REFINE, lambda cancel: self._calibrate(
            editor, session, snapshot, depths, used, cancel, None), "a refinement is already running")

    def start_scene(self, editor: "SessionEditor") -> threading.Thread:
        """Find the planes of the mirrors that have a boundary and no plane from the object, without markers
        (mirrorcore.calibration.search.calibrate_scene: a search in the first of object_frames, then the refinement over all of
        them, the other calibrated mirrors taking part as they are), and apply them as start_refine does."""
        session = editor.session
        todo = [i for i, m in enumerate(session.mirrors) if m.boundary and m.plane is None]
        if not todo:
            raise MirrorscanError("no mirror has a boundary and no plane: draw a mirror's boundary first (a mirror "
                                  "with a plane is refined with Refine from the object)")
        depths, used = self.object_frames()
        snapshot = self.snapshot()
        return self._start(REFINE, lambda cancel: self._calibrate(
            editor, session, snapshot, depths, used, cancel, todo), "a refinement is already running")

    def marker_frames(self) -> np.ndarray | None:
        """The frames the markers are read on (a fit, and each marker's grade; per pixel, markers.marker_points):
        the background and MAX_MARKER_FRAMES frames spread over the recording that plays (the same whenever it is
        clicked, as `mirrorscan calibrate` reads them; read once per recording), else the last live frames
        (RECENT_FRAMES) with the background in use, both without what passes in front of it (static_frames), or
        None before the first. (k, H, W) float32 metres."""
        source = self.loop.source
        if isinstance(source, SessionSource) and source.session.frames:
            session = source.session
            key = (session.root, session.frames, session.background)
            cached = self._marker_frames
            if cached is None or cached[0] != key:
                try:
                    cached = self._marker_frames = (key, calibration_depth(session))
                except MirrorscanError as exc:        # its files went bad: the frames as they play still serve
                    log.warning("the markers are read on the last frames: %s", exc)
                    return self._live_marker_frames()
            return cached[1]
        return self._live_marker_frames()

    def _live_marker_frames(self) -> np.ndarray | None:
        recent = self.loop.recent_depths()
        return None if recent is None else static_frames(recent, self.snapshot().background)

    def object_frames(self) -> tuple[np.ndarray, str]:
        """The frames a calibration from the object uses, and which they are in words: REFINE_FRAMES spread over
        the recording that plays (the same whenever it is clicked, as `mirrorscan calibrate` picks them), else the
        last live frames (RECENT_FRAMES). (k, H, W) float32 metres."""
        source = self.loop.source
        if isinstance(source, SessionSource) and source.session.frames:
            picks = source.session.spread_frames(REFINE_FRAMES)
            depths = source.session.read_frames(picks)
            return depths, _frames_used(picks, len(source.session.frames))
        depths = self.loop.recent_depths()
        if depths is None:
            raise MirrorscanError("no frame yet to calibrate from")
        return depths, "the last live frame" if len(depths) == 1 else f"the last {len(depths)} live frames"

    def _refuse(self, session: Session, ids: list[int], kind: str) -> None:
        """Mark the mirrors `ids` refused by `kind` ('refine' or 'scene') as they now are (refusals)."""
        self.refused.update(dict.fromkeys(ids, kind))
        self._refused_on.update({m.id: (m.boundary, m.markers) for m in session.mirrors if m.id in ids})

    def _calibrate(self, editor: "SessionEditor", session: Session, snapshot, depths: np.ndarray, used: str,
                   cancel: threading.Event, search: list[int] | None) -> str:
        """Refine the calibrated planes (search None), or find those of the mirrors at `search` (0-based) first."""
        doing = "refining the planes" if search is None else "finding the planes"
        self.bus.publish(JobProgress(REFINE, 0.0, f"{doing} from {used}…"))
        masks = np.stack([prepare_frame(snapshot.rig, d, snapshot.backdrop, session.selection)[1] for d in depths])
        progress = lambda f: self.bus.publish(JobProgress(  # noqa: E731
            REFINE, f, f"{doing} from the object seen directly and in the mirrors, over {used}…"))
        kind, ids = ("refine", [m.id for m in session.mirrors if m.plane is not None]) if search is None else (
            "scene", [session.mirrors[i].id for i in search])
        try:
            if search is None:
                refined, result = refine_session(session, depths, masks, progress=progress, cancel=cancel)
            else:
                refined, result = calibrate_scene(session, depths, masks, np.random.default_rng(0), search, progress,
                                                  cancel)
        except CalibrationError as exc:            # the mirrors it names (a search refused on one had withdrawn
            named = [m.id for m in session.mirrors if m.id in ids and m.name in exc.mirrors]
            self._refuse(session, named or ids, kind)                       # the others' offer too: a helper)
            raise
        missing = [session.mirrors[i].id for i, _ in result.refused]       # a search: those it could not do
        for mirror_id in ids:
            self.refused.pop(mirror_id, None)
        self._refuse(session, missing, kind)
        planes = {session.mirrors[r.index].id: (r.after, session.mirrors[r.index]) for r in result.mirrors}
        glass = {session.mirrors[r.index].id: (refined.mirrors[r.index].marker_offset,
                                                refined.mirrors[r.index].marker_offset_std) for r in result.mirrors}
        changed = (search is not None or result.changed(session, refined)) and editor.set_planes(
            planes, glass, what="refined plane" if search is None else "found plane")
        self._object_planes.update((i, editor.mirror(i).plane) for i in planes)
        self.start_agreement(depths)                 # the lines under the report: the new planes' agreement
        details = [f"**{r.name}** {'refined' if search is None else 'found'}: "
                   f"{r.summary(searched=search is not None, saved=changed)}" for r in result.mirrors]
        details += [f"**{session.mirrors[i].name}**{NOT_FOUND}{why.removeprefix(session.mirrors[i].name + ': ')}"
                    for i, why in result.refused]
        if not changed:                              # no undo step: Undo and Redo keep the report that set them
            report = "\n\n".join([f"{UNCHANGED} Over {used}.", *details])
            self.refinements.setdefault(planes_key(editor.session), report)
            return report
        not_found = [session.mirrors[i].name for i, _ in result.refused]
        headline = (refined_headline(result.mirrors, result.compared) if search is None else
                    found_headline(result.mirrors, result.compared, not_found))
        undo = UNDO_NOTE if search is None else UNDO_FOUND
        if result.refused:                           # Undo goes by the mirror selected, which may be one not found
            undo = f"{undo.removesuffix('.')}, with {listed([r.name for r in result.mirrors])} selected."
        report = "\n\n".join([f"{headline} Over {used}. {undo}", *details])
        self.refinements[planes_key(editor.session)] = report
        return report

    def report(self, key: tuple) -> str:
        """The report of the refinement or markers fit that left the planes `key` (planes_key), '' when none did."""
        return self.refinements.get(key) or self.fits.get(key, "")

    def start_agreement(self, depths: np.ndarray | None = None) -> None:
        """How well each mirror's view agrees with the others over frames (mirrorcore.calibration.refine.view_agreement; depths
        (k, H, W) or (H, W) metres, the last AGREEMENT_FRAMES of them; None: the last live frames), with the current
        session's planes and selection, as the job's last status. While one runs, none is started: the running one
        checks again when the rig or the background changed meanwhile (an undo, a fit), so that its report is
        always the current planes'. Safe from any thread (the refinement's worker asks for one too)."""
        depths = self.loop.recent_depths() if depths is None else np.asarray(depths)
        if depths is None:
            return
        depths = depths.reshape(-1, *depths.shape[-2:])[-AGREEMENT_FRAMES:]
        self.bus.publish(JobProgress(AGREEMENT, 0.0, CHECKING))     # every tab: the lines there are the old planes'

        def work(cancel: threading.Event) -> str:
            snapshot = None
            while snapshot is None or not _same_views(snapshot, self.snapshot()):
                snapshot = self.snapshot()
                masks = np.stack([prepare_frame(snapshot.rig, depth, snapshot.backdrop,
                                                snapshot.session.selection)[1] for depth in depths])
                found = view_agreement(snapshot.rig, depths, masks)                  # by the rig's mirror index
                mirrors = snapshot.session.mirrors
                lines = [agreement_line(mirrors[j].name, found[j], self._by_markers(mirrors[j])) for j in sorted(found)]
            self.disagreeing = tuple(mirrors[j].name for j in sorted(found) if found[j].points >= MIN_AGREEMENTS
                                     and agreement_doubt(found[j]))
            self.agreement = "\n\n".join(lines) or NO_AGREEMENT
            return self.agreement
        try:
            self._start(AGREEMENT, work, "an agreement check is running")
        except MirrorscanError:
            pass                  # one runs (the check and the start are one step under the jobs' lock): it reports

    def _by_markers(self, mirror) -> bool:
        """Whether a mirror's plane comes from its markers (3 or more, and not a plane this app found or refined
        from the object): what the agreement's advice may send the technician back to."""
        return len(mirror.markers) >= 3 and not self.from_object(mirror.id, mirror.plane)

    def start_heat(self, frame: "LiveFrame") -> None:
        """The heat map of one live frame, on a worker (about a third of a second a frame): its points, grey for the
        direct view and coloured by their distance to the direct surface for the mirrors' (agreement.local_means
        of it; white on it, red outside, blue inside, HEAT_LIMIT_MM and beyond saturated; dark grey where the camera
        does not see them), and each mirror view's figures (of the points' own distances), published as
        HeatChanged; skipped while one runs."""
        if self.running(HEAT):
            return

        def work(cancel: threading.Event) -> None:
            distances = surface_distances(frame.snapshot.rig, frame.cloud, frame.prepared_depth)
            sources = frame.cloud.sources
            local = local_means(distances, frame.cloud.pixel_index, sources, frame.prepared_depth.shape)
            colours = heat_map_colours(local, sources, HEAT_LIMIT_MM)
            pooled = self._pool_heat(frame.snapshot.rig, frame_number(frame.index, self.loop.source.frame_count),
                                     distances, sources)
            figures = heat_figures(*(np.concatenate(parts) for parts in zip(*pooled)))
            self.bus.publish(HeatChanged(frame.index, frame.cloud.points, colours, figures, len(pooled), sources))
        self._start(HEAT, work, "")

    def heat_wanted(self, frame: "LiveFrame") -> bool:
        """Whether a heat map of `frame` adds to the legend's pool: not when the pool, not yet full, has this frame
        of a replay with these planes (sampled once a second, a replay of 10 frames at 9 to 10 a second gave the
        same few frames again: 8 frames took 82 s, a helper). A live camera's frames are all new."""
        count = self.loop.source.frame_count
        if not count or frame.snapshot.rig is not self._heat_rig:
            return True
        return (frame_number(frame.index, count) not in self._heat_pool
                or len(self._heat_pool) >= min(HEAT_POOL, count))

    def _pool_heat(self, rig, number: int, distances: np.ndarray,
                   sources: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """The (distances, sources) of the heat maps of the last HEAT_POOL frames with the same planes, this one
        (frame `number`, as the header counts it) last: the legend's figures over them. A frame met again (a replay
        loops three times a second, and a map is made once a second) takes its place anew; a new calibration
        starts a new pool."""
        if self._heat_rig is not rig:
            self._heat_rig, self._heat_pool = rig, {}
        self._heat_pool.pop(number, None)
        self._heat_pool[number] = (distances, sources)
        while len(self._heat_pool) > HEAT_POOL:
            del self._heat_pool[next(iter(self._heat_pool))]
        return list(self._heat_pool.values())

    # ------------------------------------------------------------------ batch reconstruction
    def start_batch(self, session: Session, method: str, options: DenseOptions, temporal: int,
                    workers: int) -> Path:
        """Reconstruct every frame of a saved recording into SESSION/exports/frames-METHOD[-temporalN] (one PLY per
        frame and a manifest; mirrorcore.batch), on `workers` local processes (1: in this process); a second start
        of the same job goes on where it stopped. Returns the output folder."""
        if not session.frames or not (Path(session.root) / SESSION_FILE).is_file():
            raise MirrorscanError("a batch reads a saved session with frames: record one (or Save as) first")
        out = exports_folder(session.root, method, temporal)
        job = BatchJob(Path(session.root), out, method, options, temporal)
        self._start(BATCH, lambda cancel: self._batch(job, Where(workers=workers), cancel),
                    "a batch is already running; cancel it first")
        self.batch_settings = (method, temporal, workers)          # a tab opening while it runs shows them
        return out

    def _batch(self, job: BatchJob, where: Where, cancel: threading.Event) -> str:
        self.bus.publish(JobProgress(BATCH, 0.0, f"starting {job.method} on every frame…"))
        run = BatchRun(job, where, on_progress=lambda p: self.bus.publish(JobProgress(BATCH, p.fraction,
                                                                                       batch_status(p))))
        run.start()
        while run.wait(0.2) is None:
            if cancel.is_set():
                run.cancel()
        return batch_summary(run.wait())

    # ------------------------------------------------------------------ background
    def capture_background(self, n_frames: int, on_done: Callable[[np.ndarray], str | None]) -> threading.Thread:
        """The per-pixel median of the next n_frames frames, handed to on_done(depth (H, W) metres), which may
        return the status to show instead of 'captured from N frames'."""
        def work(cancel: threading.Event) -> str:
            progress = lambda k: self.bus.publish(JobProgress(BACKGROUND, k / n_frames,  # noqa: E731
                                                              f"{k} of {n_frames} frames"))
            frames = self.loop.collect(n_frames, progress, cancel=cancel)
            status = on_done(median_depth(np.stack(frames)))
            return status or f"captured from {n_frames} frames"
        return self._start(BACKGROUND, work, "a background capture is already running")

    # ------------------------------------------------------------------ recording
    def start_recording(self, sessions_dir: Path) -> Path:
        """Record the live frames into a new session folder in `sessions_dir` (a name of its own even when two
        recordings start in the same second); stop_recording() saves it with the session's mirrors and selection as
        they are then. Returns the folder."""
        with self._lock:
            if RECORD in self._running:
                raise MirrorscanError("already recording; stop first")
            self._running[RECORD] = threading.Event()
        try:
            folder = new_recording_folder(sessions_dir)
            self._tap = LiveTap(self.loop.source,
                                lambda take: self.bus.subscribe(FrameReady, lambda e: take(e.frame)))
        except (MirrorscanError, OSError):
            with self._lock:
                self._running.pop(RECORD, None)
            raise
        self.recorder = Recorder(self._tap, folder).start()
        self.bus.publish(JobProgress(RECORD, 0.0, f"recording into `{folder}`…{self._replay_left()}"))
        self._unsubscribe_count = self.bus.subscribe(FrameReady, lambda e: self._count(e.frame.index))
        return folder

    def _replay_at(self) -> tuple[int, int] | None:
        """(the frame shown, the frame count) of the recording that plays, or None for a live source."""
        count = self.loop.source.frame_count
        return (frame_number(max(self.loop.index - 1, 0), count), count) if count else None

    def _replay_left(self) -> str:
        """For a recording that plays: where it is (it is taken up to its last frame; a helper's take from near its
        end held 3 frames), and how to take all of it."""
        if (playing := self._replay_at()) is None:
            return ""
        at, count = playing
        return (f" (the recording that plays is at frame {at} of {count}: it is taken up to its last one"
                + ("; to take all of it, stop, set the Frame slider to 0, and record again)" if at > 0 else ")"))

    def _count(self, index: int) -> None:
        """Say how many frames the recording holds, every 10th live frame."""
        status = self.recording_status()
        if status is not None and index % 10 == 0:
            self.bus.publish(JobProgress(RECORD, 0.0, status))

    def recording_status(self) -> str | None:
        """How the recording stands, in a line (Markdown), or None when none runs."""
        recorder, tap = self.recorder, self._tap
        if recorder is None or tap is None:
            return None
        if recorder.done and recorder.error is not None:
            return f"the recording stopped: {recorder.error}"
        if tap.replay_ended:
            return (f"the recording that plays came to its last frame: {tap.taken} frames taken into "
                    f"`{recorder.folder}`, none twice{_behind(recorder, tap)}; **Stop recording** saves them")
        playing = self._replay_at()
        more = (f" (up to the last frame of the recording that plays: {playing[1] - 1 - playing[0]} more)"
                if playing else "")
        return f"recording: {tap.taken} frames into `{recorder.folder}`{_behind(recorder, tap)}{more}"

    def recording_headline(self) -> str | None:
        """The header's word on the recording (Markdown, short: it is in view from every step), or None."""
        recorder, tap = self.recorder, self._tap
        if recorder is None or tap is None:
            return None
        if tap.replay_ended or recorder.done:
            return f"● **recording ended** at {tap.taken} frames: *Record › Stop recording* saves it"
        return f"● **recording** {tap.taken} frames"

    def stop_recording(self, current: Session) -> Session:
        with self._lock:
            if RECORD not in self._running or self.recorder is None or self._tap is None:
                raise MirrorscanError("not recording")
        recorder, tap = self.recorder, self._tap
        self._unsubscribe_count()
        tap.close()
        try:
            recorded = recorder.stop(timeout=5)     # always returns; a stuck source is named with what was saved
        finally:
            with self._lock:
                self._running.pop(RECORD, None)
            self.recorder = self._tap = None
        recorded = replace(recorded, mirrors=current.mirrors, selection=current.selection)
        save_session(recorded)
        dropped = f" ({tap.dropped} dropped: the disk was too slow)" if tap.dropped else ""
        self.bus.publish(JobProgress(RECORD, None, f"recorded {len(recorded.frames)} frames into "
                                                   f"`{recorded.root}`{dropped}"))
        return recorded


def _behind(recorder: Recorder, tap: LiveTap) -> str:
    """' (N written so far)' while the recorder writes behind the frames taken, else '': the header, the Record
    step and the end had said 25, 21 and 28 frames of one take (a helper)."""
    return f" ({recorder.frames} written so far)" if recorder.frames < tap.taken else ""


def _same_views(a: "Snapshot", b: "Snapshot") -> bool:
    """Whether two snapshots give the same clouds: the same rig (a Snapshot keeps the one before when the camera and
    the mirrors are unchanged), background and selection."""
    return a.rig is b.rig and a.backdrop is b.backdrop and a.session.selection == b.session.selection


def planes_key(session: Session) -> tuple:
    """What a refinement leaves: each mirror's id and plane (undo and redo find its report by it)."""
    return tuple((m.id, m.plane) for m in session.mirrors)


def left_out(session: Session) -> str:
    """What a cloud of the session leaves out: 'mirror 1 and mirror 2 have no plane yet: what is seen inside their
    outlines is not in it', or '' when every mirror with an outline has a plane."""
    bare = [m.name for m in session.mirrors if m.boundary and m.plane is None]
    return (f"{listed(bare)} {'has' if len(bare) == 1 else 'have'} no plane yet: what is seen inside "
            f"{'its outline' if len(bare) == 1 else 'their outlines'} is not in it" if bare else "")


def _frames_used(picks: list[int], count: int) -> str:
    """The frames of a recording of `count` a calibration from the object used (`picks`), in words ("Over frames 0
    of the recording's 1" read oddly: a helper)."""
    if count == 1:
        return "the recording's only frame"
    which = f"frame {picks[0]}" if len(picks) == 1 else f"frames {', '.join(map(str, picks))}"
    return f"{which} of the recording's {count} (numbered as in the header)"


def refined_headline(mirrors, compared: str = "surfaces") -> str:
    """One sentence for a refinement's new planes (MirrorRefinement each): how far each moved, and its glass;
    `compared` (Refinement.compared): "sphere" says they came from the sphere's centres; from the surfaces, a glass
    measured is said to be no surer than their planes (a walking figure's 3 mm read 0.5 and 1.7 mm, saved without a
    word: a helper)."""
    moved = [f"{r.name} moved {_signed(r.shift_mm)} mm and {r.tilt_deg:.2f}°" + _glass(r) for r in mirrors]
    how = " from the sphere's centres" if compared == "sphere" else ""
    measured = any(r.marker_offset is not None and r.glass_typed is None for r in mirrors)
    glass = (f" {GLASS_ADVICE} these planes, which {METHOD_BIAS['surfaces'].words.removeprefix('the method ')}: "
             "if you know it (3 to 6 mm on an ordinary mirror), type it under Mirrors › Rename, glass, remove, clear "
             "(the markers fit then uses it; a refinement keeps it, and its planes do not depend on it)." if
             compared == "surfaces" and measured else "")
    return f"{REFINED}{how} (moved > 0: away from the camera): {'; '.join(moved)}.{glass}"


def _glass(r) -> str:
    """A refined mirror's glass for the headline (MirrorRefinement): measured, kept as typed in, or nothing."""
    if r.marker_offset is None:
        return ""
    read = f"{1e3 * r.marker_offset:.1f} ± {1e3 * r.marker_offset_std:.1f} mm"
    if r.glass_typed is None:
        return f", glass {read}"
    return f", glass {1e3 * r.glass_typed:.1f} mm as typed in (read {read})"


def found_headline(mirrors, compared: str = "surfaces", not_found: list[str] = ()) -> str:
    """One sentence for planes found without markers (MirrorRefinement each): how well the data fix each, and
    (compared, as for refined_headline) what they came from; then the mirrors `not_found` (names), if any."""
    fixed = [f"{r.name} to ±{r.shift_std_mm:.1f} mm and ±{r.tilt_std_deg:.2f}°" for r in mirrors]
    head = "Planes found from the sphere's centres" if compared == "sphere" else FOUND
    missing = (f" ⚠ {listed(not_found)}{NOT_FOUND_HEAD}: {'its' if len(not_found) == 1 else 'their'} "
               "plane is as it was." if not_found else "")
    return (f"{head} (no markers), fixed by the data: {'; '.join(fixed)} (1σ; {METHOD_BIAS[compared].reported})"
            f"{FOUND_CHECK}.{missing}")


def _signed(mm: float) -> str:
    """mm to 0.1 with its sign, '0.0' when it rounds to nothing (beside a detail line's '-0.02', '+0.0' read as
    a contradiction)."""
    return f"{mm:+.1f}" if round(mm, 1) != 0 else "0.0"


def agreement_line(name: str, found: ViewAgreement, by_markers: bool = True) -> str:
    """One mirror's agreement with the other views, against what the depth noise of the readings compared explains
    (mirrorcore.calibration.refine.view_agreement; beyond it: agreement_doubt). A mirror that disagrees with the camera gets a
    warning that its plane may be tilted or its boundary off; one that agrees with the camera but not with another
    mirror, that a plane is off (this one's along its normal, or another's), so that a mirror whose neighbour was
    fitted wrong is not told to fix itself (a helper). Fewer than MIN_AGREEMENTS comparisons judge nothing, as they
    fix no plane in the refinement: 26 of them with the camera flagged a mirror one way and then the other, the
    planes unchanged (a helper, a box on an arc of three mirrors). The advice names the markers and the glass only
    `by_markers` (the plane comes from them: a plane found from the object had been sent to its markers)."""
    if not found.points or not np.isfinite(found.rms_mm):
        return (f"{name}: nothing of the object is seen both in it and by another view, so its agreement cannot be "
                "checked (put the object in view)")
    if found.points < MIN_AGREEMENTS:
        return (f"{name}: too little of what it shows is seen by another view to judge its plane ({found.points:,} "
                f"points seen both ways {_over(found)}, {MIN_AGREEMENTS} needed): put the object where the camera and "
                "the mirror both see its sides (a person, a sphere), or check its markers' grades")
    doubt = agreement_doubt(found)
    if doubt == "camera":
        rms, noise = _apart(found.camera_rms_mm, found.camera_noise_mm)
        return (f"{name}: ⚠ its points lie {found.camera_mean_mm:+.1f} mm from the camera's surface on average "
                f"(RMS {rms} mm, the depth noise {noise} mm; good planes within "
                f"{CAMERA_MEAN_EXPLAINS * found.camera_noise_mm:.1f} mm) {_over(found)}: its plane may be tilted or "
                f"its boundary off; Refine from the object, or check its {'markers' if by_markers else 'boundary'} "
                f"({found.camera_points:,} points seen both ways)")
    figures = f"mean {found.mean_mm:+.1f} mm over {found.points:,} points seen both ways"
    if doubt == "mirrors":
        camera = (f"agrees with the camera (mean {found.camera_mean_mm:+.1f} mm) but not with the other mirrors"
                  if found.camera_points >= MIN_AGREEMENTS else
                  "disagrees with the other mirrors (the camera sees too little of what it shows to say which is off)")
        limit = MEAN_EXPLAINS * found.noise_mm
        if abs(found.mean_mm) > limit:         # what flags it, first: 'RMS 9.6 mm against 11.2' read as fine (a helper)
            why = (f"its points lie {found.mean_mm:+.1f} mm from theirs on average, good planes within {limit:.1f} mm "
                   f"(RMS {found.rms_mm:.1f} mm, the depth noise {found.noise_mm:.1f} mm")
        else:
            rms, noise = _apart(found.rms_mm, found.noise_mm)
            why = f"RMS {rms} mm against {noise} mm of depth noise (mean {found.mean_mm:+.1f} mm"
        glass = (": markers on glass put it that much too near (set each mirror's glass and fit again), or Refine "
                 "from the object" if by_markers else ": Refine from the object")
        return (f"{name}: ⚠ {camera}: {why}; {found.points:,} points seen both ways {_over(found)}). Another "
                f"mirror flagged against the camera is off; if none is, a plane is off along its normal{glass}")
    return (f"{name}: agrees with the other views within {found.rms_mm:.1f} mm RMS {_over(found)}, as the depth noise "
            f"there explains ({found.noise_mm:.1f} mm; {figures})")


def agreement_doubt(found: ViewAgreement) -> str:
    """'camera' when a mirror's comparisons with the camera (MIN_AGREEMENTS or more) go beyond the noise (their RMS
    beyond NOISE_EXPLAINS times it, or their mean beyond CAMERA_MEAN_EXPLAINS times), 'mirrors' when only all its
    comparisons together do (MEAN_EXPLAINS for their mean), else ''. The camera's alone single out a tilted plane:
    the comparisons between two mirrors put a tilt or an offset of one on both (mirrorcore.calibration.refine)."""
    def beyond(rms: float, mean: float, noise: float, share: float) -> bool:
        return rms > NOISE_EXPLAINS * noise or abs(mean) > share * noise
    if found.camera_points >= MIN_AGREEMENTS and beyond(found.camera_rms_mm, found.camera_mean_mm,
                                                        found.camera_noise_mm, CAMERA_MEAN_EXPLAINS):
        return "camera"
    return "mirrors" if beyond(found.rms_mm, found.mean_mm, found.noise_mm, MEAN_EXPLAINS) else ""


def _over(found: ViewAgreement) -> str:
    """'on one frame' or 'over 5 frames': what the agreement's figures pool."""
    return "on one frame" if found.frames == 1 else f"over {found.frames} frames"


def _apart(value: float, limit: float) -> tuple[str, str]:
    """Two figures (mm) to 0.1, or to 0.01 where they would read the same: '17.8 mm, more than 17.8 mm' read as a
    contradiction (a helper)."""
    places = 2 if f"{value:.1f}" == f"{limit:.1f}" else 1
    return f"{value:.{places}f}", f"{limit:.{places}f}"
