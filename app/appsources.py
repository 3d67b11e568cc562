"""What the app serves from: the session being edited, the source its frames come from, and the
background the object is selected against."""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.depth.files import write_depth_png
from mirrorcore.io.session import BACKGROUND_FILE, Session
from mirrorcore.sources import DepthSource, SessionSource

from .events import EventBus, LoopChanged

if TYPE_CHECKING:
    from .editor import SessionEditor
    from .live import LiveLoop

# where the background in use lives when it was captured for a session that is not saved
IN_MEMORY = ":memory:"


class AppSources:
    """Open another session, replay another source, capture the background; mixed into
    `mirrorscan.server.MirrorscanApp`.

    Uses the app's `editor`, `loop`, `bus`, `start_source`, `_source`, `_background`, `pause` and
    `_on_session_change`.
    """

    editor: SessionEditor
    loop: LiveLoop
    bus: EventBus
    start_source: DepthSource
    _source: DepthSource
    _background: tuple[str | None, np.ndarray | None]

    def open_session(self, session: Session, play: bool = False) -> None:
        """Edit another session, autosaved in its folder from now on.

        Its recorded frames play when `play`, or when it has some and no camera is live, as
        `mirrorscan serve SESSION` does (its mirrors belong to them, not to the simulator or
        recording playing before); a live camera stays, to be used with the session's calibration.

        Parameters
        ----------
        session : Session
            The session to edit.
        play : bool, optional
            Play its recorded frames even when a camera is live.

        Raises
        ------
        SessionLocked
            Another program edits it; nothing changed.
        """
        self.editor.claim(session.root)
        if session.frames and (play or not self._source.camera):
            # the session served from the start is not a replay
            start = self.start_source
            served = (isinstance(start, SessionSource)
                      and Path(start.session.root).resolve() == Path(session.root).resolve())
            # refused when its camera differs
            self.use_source(start if served else SessionSource(session))
        # the session's own, if any, is read on the change
        self._background = (None, self._source.background())
        self.editor.replace_session(session)

    def use_source(self, source: DepthSource) -> None:
        """Take frames from another source of the same camera (a recording to replay).

        Parameters
        ----------
        source : DepthSource
            The new source.

        Raises
        ------
        MirrorscanError
            When its frames' size differs from this session's camera.
        """
        if source.intrinsics.shape != self._source.intrinsics.shape:
            size = f"{source.intrinsics.width}x{source.intrinsics.height}"
            raise MirrorscanError(f"{source.name}: its {size} frames do not fit this session's "
                                  "camera; replay a recording of the same camera")
        self._source = source
        self.loop.use_source(source)
        self.bus.publish(LoopChanged(self.loop.paused, source))

    def back_to_start_source(self) -> None:
        """Take frames from the source served from the start again, playing (not paused).

        After a recording played (Record's replay, or a session opened over the simulator); the
        session being edited stays (its calibration is this rig's).
        """
        self.use_source(self.start_source)
        self.pause(False)

    def set_background(self, depth: np.ndarray) -> None:
        """Use `depth` as the background.

        Saved beside a saved session as background.png, held in memory for one that is not saved
        (Save as writes it).

        Parameters
        ----------
        depth : np.ndarray, shape (H, W)
            Depth in metres.
        """
        if self.editor.autosave:
            root = Path(self.editor.session.root)
            root.mkdir(parents=True, exist_ok=True)
            write_depth_png(root / BACKGROUND_FILE, depth, self.editor.session.camera.depth_scale)
            self._background = (BACKGROUND_FILE, depth)
            self.editor.set_background(BACKGROUND_FILE)
        else:
            self._background = (IN_MEMORY, depth)
            self._on_session_change()

    @property
    def background_captured(self) -> bool:
        """Whether the background in use was captured, not the source's own.

        One read from the session's file counts as captured.
        """
        return self._background[0] is not None
