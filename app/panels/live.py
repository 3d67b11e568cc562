"""The "Live" folder: frame rate, points per source with the colour legend, pause / step, point size, and the two
camera views (the 3D scene, the depth frame)."""
from __future__ import annotations

import time
from typing import TYPE_CHECKING

from mirrorcore.palette import source_color

from ..live import LiveFrame

if TYPE_CHECKING:
    from ..server import MirrorscanApp

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
    def __init__(self, app: "MirrorscanApp"):
        gui, self.app = app.server.gui, app
        gui.add_markdown(f"**mirrorscan** · source: {app.source.name}")
        with gui.add_folder("Live"):
            self.rate = gui.add_markdown("starting…")
            self.legend = gui.add_html("")
            self.depth_range = gui.add_markdown("")
            self.pixel = gui.add_markdown("Click the depth frame to read a pixel.")
            with gui.add_folder("View", expand_by_default=True):
                self.look_3d = gui.add_button("Look at the 3D scene")
                self.look_depth = gui.add_button("Look at the depth frame")
            self.pause = gui.add_checkbox("Pause", initial_value=False)
            self.step = gui.add_button("Step one frame", disabled=True)
            self.size = gui.add_slider("Point size (mm)", min=1.0, max=20.0, step=0.5, initial_value=6.0)
        self.look_3d.on_click(lambda e: app.view.look_from_home(e.client))
        self.look_depth.on_click(lambda e: app.screen.look_at(e.client))
        self.pause.on_update(lambda _: self._on_pause())
        self.step.on_click(lambda _: app.loop.step())
        self.size.on_update(lambda _: app.view.set_point_size(self.size.value / 1000))
        self._last_stats = 0.0

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
        self.legend.content = legend_html(frame.cloud.counts(len(frame.snapshot.rig.mirrors)))

    def show_pixel(self, u: float, v: float, depth: float) -> None:
        reading = f"{depth:.3f} m" if depth > 0 else "no reading"
        self.pixel.content = f"pixel ({u:.1f}, {v:.1f}): {reading}"
