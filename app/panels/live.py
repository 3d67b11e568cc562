"""The "Live" folder: frame rate, points per source with the colour legend, pause / step, point size, and the two
camera views (the 3D scene, the depth frame)."""
from __future__ import annotations

import time
from typing import TYPE_CHECKING

from mirrorcore.palette import source_colour

from ..live import LiveFrame

if TYPE_CHECKING:
    from ..server import MirrorscanApp

STATS_HZ = 4.0


def legend_html(counts: dict[str, int]) -> str:
    """One line per source: a swatch in the source colour, its name and its point count."""
    rows = []
    for j, (name, count) in enumerate(counts.items()):
        r, g, b = (int(c) for c in source_colour(j))
        rows.append(f'<div style="font-size:0.85em"><span style="display:inline-block;width:0.9em;height:0.9em;'
                    f'background:rgb({r},{g},{b});margin-right:0.4em;border-radius:2px"></span>'
                    f'{name}: <b>{count:,}</b> points</div>')
    return "".join(rows)


class LivePanel:
    def __init__(self, app: "MirrorscanApp"):
        gui, self.app = app.server.gui, app
        self.title = gui.add_markdown("")
        with gui.add_folder("Live"):
            self.rate = gui.add_markdown("starting…")
            self.legend = gui.add_html("")
            self.depth_range = gui.add_markdown("")
            self.pixel = gui.add_markdown("Click the depth frame to read a pixel.")
            with gui.add_folder("View", expand_by_default=True):
                self.look_3d = gui.add_button("Look at the 3D scene")
                self.look_depth = gui.add_button("Look at the depth frame")
            self.pause = gui.add_checkbox("Pause", initial_value=False)
            self.seek = gui.add_slider("Frame", min=0, max=1, step=1, initial_value=0, visible=False)
            self.step = gui.add_button("Step one frame", disabled=True)
            self.size = gui.add_slider("Point size (mm)", min=1.0, max=20.0, step=0.5, initial_value=6.0)
        self.look_3d.on_click(lambda e: app.view.look_from_home(e.client))
        self.look_depth.on_click(lambda e: app.screen.look_at(e.client))
        self.pause.on_update(lambda _: self._on_pause())
        self.step.on_click(lambda _: app.loop.step())
        self.size.on_update(lambda _: app.view.set_point_size(self.size.value / 1000))
        self.seek.on_update(lambda e: app.loop.seek(self.seek.value) if e.client is not None else None)
        self._last_stats = 0.0
        self.follow_source(app.source)

    def follow_source(self, source) -> None:
        """Name the source; show the frame slider for a recording (seekable), hide it for a live camera."""
        self.title.content = f"**mirrorscan** · source: {source.name}"
        if source.frame_count:
            self.seek.max = max(source.frame_count - 1, 1)
        self.seek.visible = bool(source.frame_count)

    def _on_pause(self) -> None:
        self.app.loop.pause(self.pause.value)
        self.step.disabled = not self.pause.value

    def show(self, frame: LiveFrame) -> None:
        """Refresh the figures at STATS_HZ (every frame while paused)."""
        now = time.perf_counter()
        if now - self._last_stats < 1 / STATS_HZ and not self.app.loop.paused:
            return
        self._last_stats = now
        self.rate.content = (f"frame {frame.index} · **{self.app.loop.rate.fps:.1f} fps** · "
                             f"processing {frame.process_ms:.1f} ms")
        count = self.app.source.frame_count
        if count:
            self.seek.value = frame.index % count
        self.legend.content = legend_html(frame.cloud.counts(len(frame.snapshot.rig.mirrors)))

    def show_pixel(self, u: float, v: float, depth: float) -> None:
        reading = f"{depth:.3f} m" if depth > 0 else "no reading"
        self.pixel.content = f"pixel ({u:.1f}, {v:.1f}): {reading}"
