"""Step 4, "Dense": carve (the paper's Algorithm 2, or the consistent carving) or fuse (TSDF) the
recent frames of a static object inside a box (around the live cloud and following it until a corner
is typed in, shown in 3D and in the fields), with a progress bar and a cancel button. The result is
shared by every tab, drawn in its own colour and layer with a label (a carving shaded by its
normals, a fusion's mesh lit and closed where the views saw; hidden while another source plays),
framed the first time only, and exported under a new name each time."""

from __future__ import annotations

import threading

import numpy as np

from mirrorcore.dense import DenseOptions
from mirrorcore.dense.volume import Volume
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.ply import encode_ply

from ..context import TabContext
from ..events import DenseChanged, FrameReady, JobProgress, LoopChanged, SessionChanged
from ..exports import export_ply
from ..jobs import DENSE
from ..markup import markdown
from ..wording.jobs import dense as dense_message

TITLE = "Dense"
METHODS = {
    "carve (consistent)": "carve",
    "TSDF fusion (mesh)": "tsdf",
    "Algorithm 2 as in the paper": "paper",
}


class DensePanel:
    """Step 4, "Dense": carve or fuse the object, in one tab (see the module docstring).

    Parameters
    ----------
    tab : TabContext
        The tab it is built in.
    """
    TITLE = TITLE

    def __init__(self, tab: TabContext):
        gui, self.tab, self.services = tab.gui, tab, tab.services
        # the fields' callbacks run on viser's threads, two at once when both move
        self._box_lock = threading.Lock()
        # the box follows the cloud until the technician edits its corners
        self._follow = True
        # ... and is put around the next frame's cloud (its calibration changed)
        self._refit = True
        # the result hidden by this tab while another source plays
        self._hidden_elsewhere = False
        # this tab ran the job: its result is framed when it comes, the first time only (a view
        # the technician turned is kept; Look at the dense result frames it again)
        self._look = False
        self._framed = False
        self.method = gui.add_dropdown("Method", tuple(METHODS), initial_value="carve (consistent)")
        self.voxel = gui.add_slider("Voxel (mm)", min=1.0, max=20.0, step=0.5, initial_value=4.0)
        self.threshold = gui.add_slider(
            "Carving threshold (mm)", min=1.0, max=50.0, step=0.5, initial_value=4.0
        )
        self.frames = gui.add_slider(
            "Frames to fuse", min=1, max=5, step=1, initial_value=1, disabled=True
        )
        self.run = gui.add_button("Run", color="blue")
        self.cancel = gui.add_button("Cancel", disabled=True, color="red")
        self.progress = gui.add_progress_bar(0.0, visible=False)
        self.status = gui.add_markdown("")
        # in view at 1024x600
        self.export = gui.add_button("Export the dense result as PLY", disabled=True)
        self.show = gui.add_checkbox("Show the dense result", initial_value=True)
        self.look = gui.add_button("Look at the dense result", disabled=True)
        self.beside = gui.add_checkbox(
            "Beside the live cloud",
            initial_value=True,
            hint="unticked: in place, over the live cloud",
        )
        # not over the scene of a
        self.show_box = gui.add_checkbox(
            "Show the box in 3D",
            initial_value=False,
            hint="ticked by Run, a corner typed or Box around the current cloud",
        )
        with gui.add_folder("Box (m, camera frame)", expand_by_default=False):
            self.margin = gui.add_slider(
                "Margin around the cloud (mm)", min=0.0, max=200.0, step=5.0, initial_value=20.0
            )
            self.auto = gui.add_button("Box around the current cloud")
            self.low = gui.add_vector3("Box min", (0.0, 0.0, 0.0), step=0.01)
            self.high = gui.add_vector3("Box max", (0.0, 0.0, 0.0), step=0.01)
        act = tab.act
        self.method.on_update(lambda _: self._method_options())
        self.auto.on_click(lambda _: act(self.follow_cloud))
        self.low.on_update(self._box_edited)
        self.high.on_update(self._box_edited)
        self.run.on_click(lambda _: act(self.start))
        self.cancel.on_click(lambda _: self.services.jobs.cancel(DENSE))
        self.show.on_update(lambda _: self._layer())
        self.beside.on_update(lambda _: self._layer())
        self.show_box.on_update(lambda _: self._show_box())
        self.export.on_click(lambda _: act(self.export_result))
        self.look.on_click(lambda _: act(self.look_at_result))
        self._unsubscribe = [
            self.services.bus.subscribe(JobProgress, self._on_job),
            self.services.bus.subscribe(DenseChanged, self._on_result),
            self.services.bus.subscribe(FrameReady, self._around_frame),
            self.services.bus.subscribe(SessionChanged, self._session_changed),
            self.services.bus.subscribe(LoopChanged, self._source_changed),
        ]
        if self.services.jobs.dense_result is not None:
            self._on_result(DenseChanged(self.services.jobs.dense_result))

    def detach(self) -> None:
        """Stop listening to the app (the tab closed)."""
        for unsubscribe in self._unsubscribe:
            unsubscribe()

    def _around_frame(self, event: FrameReady) -> None:
        """While the box follows the cloud, put it around the cloud at the right frames.

        Around the first frame's cloud, and around the next one after the calibration changed (the
        mirrors' points come into place: the box shrinks to the object).
        """
        if self._follow and self._refit and len(event.frame.cloud):
            self._refit = False
            self.box_around_cloud()

    def _session_changed(self, event: SessionChanged) -> None:
        """Fit the box to the next frame's cloud again, while the box follows the cloud."""
        self._refit = self._follow

    def _source_changed(self, event: LoopChanged) -> None:
        """Hide a dense result while another source than its own plays, and show it again after.

        Its own source is the one whose frames it was made of; the hiding is said under Run.
        """
        result = self.services.jobs.dense_result
        if result is None:
            return
        elsewhere = event.source.name != result.source
        if elsewhere and self.show.value:
            self._hidden_elsewhere, self.show.value = True, False
            self.status.content = markdown(
                f"{dense_message(result).headline}, of the frames of {result.source}: "
                f"hidden while {event.source.name} plays (Show the dense result "
                "shows it)"
            )
        elif not elsewhere and self._hidden_elsewhere:
            self._hidden_elsewhere, self.show.value = False, True
            self.status.content = dense_message(result).markdown()

    def _box_edited(self, event) -> None:
        """A corner typed in by the technician.

        The box stays where it is put from now on, and is shown.
        """
        if event.client is not None:
            self._follow = False
            self.show_box.value = True
        self._show_box()

    def follow_cloud(self) -> Volume:
        """'Box around the current cloud': put the box around the live cloud; it follows it again.

        The box is shown.

        Returns
        -------
        Volume
            The box.
        """
        self._follow = True
        self.show_box.value = True
        return self.box_around_cloud()

    def _method_options(self) -> None:
        """Offer what the chosen method uses.

        The carving threshold to carving, several frames to the fusion.
        """
        fuse = METHODS[self.method.value] == "tsdf"
        self.threshold.disabled, self.frames.disabled = fuse, not fuse

    def _layer(self) -> None:
        """Show the dense result as the Show and Beside boxes say."""
        if self.show.value:
            self._hidden_elsewhere = False
        self.tab.dense_visible, self.tab.dense_beside = (
            bool(self.show.value),
            bool(self.beside.value),
        )
        self.tab.show_dense(self.services.jobs.dense_result)

    def _box(self) -> tuple[np.ndarray, np.ndarray]:
        """The box's corners as the fields hold them, metres."""
        return np.array(self.low.value, float), np.array(self.high.value, float)

    def options(self) -> DenseOptions:
        """The dense options as the fields hold them.

        The voxel, margin and threshold are typed in mm; the box is used only when `high` is above
        `low` on every axis.

        Returns
        -------
        DenseOptions
            Metres.
        """
        low, high = self._box()
        bounds = (tuple(low), tuple(high)) if np.all(high > low) else None
        return DenseOptions(
            self.voxel.value / 1000, self.margin.value / 1000, bounds, self.threshold.value / 1000
        )

    def box_around_cloud(self) -> Volume:
        """Put the box around the live cloud (grown by the margin), in the fields and in 3D."""
        frame = self.services.last_frame
        if frame is None or len(frame.cloud) == 0:
            raise MirrorscanError("no cloud yet to put a box around")
        volume = Volume.around(
            frame.cloud.points, self.voxel.value / 1000, self.margin.value / 1000
        )
        # origin is the first voxel's centre
        low = np.array(volume.origin) - volume.voxel / 2
        self.low.value, self.high.value = (
            tuple(low),
            tuple(low + volume.voxel * np.array(volume.shape)),
        )
        return volume

    def _show_box(self) -> None:
        """Draw the box the fields hold now, once Dense is used (show_box).

        One callback at a time: the last one draws both fields' last values. Not drawn over the
        scene of one who never uses Dense.
        """
        with self._box_lock:
            low, high = self._box() if self.show_box.value else (None, None)
            self.tab.scene.show_box(low, high)

    def start(self) -> None:
        """Run the chosen method on the shared worker (one run at a time) in the box shown.

        The box is around the current cloud while it follows the cloud (or is empty), as the
        technician put it otherwise; it is shown from now on.
        """
        self.show_box.value = True
        if self._follow or not np.all(self._box()[1] > self._box()[0]):
            self.box_around_cloud()
        self._show_box()
        method = METHODS[self.method.value]
        # before the start: a quick result may come before it returns
        self._look = True
        try:
            self.services.jobs.start_dense(
                method, self.options(), int(self.frames.value) if method == "tsdf" else 1
            )
        except MirrorscanError:
            self._look = False
            raise

    def _on_job(self, event: JobProgress) -> None:
        """Follow the dense job: buttons, progress bar and status."""
        if event.job != DENSE:
            return
        running = event.fraction is not None
        self.run.disabled, self.cancel.disabled = running, not running
        self.progress.visible = running
        if running:
            self.progress.value = event.percent
        self.status.content = event.status

    def _on_result(self, event: DenseChanged) -> None:
        """Show a dense result: its box, its message, and the view on it in the tab that ran it."""
        result = event.result
        self.export.disabled = self.look.disabled = result is None
        if result is not None:
            self.low.value, self.high.value = tuple(result.low), tuple(result.high)
            self.status.content = dense_message(result).markdown()
            # the tab that ran it sees its first result; later ones keep the view it has
            if (self._look and not self._framed and self.show.value
                    and self.tab.state.view == "3d"):
                self.tab.look_at_dense(result)
                self._framed = True
            self._look = False

    def look_at_result(self) -> None:
        """'Look at the dense result': show it and frame it with the object in this tab's view."""
        result = self.services.jobs.dense_result
        if result is None:
            raise MirrorscanError("no dense result yet: Run one first")
        self.show.value = True
        if self.tab.state.view != "3d":
            self.tab.look("3d")
        self.tab.look_at_dense(result)
        self._framed = True

    def export_result(self) -> None:
        """Export the last dense result as PLY, under a new name.

        Carved voxels, or the fused mesh with its faces; in the result's colours where it has
        them.
        """
        result = self.services.jobs.dense_result
        if result is None:
            raise MirrorscanError("no dense result yet: Run one first")
        data = encode_ply(result.vertices, result.sources, result.faces, result.colours)
        root = self.services.editor.session.root if self.services.editor.autosave else None
        saved = export_ply(root, f"dense-{result.method}", data, self.tab.client)
        self.status.content = markdown(
            f"{dense_message(result).headline}; "
            + (f"saved as `{saved}`" if saved else "downloaded")
        )
