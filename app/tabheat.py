"""How a tab colours its live cloud: in true colour or its sources' colours, or the heat map, shown
instead of the live cloud, drawn when the heat worker's map comes, of one mirror's points or every
mirror's."""
from __future__ import annotations

import threading
import time
from typing import TYPE_CHECKING

import numpy as np

from mirrorcore.base.palette import HEAT_UNCOMPARED, SOURCE_COLOURS

from .events import HeatChanged

if TYPE_CHECKING:
    from .context import Services


class TabHeat:
    """The colouring of a tab's live cloud and its heat map; mixed into `mirrorscan.tab.Tab`.

    Uses the tab's `services`, `scene`, `state`, `header`, `closed`, `lagging`, `shows_cloud`,
    `_stale` and `look_at_object`.
    """

    services: Services
    heat: bool
    true_colour: bool
    heat_of: int | None
    heat_figures: dict[int, tuple[float, float]]
    heat_frames: int
    _heat_event: HeatChanged | None
    _heat_lock: threading.Lock
    _last_heat: float

    def show_heat(self, on: bool) -> None:
        """Show the heat map of HEAT_HZ frames a second instead of the live cloud, or go back.

        The first heat map is of the last frame, at once: while paused no new frame comes. The view
        frames the object, whose rims carry the heat map's colours.

        Parameters
        ----------
        on : bool
            Show the heat map (True) or go back to the live cloud (False).
        """
        with self._heat_lock:
            self.heat, self._stale, self._last_heat = on, True, 0.0
            if not on:
                self.scene.show_heat(None, None)
                self.heat_figures, self._heat_event = {}, None
        if on:
            self._heat_now()
        self.scene.show_clouds(not on and self.state.view == "3d")
        if on and self.state.view == "3d":
            self.look_at_object()
        self.header.colours.follow()

    def colour_by(self, true_colour: bool) -> None:
        """Show the live cloud in its points' colours or in its sources', the heat map off.

        The last frame's cloud is drawn so at once: while paused no new frame comes.

        Parameters
        ----------
        true_colour : bool
            Each point's colour (a frame without colour shows its sources' instead), or its
            source's.
        """
        self.true_colour = true_colour
        if self.heat:
            self.show_heat(False)
        self._stale = True
        frame = self.services.last_frame
        if frame is not None and self.shows_cloud and not self.lagging:
            self.scene.show_cloud(frame.parts(None, true_colour), frame.mirror_ids)
            self._stale = False
        self.header.colours.follow()

    def _heat_now(self) -> None:
        """The heat map of the last frame, now (when the tab looks at the 3D scene)."""
        frame = self.services.last_frame
        if frame is not None and self.shows_cloud:
            self._last_heat = time.perf_counter()
            self.services.jobs.start_heat(frame)

    def _on_heat(self, event: HeatChanged) -> None:
        # a map whose check passed before a switch-off must not be drawn after it
        """Draw a heat map that came, unless the heat map was switched off meanwhile."""
        with self._heat_lock:
            if self.heat and not self.closed:
                self._heat_event = event
                self._draw_heat()
                self.heat_figures, self.heat_frames = event.figures, event.frames

    def heat_only(self, mirror_id: int | None) -> None:
        """Colour only this mirror's points on the heat map.

        The others' are grey and small, as the camera's, so that each strip can be told apart.

        Parameters
        ----------
        mirror_id : int or None
            The mirror; None colours every mirror's.
        """
        with self._heat_lock:
            self.heat_of = mirror_id
            if self.heat and self._heat_event is not None and not self.closed:
                self._draw_heat()

    def _draw_heat(self) -> None:
        """Draw the last heat map (under _heat_lock).

        The camera's points, those of the mirrors not chosen (heat_of) and those with nothing to
        compare with, small and grey.
        """
        event = self._heat_event
        if event.sources is None:
            self.scene.show_heat(event.points, event.colours)
            return
        mirrors = self.services.snapshot.session.mirrors
        label = next((k for k, m in enumerate(mirrors, start=1) if m.id == self.heat_of), None)
        # the mirrors' points with nothing to compare with (the camera does not see their part of
        # the object: most of a person's back and sides) are drawn as the camera's, so that the
        # points compared show in their colours
        uncompared = np.all(event.colours == HEAT_UNCOMPARED, axis=1) & (event.sources != 0)
        small = (event.sources == 0 if label is None else event.sources != label) | uncompared
        grey = (small & (event.sources != 0))[:, None]
        colours = np.where(grey, SOURCE_COLOURS[0], event.colours)
        self.scene.show_heat(event.points, colours.astype(np.uint8), small)
