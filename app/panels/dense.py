"""The "Dense" folder: carve (the paper's Algorithm 2, or the consistent carving) or fuse (TSDF) the recent frames of
a static object inside a box (automatic around the cloud, adjustable), with a progress bar and a cancel button; the
result is shown beside the live cloud, as points or a mesh in the source colours, and can be exported."""
from __future__ import annotations

import threading
from typing import TYPE_CHECKING

import numpy as np
import trimesh

from mirrorcore.dense import DenseOptions, dense_volume, reconstruct_dense
from mirrorcore.dense.carve import CarveResult
from mirrorcore.dense.volume import Volume
from mirrorcore.errors import Cancelled, MirrorscanError
from mirrorcore.palette import source_colours
from mirrorcore.pipeline import prepare_frame
from mirrorcore.ply import encode_ply

if TYPE_CHECKING:
    from ..server import MirrorscanApp

METHODS = {"carve (consistent)": "carve", "TSDF fusion (mesh)": "tsdf", "Algorithm 2 as in the paper": "paper"}
BOX_COLOUR = (120, 120, 120)


class DensePanel:
    def __init__(self, app: "MirrorscanApp"):
        gui, self.app = app.server.gui, app
        self.result: tuple[np.ndarray, np.ndarray, np.ndarray | None] | None = None   # vertices, sources, faces
        self._cancel = threading.Event()
        self._running = threading.Lock()
        with gui.add_folder("Dense (static object)", expand_by_default=False):
            self.method = gui.add_dropdown("Method", tuple(METHODS), initial_value="carve (consistent)")
            self.voxel = gui.add_slider("Voxel (mm)", min=1.0, max=20.0, step=0.5, initial_value=4.0)
            self.threshold = gui.add_slider("Carving threshold (mm)", min=1.0, max=50.0, step=0.5, initial_value=4.0)
            self.frames = gui.add_slider("Frames to fuse", min=1, max=5, step=1, initial_value=1)
            self.margin = gui.add_slider("Margin around the cloud (mm)", min=0.0, max=200.0, step=5.0,
                                         initial_value=20.0)
            self.auto = gui.add_button("Box around the current cloud")
            self.low = gui.add_vector3("Box min (m)", (0.0, 0.0, 0.0), step=0.01)
            self.high = gui.add_vector3("Box max (m)", (0.0, 0.0, 0.0), step=0.01)
            self.run = gui.add_button("Run")
            self.cancel = gui.add_button("Cancel", disabled=True, color="red")
            self.progress = gui.add_progress_bar(0.0, visible=False)
            self.status = gui.add_markdown("")
        self.auto.on_click(lambda e: app.act(e.client, self.box_around_cloud))
        self.low.on_update(lambda _: self._show_box())
        self.high.on_update(lambda _: self._show_box())
        self.run.on_click(lambda e: app.act(e.client, self.start))
        self.cancel.on_click(lambda _: self._cancel.set())

    def options(self) -> DenseOptions:
        bounds = (tuple(self.low.value), tuple(self.high.value))
        has_box = all(h > lo for lo, h in zip(*bounds))
        return DenseOptions(self.voxel.value / 1000, self.margin.value / 1000, bounds if has_box else None,
                            self.threshold.value / 1000)

    def box_around_cloud(self) -> Volume:
        frame = self.app.last_frame
        if frame is None or len(frame.cloud) == 0:
            raise MirrorscanError("no cloud yet to put a box around")
        volume = Volume.around(frame.cloud.points, self.voxel.value / 1000, self.margin.value / 1000)
        low = np.array(volume.origin) - volume.voxel / 2            # origin is the first voxel's centre
        self.low.value, self.high.value = tuple(low), tuple(low + volume.voxel * np.array(volume.shape))
        return volume

    def _show_box(self) -> None:
        low, high = np.array(self.low.value), np.array(self.high.value)
        if np.all(high > low):
            self.app.server.scene.add_box("/dense/box", color=BOX_COLOUR, dimensions=tuple(high - low),
                                          position=tuple((low + high) / 2), wireframe=True)

    # ------------------------------------------------------------------ running
    def start(self) -> threading.Thread:
        """Start the chosen method on a worker thread (one at a time); returns the thread."""
        depths = self.app.loop.recent_depths()
        if depths is None:
            raise MirrorscanError("no frame yet")
        if not self._running.acquire(blocking=False):
            raise MirrorscanError("a dense reconstruction is already running; cancel it first")
        self._cancel.clear()
        thread = threading.Thread(target=self._work, args=(depths[-int(self.frames.value):],), daemon=True)
        thread.start()
        return thread

    def _work(self, depths: np.ndarray) -> None:
        method, snapshot = METHODS[self.method.value], self.app.state.current
        self.run.disabled, self.cancel.disabled = True, False
        self.progress.visible, self.progress.value = True, 0.0
        try:
            prepared = [prepare_frame(snapshot.rig, d, snapshot.background, snapshot.session.selection) for d in depths]
            options = self.options()
            volume = dense_volume(snapshot.rig, *prepared[-1], options)   # refuses boxes of too many voxels
            result = reconstruct_dense(snapshot.rig, np.stack([p[0] for p in prepared]),
                                       np.stack([p[1] for p in prepared]), volume, method, options,
                                       lambda f: setattr(self.progress, "value", 100.0 * f), self._cancel)
            self._show(result, volume)
        except Cancelled:
            self.status.content = "cancelled"
        except MirrorscanError as exc:
            self.status.content = f"not done: {exc}"
        finally:
            self.progress.visible = False
            self.run.disabled, self.cancel.disabled = False, True
            self._running.release()

    def _show(self, result, volume: Volume) -> None:
        """Draw the result beside the live cloud (shifted along +x by the box's width and 20 cm)."""
        shift = np.array([volume.voxel * volume.shape[0] + 0.2, 0.0, 0.0])
        if isinstance(result, CarveResult):
            points, sources = result.surface_points()
            self.result = (points, sources, None)
            self.app.server.scene.remove_by_name("/dense/mesh")
            self.app.server.scene.add_point_cloud("/dense/points", points + shift, source_colours(sources),
                                                  point_size=volume.voxel, precision="float32")
            self.status.content = f"{result.method}: {len(points):,} surface voxels of {volume.voxel * 1e3:.1f} mm"
            return
        mesh = result.mesh()
        self.result = (mesh.vertices, mesh.sources, mesh.faces)
        coloured = trimesh.Trimesh(mesh.vertices + shift, mesh.faces, vertex_colors=source_colours(mesh.sources),
                                   process=False)
        self.app.server.scene.remove_by_name("/dense/points")
        self.app.server.scene.add_mesh_trimesh("/dense/mesh", coloured)
        self.status.content = f"tsdf: mesh of {len(mesh.vertices):,} vertices, {len(mesh.faces):,} faces"

    def method_name(self) -> str:
        return METHODS[self.method.value]

    def export_bytes(self) -> bytes | None:
        """The last result as PLY (points, or a mesh with faces), or None."""
        if self.result is None:
            return None
        vertices, sources, faces = self.result
        return encode_ply(vertices, sources, faces)
