"""The "Object" folder: which pixels are the object: capture the background (median of N frames, with progress),
the depth range, the region of interest; with the simulated rig, take the object out of the scene to capture."""
from __future__ import annotations

import threading
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from mirrorcore.depthops import median_depth
from mirrorcore.errors import MirrorscanError
from mirrorcore.geometry.polygon import validate_polygon
from mirrorcore.session import BACKGROUND_FILE
from mirrorcore.sources import SimulatedSource

if TYPE_CHECKING:
    from ..server import MirrorscanApp



class SelectionPanel:
    def __init__(self, app: "MirrorscanApp"):
        gui, self.app = app.server.gui, app
        self.roi_draft: tuple[tuple[float, float], ...] = ()
        self._capture = threading.Lock()
        selection = app.state.current.session.selection
        with gui.add_folder("Object"):
            if isinstance(app.source, SimulatedSource):
                self.object_in_scene = gui.add_checkbox("Simulated object in the scene", initial_value=True)
                self.object_in_scene.on_update(
                    lambda _: setattr(app.source, "objects_in_view", bool(self.object_in_scene.value)))
            self.frames = gui.add_slider("Background frames", min=1, max=60, step=1, initial_value=15)
            self.capture = gui.add_button("Capture background (object out of view)")
            self.progress = gui.add_progress_bar(0.0, visible=False)
            self.background = gui.add_markdown("")
            self.range = gui.add_multi_slider("Depth range (m)", min=0.0, max=8.0, step=0.05,
                                              initial_value=(selection.depth_min, selection.depth_max))
            self.smooth = gui.add_checkbox("Smooth depth (edge-aware)", initial_value=selection.smooth)
            self.clear_roi = gui.add_button("Clear region of interest")
        self.capture.on_click(lambda e: app.act(e.client, lambda: self.capture_background(int(self.frames.value))))
        self.range.on_update(lambda e: app.act(e.client, self._set_range))
        self.smooth.on_update(lambda e: app.act(e.client, lambda: self._set(smooth=bool(self.smooth.value))))
        self.clear_roi.on_click(lambda e: app.act(e.client, self._clear_roi))
        self.refresh()

    def refresh(self) -> None:
        snapshot = self.app.state.current
        source = ("captured" if snapshot.session.background else "from the source") \
            if snapshot.background is not None else "none: the object is every pixel in the depth range"
        roi = snapshot.session.selection.roi
        self.background.content = (f"Background: {source}. Region of interest: "
                                    f"{'%d corners' % len(roi) if roi else 'whole image'}"
                                    + (f" (drawing: {len(self.roi_draft)} corners)" if self.roi_draft else "") + ".")

    def _set(self, **changes) -> None:
        self.app.editor.set_selection(replace(self.app.state.current.session.selection, **changes))

    def _set_range(self) -> None:
        low, high = self.range.value
        if high - low < 0.05:
            raise MirrorscanError("the depth range must be at least 5 cm wide")
        self._set(depth_min=float(low), depth_max=float(high))

    # ------------------------------------------------------------------ region of interest
    def add_roi_vertex(self, u: float, v: float) -> None:
        self.roi_draft = self.roi_draft + ((round(u, 2), round(v, 2)),)
        self.refresh()
        self.app.redraw_screen()

    def close_roi(self) -> None:
        roi = validate_polygon(self.roi_draft, self.app.editor.session.camera.shape, "region of interest")
        self.roi_draft = ()
        self._set(roi=tuple(map(tuple, roi.tolist())))

    def _clear_roi(self) -> None:
        self.roi_draft = ()
        self._set(roi=None)

    # ------------------------------------------------------------------ background
    def capture_background(self, n_frames: int) -> None:
        """Median of the next n_frames live frames, saved as the session's background.png (when it has a folder)."""
        if not self._capture.acquire(blocking=False):
            raise MirrorscanError("a background capture is already running")
        try:
            self.progress.visible, self.progress.value = True, 0.0
            frames = self.app.loop.collect(n_frames, lambda k: setattr(self.progress, "value", 100.0 * k / n_frames))
            self.app.set_background(median_depth(np.stack(frames)), BACKGROUND_FILE)
        finally:
            self.progress.visible = False
            self._capture.release()
            self.refresh()
