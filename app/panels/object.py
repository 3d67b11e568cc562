"""Step 2, "Object": which pixels are the object: capture the background (median of N frames, with
progress), the depth range, edge-aware smoothing, and a region of interest drawn on the depth frame;
with the simulated rig, take the object out of the scene to capture."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.polygon import MIN_VERTICES, validate_polygon
from mirrorcore.base.palette import MAX_ORDER
from mirrorcore.depth.selection import object_mask
from mirrorcore.sources import SimulatedSource

from ..context import TabContext
from ..events import JobProgress, SessionChanged
from ..jobs import BACKGROUND
from ..markup import markdown
from ..wording import Message
from ..wording.jobs import say
from .mirrors.clicks import nearest

TITLE = "Object"
# pixels: an object this large in the last frame is checked against a new background...
SEEN_OBJECT = 500
# ...which is used only on confirmation when it would hide more than this share of it
HIDDEN_SHARE = 0.5


class ObjectPanel:
    """Step 2, "Object": which pixels are the object, in one tab (see the module docstring).

    Parameters
    ----------
    tab : TabContext
        The tab it is built in.
    """
    TITLE = TITLE

    def __init__(self, tab: TabContext):
        gui, self.tab, self.services = tab.gui, tab, tab.services
        selection = self.services.snapshot.session.selection
        self.status = gui.add_markdown("")
        # the question asked before a background that hides the object is used,
        self.confirm = None
        self.pending_background = None  # and that background
        if isinstance(self.services.source, SimulatedSource):
            self.object_in_scene = gui.add_checkbox(
                "Simulated object in the scene", initial_value=True
            )
            self.object_in_scene.on_update(
                lambda _: setattr(
                    self.services.source, "objects_in_view", bool(self.object_in_scene.value)
                )
            )
        self.frames = gui.add_slider("Background frames", min=1, max=60, step=1, initial_value=15)
        self.capture = gui.add_button("Capture background (object out of view)")
        self.cancel = gui.add_button("Cancel capture", visible=False)
        self.progress = gui.add_progress_bar(0.0, visible=False)
        self.range = gui.add_multi_slider(
            "Depth range (m)",
            min=0.0,
            max=8.0,
            step=0.05,
            initial_value=(selection.depth_min, selection.depth_max),
        )
        self.smooth = gui.add_checkbox("Smooth depth (edge-aware)", initial_value=selection.smooth)
        self.bounces = gui.add_slider(
            "Views through up to N mirrors",
            min=1,
            max=MAX_ORDER,
            step=1,
            initial_value=self.services.snapshot.session.bounces,
        )
        self.draw = gui.add_button("Draw a region of interest")
        self.close = gui.add_button("Close the region", visible=False)
        self.clear = gui.add_button("Clear the region of interest")
        act = tab.act
        self.capture.on_click(lambda _: act(self._capture))
        self.cancel.on_click(lambda _: self.services.jobs.cancel(BACKGROUND))
        self.range.on_update(lambda e: e.client is not None and act(self._set_range))
        self.smooth.on_update(
            lambda e: e.client is not None and act(lambda: self._set(smooth=self.smooth.value))
        )
        self.bounces.on_update(
            lambda e: (
                e.client is not None
                and act(lambda: self._edit(lambda: self.services.editor.set_bounces(
                    int(self.bounces.value))))
            )
        )
        self.draw.on_click(lambda _: act(self._start_region))
        self.close.on_click(lambda _: act(self._close_region))
        self.clear.on_click(lambda _: act(self._clear_region))
        tab.on_click("region", self._region_click)
        tab.on_state(lambda _: self.refresh())
        self._unsubscribe = [
            self.services.bus.subscribe(JobProgress, self._on_job),
            self.services.bus.subscribe(SessionChanged, lambda _: self.refresh()),
        ]
        self.refresh()

    def detach(self) -> None:
        """Stop listening to the app (the tab closed)."""
        for unsubscribe in self._unsubscribe:
            unsubscribe()

    def refresh(self) -> None:
        """Show the selection as it is: background, depth range, region and bounces."""
        snapshot, state = self.services.snapshot, self.tab.state
        selection = snapshot.session.selection
        source = (
            ("captured" if self.services.background_captured else "from the source")
            if snapshot.background is not None
            else "none: the object is every pixel in the depth range"
        )
        roi = selection.roi
        region = f"{len(roi)} corners" if roi else "the whole image"
        if state.region_draft:
            region += f" (drawing: {len(state.region_draft)} corners)"
        # the numbers, which the slider does not show
        self.status.content = markdown(
            f"Background: {source}. Depth range: {selection.depth_min:.2f} to "
            f"{selection.depth_max:.2f} m. Region of interest: {region}."
        )
        self.range.value = (selection.depth_min, selection.depth_max)
        self.smooth.value = selection.smooth
        self.bounces.value = snapshot.session.bounces
        drawing = state.mode == "region"
        self.close.visible = drawing
        self.close.disabled = len(state.region_draft) < MIN_VERTICES

    def _edit(self, change) -> None:
        """Make a change; refused, the controls show the session's selection again."""
        try:
            change()
        except MirrorscanError:
            self.refresh()
            raise

    def _set(self, **changes) -> None:
        """Change fields of the session's object selection (what the session reader refuses is
        refused by the editor, naming the field)."""
        self._edit(lambda: self.services.editor.set_selection(
            replace(self.services.snapshot.session.selection, **changes)))

    def _set_range(self) -> None:
        """Set the depth range from the slider; at least 5 cm wide."""
        self._edit(self._check_range)
        low, high = self.range.value
        self._set(depth_min=float(low), depth_max=float(high))

    def _check_range(self) -> None:
        """Refuse a depth range that is not two numbers at least 5 cm apart (a message of another
        client may hold anything)."""
        value = self.range.value
        numbers = (isinstance(value, (list, tuple)) and len(value) == 2
                   and all(isinstance(x, (int, float)) for x in value))
        if not numbers or value[1] - value[0] < 0.05:
            raise MirrorscanError("the depth range must be at least 5 cm wide")

    # ------------------------------------------------------------------ region of interest
    def _start_region(self) -> None:
        """Start drawing a region of interest on the depth frame."""
        state = self.tab.state
        state.mode, state.region_draft = "region", ()
        self.tab.look("depth")
        self.tab.changed()

    def _region_click(self, u: float, v: float) -> None:
        """A click in Region mode: close the draft at its first corner, else add a corner."""
        state = self.tab.state
        if len(state.region_draft) >= 3 and nearest(state.region_draft[:1], (u, v)) == 0:
            self._close_region()
            return
        state.region_draft = state.region_draft + ((round(u, 2), round(v, 2)),)
        self.tab.changed()

    def _close_region(self) -> None:
        """Make the draft the region of interest."""
        state = self.tab.state
        roi = validate_polygon(
            state.region_draft, self.services.snapshot.session.camera.shape, "region of interest"
        )
        state.region_draft, state.mode = (), "inspect"
        self._set(roi=tuple(map(tuple, roi.tolist())))
        self.tab.changed()

    def _clear_region(self) -> None:
        """Drop the draft and the region of interest."""
        state = self.tab.state
        state.region_draft = ()
        if state.mode == "region":
            state.mode = "inspect"
        if self.services.snapshot.session.selection.roi is not None:
            self._set(roi=None)
        self.tab.changed()

    # ------------------------------------------------------------------ background
    def _capture(self) -> None:
        """Capture the background over the frames asked for."""
        self.services.jobs.capture_background(int(self.frames.value), self._captured)

    def _captured(self, depth: np.ndarray) -> bool:
        """Use a captured background, (H, W) metres, at once or once the user confirms.

        When it would hide most of the object seen in the last frame (the object was in view while
        it was captured), it is used only once the user confirms. Returns whether it waits for that.
        """
        frame, snapshot = self.services.last_frame, self.services.snapshot
        seen = (
            0 if frame is None or snapshot.background is None else int(np.count_nonzero(frame.mask))
        )
        if seen < SEEN_OBJECT:
            self.services.set_background(depth)
            return False
        left = int(
            np.count_nonzero(
                object_mask(snapshot.rig.intrinsics, frame.depth, depth, snapshot.session.selection)
            )
        )
        if left >= (1 - HIDDEN_SHARE) * seen:
            self.services.set_background(depth)
            return False
        self.pending_background = depth
        self.confirm = self.tab.ask(
            "Use this background?",
            f"It would hide {1 - left / seen:.0%} of the object seen now ({seen:,} -> "
            f"{left:,} pixels): was the object in view while it was captured? Take it out and "
            "capture again. (If the "
            "scene itself changed, the camera moved say, use it.)",
            "Use it anyway",
            self._use_captured,
            "Keep the background as it was",
            self._keep_background,
        )
        return True

    def _use_captured(self) -> None:
        """The user confirmed: use the pending captured background."""
        depth, self.pending_background = self.pending_background, None
        self.services.set_background(depth)
        self.status.content = "Background: captured, used on confirmation."

    def _keep_background(self) -> None:
        """Keep the background as it was: the capture is not used."""
        self.pending_background = None
        self.status.content = "Background: kept as it was (the capture was not used)."

    def _on_job(self, event: JobProgress) -> None:
        """Follow the background capture: buttons, progress bar and status."""
        if event.job != BACKGROUND:
            return
        running = event.fraction is not None
        self.progress.visible = self.cancel.visible = running
        self.capture.disabled = running
        if running:
            self.progress.value = event.percent
        else:
            said = say(event.result)[0]
            self.status.content = Message(f"Background: {said.headline}.", said.details).markdown()
