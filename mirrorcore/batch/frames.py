"""The worker's side of a batch: the context built once (rig with its per-pixel tables, background,
job) and shipped to every worker, and the reconstruction of a run of frames into PLY files, each
written atomically."""
from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mirrorcore.base.atomic import write_atomic
from mirrorcore.dense import dense_volume, reconstruct_dense, result_geometry
from mirrorcore.base.errors import Cancelled, MirrorscanError
from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.io.ply import encode_ply
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.rig.model import Rig, calibrated_rig
from mirrorcore.io.session import Session
from mirrorcore.depth.temporal import check_window_memory, frame_window, temporal_smooth
from mirrorcore.batch.job import BatchJob, output_names
from mirrorcore.batch.records import FrameRecord


@dataclass(frozen=True, eq=False)
class FrameContext:
    """What every frame of a batch shares, built once by the client.

    Attributes
    ----------
    session : Session
        Its root an absolute path.
    rig : Rig
        The calibrated rig, its per-pixel tables already computed (they travel with it).
    background : (H, W) float32 array or None
        Metres.
    job : BatchJob
    names : tuple of str
        Each frame's output file name.
    threads : int or None
        The threads a dense frame may use (None: all).
    """

    session: Session
    rig: Rig
    background: np.ndarray | None
    job: BatchJob
    names: tuple[str, ...]
    threads: int | None = None

    @classmethod
    def build(cls, session: Session, job: BatchJob, threads: int | None = None) -> FrameContext:
        """Build the context of a batch.

        Parameters
        ----------
        session : Session
        job : BatchJob
        threads : int, optional

        Returns
        -------
        FrameContext

        Raises
        ------
        MirrorscanError
            An uncalibrated session, or frames whose output names collide.
        """
        rig = calibrated_rig(session, job.bounces)
        # computed once, here
        rig.reflection_table, rig.inside_bits, rig.intrinsics.rays  # noqa: B018
        return cls(session, rig, session.read_background(), job, output_names(session), threads)


def read_depth(session: Session, index: int, temporal: int = 0,
               cache: dict[int, np.ndarray] | None = None
               ) -> np.ndarray:
    """Read a frame, smoothed with its neighbours where the scene is static.

    Parameters
    ----------
    session : Session
    index : int
        0-based, negative from the end.
    temporal : int
        Neighbours on each side (mirrorcore.depth.temporal); 0: as read.
    cache : dict of int to array, optional
        Frame index -> depth; keeps the frames read for the next call.

    Returns
    -------
    (H, W) float32 array
        Metres.
    """
    count = len(session.frames)
    if not -count <= index < count:
        session.read_frame(index)              # refuses it, naming the frames there are
    index %= count
    cache = {} if cache is None else cache
    window = frame_window(index, temporal, count)
    if temporal:
        check_window_memory(len(window), session.camera.shape, f"--temporal {temporal}")
    for i in window:
        if i not in cache:
            cache[i] = session.read_frame(i)
    if temporal == 0:
        return cache[index]
    return temporal_smooth(np.stack([cache[i] for i in window]), window.index(index))


def reconstruct_frames(context: FrameContext, indices: Iterable[int], cancel=None
                       ) -> tuple[list[FrameRecord], dict[int, str]]:
    """Reconstruct frames (in order) into context.job.out, one PLY file each.

    Written atomically but not flushed to the disk: the client does that before the manifest lists
    them (OutputFolder.flush), so that no worker waits for the disk.

    Parameters
    ----------
    context : FrameContext
    indices : iterable of int
    cancel : callable, optional
        Asked before each frame and during a dense one (returns True to stop): the frames done
        so far are returned.

    Returns
    -------
    records : list of FrameRecord
        The frames written.
    failures : dict of int to str
        {index: one-line error} of the frames that could not be read or reconstructed
        (MirrorscanError, OSError: the others go on).
    """
    records, failures, cache = [], {}, {}
    for index in indices:
        if cancel is not None and cancel():
            break
        start = time.perf_counter()
        for old in [i for i in cache if i < index - context.job.temporal]:
            del cache[old]                                   # keep only the frames still needed
        try:
            data, sources, faces = _frame_ply(context, index,
                                              read_depth(context.session, index,
                                                         context.job.temporal, cache), cancel)
            path = Path(context.job.out) / context.names[index]
            write_atomic(path, data, durable=False)
        except Cancelled:
            break
        except (MirrorscanError, OSError) as exc:
            failures[index] = _one_line(exc)
            continue
        counts = np.bincount(sources, minlength=len(context.rig.mirrors) + 1)
        records.append(FrameRecord(index, context.names[index], len(sources), faces,
                                   tuple(int(c) for c in counts),
                                   len(data), round(time.perf_counter() - start, 4)))
    return records, failures


def _frame_ply(context: FrameContext, index: int, depth: np.ndarray, cancel=None
               ) -> tuple[bytes, np.ndarray, int | None]:
    """One frame's PLY bytes, its vertices' sources (n,) uint8 and its face count (None for clouds).
    The vertices carry the scene's colour (frame `index`'s colour image) with job.colour 'scene'
    and a session with colour frames. A dense frame with no object pixels (and no fixed box) gives
    an empty file rather than an error: the person left the view."""
    rig, job = context.rig, context.job
    depth, mask = prepare_frame(rig, depth, context.background, context.session.selection)
    colour = context.session.read_colour(index) if job.colour == "scene" else None
    if job.method == "raw":
        cloud = reconstruct_raw(rig, depth, mask, colour)
        rgb = None if cloud.rgb is None else np.ascontiguousarray(cloud.rgb)
        return encode_ply(cloud.points, cloud.sources, colours=rgb), cloud.sources, None
    if job.options.bounds is None and len(reconstruct_raw(rig, depth, mask)) == 0:
        points, sources = np.zeros((0, 3), np.float32), np.zeros(0, np.uint8)
        faces = np.zeros((0, 3), np.int32) if job.method == "tsdf" else None
        colours = None if colour is None else np.zeros((0, 3), np.uint8)
    else:
        volume = dense_volume(rig, depth, mask, job.options)
        points, sources, faces, colours = result_geometry(reconstruct_dense(
            rig, depth[None], mask[None], volume, job.method, job.options, cancel=cancel,
            workers=context.threads, colours=None if colour is None else colour[None]))
    return (encode_ply(points, sources, faces, colours), sources,
            None if faces is None else len(faces))


def _one_line(exc: BaseException) -> str:
    """An error as one line: our own errors as they are, OS errors with the file they name."""
    if isinstance(exc, OSError) and exc.filename:
        return f"{exc.filename}: {exc.strerror or exc}"
    return " ".join(str(exc).split())


def task_error(exc: BaseException) -> str:
    """Write an unexpected error of a whole task as one line with its type.

    A bug, or KilledWorker after its workers died.

    Parameters
    ----------
    exc : BaseException

    Returns
    -------
    str
    """
    return f"{type(exc).__name__}: {_one_line(exc)}"

