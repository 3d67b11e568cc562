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
    from mirrorcore.io.session import Session

    from .editor import SessionEditor
    from .events import EventBus
    from .jobs import Jobs
    from .liveframe import LiveFrame
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
    def snapshot(self) -> "Snapshot":
        """The current state (replaced whole on every change of the session or its background)."""

    @property
    def source(self) -> DepthSource:
        """The depth source the live loop takes its frames from."""

    @property
    def last_frame(self) -> "LiveFrame | None":
        """The live loop's last processed frame, or None before the first."""

    @property
    def paused(self) -> bool:
        """Whether the live loop is paused."""

    def pause(self, paused: bool) -> None:
        """Pause or resume the live loop, and tell the tabs (LoopChanged).

        Parameters
        ----------
        paused : bool
            Pause it (True) or let it play (False).
        """

    def step(self) -> None:
        """Process the next frame while paused."""

    def seek(self, index: int) -> None:
        """Go to a frame of the source.

        Parameters
        ----------
        index : int
            The frame's index in the source.
        """

    def fps(self) -> float:
        """The live loop's measured rate, frames per second."""

    def fps_wanted(self) -> float | None:
        """The live loop's rate when it should be lower than the source's (pacing), else None."""

    def pacing(self) -> tuple[float, str] | None:
        """(frames per second, why) when the live loop runs slower than its source, else None."""

    def open_session(self, session, play: bool = False) -> None:
        """Edit another session, autosaved in its folder from now on.

        Parameters
        ----------
        session : Session
            The session to edit.
        play : bool, optional
            Play its recorded frames even when a camera is live.
        """

    def use_source(self, source: DepthSource) -> None:
        """Take frames from another source of the same camera (a recording to replay).

        Parameters
        ----------
        source : DepthSource
            The new source.

        Raises
        ------
        MirrorscanError
            When its frames' size differs from the camera's.
        """

    def back_to_start_source(self) -> None:
        """Take frames from the source served from the start again, playing."""

    def set_background(self, depth: np.ndarray) -> None:
        """Use `depth` as the background.

        Parameters
        ----------
        depth : np.ndarray, shape (H, W)
            Depth in metres.
        """

    @property
    def background_captured(self) -> bool:
        """Whether the background in use was captured, not the source's own."""

    def notify(self, client: viser.ClientHandle | None, title: str, message: str,
               kind: str = "error", stay: bool = False,
               logged: bool = True) -> viser.NotificationHandle | None:
        """Show a notification on one tab, or on every tab when `client` is None.

        Parameters
        ----------
        client : viser.ClientHandle or None
            The tab, or None for all.
        title, message : str
            The headline and its text.
        kind : str, optional
            The notification's kind, which sets its colour (NOTE_COLOURS).
        stay : bool, optional
            Close it after RESULT_NOTE_SECONDS (the result of long work) instead of NOTE_SECONDS.
        logged : bool, optional
            Also write it to the log.

        Returns
        -------
        viser.NotificationHandle or None
            The one tab's notification, else None.
        """

    def act(self, client: viser.ClientHandle | None, action: Callable[[], object]) -> None:
        """Run a user's action; a refusal, file error or bug becomes a notification on the tab.

        Parameters
        ----------
        client : viser.ClientHandle or None
            The tab the action came from (None: every tab).
        action : callable
            The action, called with no arguments.
        """


@dataclass(frozen=True)
class Question:
    """A question on a tab (TabContext.ask): its modal, and its two answers.

    Attributes
    ----------
    modal : object
        The modal shown.
    yes, no : callable
        What the two buttons run.
    """

    modal: object
    yes: Callable[[], None]
    no: Callable[[], None]


@dataclass
class TabState:
    """What belongs to one browser tab.

    Attributes
    ----------
    mode : str
        The click mode, one of MODES.
    mirror_id : int or None
        The selected mirror.
    drafts : dict
        {mirror id: boundary being drawn, as (u, v) pixels}.
    region_draft : tuple of (float, float)
        The region of interest being drawn (pixels).
    picked_corner, picked_marker : int or None
        The picked boundary corner or marker.
    moving_marker : bool
        The picked marker moves with the next click.
    flagged_markers : tuple
        (mirror id, marker's pixel) that a proposal flags, crossed on the depth frame.
    proposal_for : tuple of str
        The mirrors whose fitted plane waits for Apply or Discard.
    view : str
        '3d' or 'depth'.
    colour_image : bool
        The depth frame's screen shows the colour image (when the frame has one).
    """

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
    colour_image: bool = False


class TabContext(Protocol):
    """What a panel of one tab works with."""

    client: viser.ClientHandle
    services: Services
    state: TabState
    # the browser draws slower than frames come: it is sent fewer (presence.MAX_LAG_S)
    lagging: bool
    # when it last lagged, once its page was built (time.perf_counter())
    lagged_at: float
    # the session as the tab last drew it: what its actions are made on
    drawn: "Session"
    # the session its page is known to have been sent (presence.py): what a click that comes
    # before the page's next answer was made on
    seen: "Session"

    @property
    def gui(self):
        """The tab's GUI."""

    def changed(self) -> None:
        """The tab's state changed: redraw what shows it (overlay, hints) and tell its panels."""

    def on_state(self, callback: Callable[[TabState], None]) -> None:
        """Call callback(state) after every change of the tab's state.

        Parameters
        ----------
        callback : callable
            Called with the TabState.
        """

    def on_click(self, mode: str, handler: Callable[[float, float], None]) -> None:
        """Route clicks on the depth frame in `mode` to handler(u, v).

        Parameters
        ----------
        mode : str
            One of MODES.
        handler : callable
            Called with the clicked pixel's column and row.
        """

    def look(self, view: str) -> None:
        """Show the 3D scene or the depth frame in this tab.

        Parameters
        ----------
        view : str
            '3d' or 'depth'.
        """

    def act(self, action: Callable[[], object], drawn: "Session | None" = None) -> None:
        """Run a user's action of this tab; a refusal becomes a notification on this tab.

        Its edits are made on `drawn` (by default the session the tab drew last): one made stale
        by another tab is refused and the tab redrawn.

        Parameters
        ----------
        action : callable
            The action, called with no arguments.
        drawn : Session, optional
            The session the action was made on.
        """

    def ask(self, title: str, text: str, yes: str, on_yes: Callable[[], object], no: str,
            on_no: Callable[[], object] = lambda: None) -> "Question":
        """Ask before an action that loses something: a modal with two buttons; either closes it.

        Parameters
        ----------
        title : str
            The modal's title.
        text : str
            The question (markdown).
        yes : str
            The first button's label; it runs `on_yes` as a user's action (act).
        on_yes : callable
            What `yes` does.
        no : str
            The second button's label.
        on_no : callable, optional
            What `no` does (nothing by default).

        Returns
        -------
        Question
        """
