"""The "Mirrors" folder: add, rename and remove mirrors; what a click on the depth frame does (inspect, place markers,
draw the boundary, draw the region of interest); undo; fit the planes and report how well they fit."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import viser

from mirrorcore.calibration import calibrate_session
from mirrorcore.errors import MirrorscanError

if TYPE_CHECKING:
    from ..server import MirrorscanApp

MODES = ("inspect", "markers", "boundary", "region of interest")
NO_MIRROR = "(no mirror)"


class MirrorsPanel:
    def __init__(self, app: "MirrorscanApp"):
        gui, self.app = app.server.gui, app
        self.selected_vertex: tuple[int, int] | None = None   # (mirror, vertex) picked for moving or deleting
        with gui.add_folder("Mirrors"):
            self.add = gui.add_button("Add a mirror")
            self.mirror = gui.add_dropdown("Mirror", (NO_MIRROR,))
            with gui.add_folder("Rename or remove", expand_by_default=False):
                self.name = gui.add_text("Name", "")
                self.rename = gui.add_button("Rename")
                self.remove = gui.add_button("Remove", color="red")
            self.mode = gui.add_dropdown("Click to", MODES, initial_value="inspect")
            self.help = gui.add_markdown("")
            self.undo = gui.add_button("Undo")
            self.clear_markers = gui.add_button("Clear markers")
            self.close = gui.add_button("Close boundary")
            self.delete_vertex = gui.add_button("Delete picked vertex")
            self.clear_boundary = gui.add_button("Clear boundary")
            self.fit = gui.add_button("Fit plane")
            self.fit_all = gui.add_button("Fit all planes")
            self.result = gui.add_markdown("")
        self._wire()
        self.refresh()

    def _wire(self) -> None:
        act = self.app.act
        self.mirror.on_update(lambda _: self.refresh())
        self.mode.on_update(lambda _: self._on_mode())
        self.add.on_click(lambda e: act(e.client, self._add))
        self.rename.on_click(lambda e: act(e.client, lambda: self.app.editor.rename_mirror(self.index(), self.name.value)))
        self.remove.on_click(lambda e: act(e.client, lambda: self.app.editor.remove_mirror(self.index())))
        self.undo.on_click(lambda e: act(e.client, self.app.editor.undo))
        self.clear_markers.on_click(lambda e: act(e.client, lambda: self.app.editor.clear_markers(self.index())))
        self.close.on_click(lambda e: act(e.client, self._close))
        self.delete_vertex.on_click(lambda e: act(e.client, self._delete_vertex))
        self.clear_boundary.on_click(lambda e: act(e.client, lambda: self.app.editor.clear_boundary(self.index())))
        self.fit.on_click(lambda e: act(e.client, lambda: self.fit_planes([self.index()])))
        self.fit_all.on_click(lambda e: act(e.client, lambda: self.fit_planes(range(len(self.app.editor.session.mirrors)))))

    # ------------------------------------------------------------------ selection of the mirror
    def index(self) -> int:
        """The selected mirror (0-based); MirrorscanError when there is none."""
        names = [m.name for m in self.app.editor.session.mirrors]
        if self.mirror.value not in names:
            raise MirrorscanError("add a mirror first (Mirrors > Add a mirror)")
        return names.index(self.mirror.value)

    def _add(self) -> None:
        index = self.app.editor.add_mirror()
        self.mirror.value = self.app.editor.session.mirrors[index].name

    def refresh(self) -> None:
        """Follow the session: the mirror list, the name field, what the buttons can do."""
        session = self.app.editor.session
        names = tuple(m.name for m in session.mirrors) or (NO_MIRROR,)
        if self.mirror.options != names:
            current = self.mirror.value
            self.mirror.options = names
            self.mirror.value = current if current in names else names[-1]
        has = bool(session.mirrors)
        for button in (self.rename, self.remove, self.clear_markers, self.close, self.clear_boundary, self.fit):
            button.disabled = not has
        self.fit_all.disabled = not has
        self.delete_vertex.disabled = self.selected_vertex is None
        if has and self.mirror.value in names and self.name.value != self.mirror.value:
            self.name.value = self.mirror.value
        self._on_mode()

    def _on_mode(self) -> None:
        self.help.content = {
            "inspect": "Clicks on the depth frame show the pixel and its depth.",
            "markers": "Click the centre of each marker on the selected mirror (3 or more, spread out).",
            "boundary": "Click the mirror's corners in order; click the first corner again (or *Close boundary*) "
                        "to close. On a closed boundary, click a corner to pick it, then click where it goes.",
            "region of interest": "Click the corners of the region where the object can be; *Close boundary* "
                                  "closes it (Object folder: *Clear region* removes it).",
        }[self.mode.value]

    # ------------------------------------------------------------------ clicks on the depth frame
    def handle_click(self, u: float, v: float, client: viser.ClientHandle) -> None:
        """What a click at pixel (u, v) does in the current mode; refusals become the client's notification."""
        mode = self.mode.value
        if mode == "inspect":
            self.app.show_pixel(u, v)
        elif mode == "markers":
            self.app.act(client, lambda: self.app.editor.add_marker(self.index(), (u, v)))
        elif mode == "boundary":
            self.app.act(client, lambda: self._boundary_click(u, v))
        else:
            self.app.act(client, lambda: self.app.selection_panel.add_roi_vertex(u, v))

    def _boundary_click(self, u: float, v: float) -> None:
        editor, index = self.app.editor, self.index()
        picked = editor.nearest_vertex(index, (u, v))
        if index in editor.drafts:
            if picked == 0 and len(editor.drafts[index]) >= 3:
                self._close()
            else:
                editor.add_vertex(index, (u, v))
        elif self.selected_vertex is not None and self.selected_vertex[0] == index:
            vertex, self.selected_vertex = self.selected_vertex[1], None
            editor.move_vertex(index, vertex, (u, v))
        elif picked is not None:
            self.selected_vertex = (index, picked)
            self.app.redraw_screen()
        else:
            editor.add_vertex(index, (u, v))
        self.refresh()

    def _close(self) -> None:
        if self.mode.value == "region of interest":
            self.app.selection_panel.close_roi()
        else:
            self.app.editor.close_boundary(self.index())

    def _delete_vertex(self) -> None:
        if self.selected_vertex is None:
            raise MirrorscanError("pick a vertex first: in boundary mode, click a corner of a closed boundary")
        mirror, vertex = self.selected_vertex
        self.selected_vertex = None
        self.app.editor.delete_vertex(mirror, vertex)

    # ------------------------------------------------------------------ plane fitting
    def fit_planes(self, indices) -> None:
        """Calibrate the given mirrors from their markers on the median of the recent frames; all or nothing."""
        depth = self.app.loop.recent_depths()
        if depth is None:
            raise MirrorscanError("no frame yet to calibrate from")
        session, results = calibrate_session(self.app.editor.session, depth, np.random.default_rng(0), indices)
        self.app.editor.set_planes({i: result.plane for i, result in results})
        self.result.content = "\n\n".join(f"**{session.mirrors[i].name}**: {r.summary()}" for i, r in results)
