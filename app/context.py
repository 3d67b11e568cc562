"""The narrow interfaces a panel works through: the app's shared services (the session editor, the
current state, the live loop's controls, the shared jobs, the event bus) and its own tab (GUI,
per-tab state, view). A panel reads and calls these and publishes events; it never reaches into
another panel or a GUI handle it does not own."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Protocol

import numpy as np
import viser

from mirrorcore.sources import DepthSource

if TYPE_CHECKING:
    from .editor import SessionEditor
    from .events import EventBus
    from .jobs import Jobs
    from .live import LiveFrame
    from .state import Snapshot

MODES = ("inspect", "markers", "boundary", "region")


class Services(Protocol):
    """What the app shares with every tab."""

    editor: "SessionEditor"
    bus: "EventBus"
    jobs: "Jobs"
    sessions_dir: Path
    start_source: DepthSource

    @property
    def snapshot(self) -> "Snapshot": ...

    @property
    def source(self) -> DepthSource: ...

    @property
    def last_frame(self) -> "LiveFrame | None": ...

    @property
    def paused(self) -> bool: ...

    def pause(self, paused: bool) -> None: ...

    def step(self) -> None: ...

    def seek(self, index: int) -> None: ...

    def fps(self) -> float: ...

    def fps_wanted(self) -> float | None: ...

    def pacing(self) -> tuple[float, str] | None: ...

    def open_session(self, session, play: bool = False) -> None: ...

    def use_source(self, source: DepthSource) -> None: ...

    def back_to_start_source(self) -> None: ...

    def set_background(self, depth: np.ndarray) -> None: ...

    @property
    def background_captured(self) -> bool: ...

    def notify(self, client: viser.ClientHandle | None, title: str, message: str,
               kind: str = "error", stay: bool = False,
               logged: bool = True) -> viser.NotificationHandle | None: ...

    def act(self, client: viser.ClientHandle | None, action: Callable[[], object]) -> None: ...


@dataclass(frozen=True)
class Question:
    """A question on a tab (TabContext.ask): its modal, and its two answers as the buttons give
    them."""

    modal: object
    yes: Callable[[], None]
    no: Callable[[], None]


@dataclass
class TabState:
    """What belongs to one browser tab: the click mode, the selected mirror (by id), the drafts
    being drawn (a boundary per mirror id, the region of interest), the picked corner or marker, the
    markers a proposal flags and the mirrors it is for, and the view ('3d' or 'depth')."""

    mode: str = "inspect"
    mirror_id: int | None = None
    drafts: dict[int, tuple[tuple[float, float], ...]] = field(default_factory=dict)
    region_draft: tuple[tuple[float, float], ...] = ()
    picked_corner: int | None = None
    picked_marker: int | None = None
    moving_marker: bool = False
    # (mirror id, marker's pixel) crossed on the depth frame: by place, so that a marker deleted
    # before it does not move the cross on
    flagged_markers: tuple[tuple[int, tuple[float, float]], ...] = ()
    # the mirrors whose fitted plane waits for Apply or Discard
    proposal_for: tuple[str, ...] = ()
    view: str = "3d"


class TabContext(Protocol):
    """What a panel of one tab works with."""

    client: viser.ClientHandle
    services: Services
    state: TabState
    # the browser draws slower than frames come: it is sent fewer (presence.MAX_LAG_S)
    lagging: bool
    # when it last lagged, once its page was built (time.perf_counter())
    lagged_at: float

    @property
    def gui(self): ...

    def changed(self) -> None:
        """The tab's state changed: redraw what shows it (overlay, hints) and tell the tab's panels.
        """

    def on_state(self, callback: Callable[[TabState], None]) -> None:
        """Call callback(state) after every change of the tab's state."""

    def on_click(self, mode: str, handler: Callable[[float, float], None]) -> None:
        """Route clicks on the depth frame in `mode` to handler(u, v)."""

    def look(self, view: str) -> None:
        """Show the 3D scene ('3d') or the depth frame ('depth') in this tab."""

    def act(self, action: Callable[[], object]) -> None:
        """Run a user's action of this tab; a refusal becomes a notification on this tab."""

    def ask(self, title: str, text: str, yes: str, on_yes: Callable[[], object], no: str,
            on_no: Callable[[], object] = lambda: None) -> "Question":
        """Ask before an action that loses something: a modal with `text` (markdown) and two
        buttons; `yes` runs on_yes as a user's action (act), `no` on_no; either closes it."""
