"""The side panel: what the live view shows (frame rate, points per source with the colour legend, the depth frame
with its overlays) and its controls (pause, step, point size)."""
from __future__ import annotations

import time

import numpy as np
import viser

from mirrorcore.palette import source_color

from .live import LiveFrame, LiveLoop
from .overlays import colorize_depth, draw_mask, draw_mirrors
from .view import SceneView

DEPTH_VIEW_HZ = 8.0     # the depth image is re-sent at most this often
STATS_HZ = 4.0


def legend_html(counts: dict[str, int]) -> str:
    """One line per source: a swatch in the source colour, its name and its point count."""
    rows = []
    for j, (name, count) in enumerate(counts.items()):
        r, g, b = (int(c) for c in source_color(j))
        rows.append(f'<div style="font-size:0.85em"><span style="display:inline-block;width:0.9em;height:0.9em;'
                    f'background:rgb({r},{g},{b});margin-right:0.4em;border-radius:2px"></span>'
                    f'{name}: <b>{count:,}</b> points</div>')
    return "".join(rows)


class LivePanel:
    """Builds the GUI folders and refreshes them from live frames (called on the loop's thread)."""

    def __init__(self, server: viser.ViserServer, view: SceneView, loop: LiveLoop, source_name_: str):
        gui = server.gui
        self.view, self.loop = view, loop
        gui.add_markdown(f"**mirrorscan** · source: {source_name_}")
        with gui.add_folder("Live"):
            self.rate = gui.add_markdown("starting…")
            self.legend = gui.add_html("")
            self.pause = gui.add_checkbox("Pause", initial_value=False)
            self.step = gui.add_button("Step one frame", disabled=True)
            self.size = gui.add_slider("Point size (mm)", min=1.0, max=20.0, step=0.5, initial_value=6.0)
        with gui.add_folder("Depth frame"):
            self.range = gui.add_markdown("")
            self.depth = gui.add_image(np.zeros((48, 64, 3), np.uint8), label="depth, object and mirrors",
                                       format="jpeg")
        self.pause.on_update(lambda _: self._on_pause())
        self.step.on_click(lambda _: self.loop.step())
        self.size.on_update(lambda _: self.view.set_point_size(self.size.value / 1000))
        self._last_depth = self._last_stats = 0.0

    def _on_pause(self) -> None:
        self.loop.pause(self.pause.value)
        self.step.disabled = not self.pause.value

    def show(self, frame: LiveFrame) -> None:
        """Refresh the cloud every frame, the depth image and the figures at their own lower rates."""
        n_sources = len(frame.snapshot.rig.mirrors) + 1
        self.view.show_cloud(frame.cloud, n_sources)
        now = time.perf_counter()
        if now - self._last_depth >= 1 / DEPTH_VIEW_HZ or self.loop.paused:
            self._last_depth = now
            self.depth.image = self.depth_image(frame)
        if now - self._last_stats >= 1 / STATS_HZ or self.loop.paused:
            self._last_stats = now
            self.rate.content = (f"frame {frame.index} · **{self.loop.rate.fps:.1f} fps** · "
                                 f"processing {frame.process_ms:.1f} ms")
            self.legend.content = legend_html(frame.cloud.counts(n_sources - 1))

    def depth_image(self, frame: LiveFrame) -> np.ndarray:
        """The colourised depth frame with the object mask, boundaries and markers; its range in the panel."""
        valid = frame.depth[frame.depth > 0]
        near, far = (np.percentile(valid, [1, 99]) if len(valid) else (0.5, 4.5))
        self.range.content = f"depth {near:.2f} m (red) to {far:.2f} m (blue); black: no reading"
        rgb = colorize_depth(frame.depth, near, far)
        draw_mask(rgb, frame.mask)
        return draw_mirrors(rgb, frame.snapshot.session.mirrors)
