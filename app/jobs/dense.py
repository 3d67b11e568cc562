"""The dense reconstruction job: carve or fuse the recent frames with the current calibration."""

from __future__ import annotations

import threading
import time

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.dense import DenseOptions, dense_volume, reconstruct_dense
from mirrorcore.dense.carve import CarveResult
from mirrorcore.dense.normals import surface_normals
from mirrorcore.io.session import Session
from mirrorcore.rig.pipeline import prepare_frame

from ..events import DenseChanged
from ..results import DenseResult, DenseWork
from .runner import DENSE, Runner


def unplaned(session: Session) -> tuple[str, ...]:
    """The names of the mirrors with an outline and no plane.

    A cloud of the session leaves out what is seen inside their outlines.

    Parameters
    ----------
    session : Session

    Returns
    -------
    tuple of str
    """
    return tuple(m.name for m in session.mirrors if m.boundary and m.plane is None)


class DenseJob(Runner):
    """Dense reconstruction (Jobs mixes it in); `dense_result` holds the last one."""

    dense_result: DenseResult | None = None

    def start_dense(self, method: str, options: DenseOptions, frames: int) -> threading.Thread:
        """Carve or fuse the last `frames` frames with the current calibration.

        Parameters
        ----------
        method : str
            The dense method.
        options : DenseOptions
        frames : int
            1 for carving.

        Returns
        -------
        threading.Thread
            The job's thread.

        Raises
        ------
        MirrorscanError
            Before the first frame, or while a dense reconstruction runs.
        """
        recent = self.loop.recent_frames()
        if recent is None:
            raise MirrorscanError("no frame yet")
        depths, colours = recent
        colours = None if colours is None else colours[-frames:]
        snapshot, source = self.snapshot(), self.loop.source.name
        return self._start(
            DENSE,
            lambda cancel: self._dense(snapshot, source, depths[-frames:], method, options, cancel,
                                       colours),
            "a dense reconstruction is already running; cancel it first",
        )

    def _dense(
        self,
        snapshot,
        source: str,
        depths: np.ndarray,
        method: str,
        options: DenseOptions,
        cancel: threading.Event,
        colours: np.ndarray | None = None,
    ) -> DenseResult:
        """Carve or fuse the frames with the snapshot's rig, coloured with their colour images
        (k, H, W, 3) when given; keep and publish the result."""
        self.progress(DENSE, 0.0, DenseWork(method, len(depths)))
        prepared = [
            prepare_frame(snapshot.rig, d, snapshot.backdrop, snapshot.session.selection)
            for d in depths
        ]
        # refuses boxes of too many voxels
        volume = dense_volume(snapshot.rig, *prepared[-1], options)
        work = DenseWork(method, len(depths), tuple(volume.shape))
        result = reconstruct_dense(
            snapshot.rig,
            np.stack([p[0] for p in prepared]),
            np.stack([p[1] for p in prepared]),
            volume,
            method,
            options,
            lambda f: self.progress(DENSE, f, work),
            cancel,
            colours=colours,
        )
        low = np.asarray(volume.origin) - volume.voxel / 2
        high = low + volume.voxel * np.asarray(volume.shape)
        # a carving's points are shaded by their normals; a fusion's mesh is closed where seen
        if isinstance(result, CarveResult):
            vertices, sources = result.surface_points()
            faces, vertex_colours = None, result.colours
            normals = surface_normals(vertices, sources, snapshot.rig, volume.voxel)
        else:
            mesh = result.closed_mesh()
            vertices, sources, faces, normals = mesh.vertices, mesh.sources, mesh.faces, None
            vertex_colours = mesh.colours
        dense = DenseResult(
            vertices,
            sources,
            faces,
            method,
            low,
            high,
            volume.voxel,
            time.time(),
            source,
            unplaned(snapshot.session),
            normals,
            vertex_colours,
        )
        self.dense_result = dense
        self.bus.publish(DenseChanged(dense))
        return dense
