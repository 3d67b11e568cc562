"""The browser tool: a viser server showing the live merged cloud of a source through a session's calibration."""
from __future__ import annotations

import logging

import viser

from mirrorcore.session import Session
from mirrorcore.sources import DepthSource

from .live import LiveLoop
from .panel import LivePanel
from .state import SharedState, Snapshot
from .view import SceneView

log = logging.getLogger("mirrorscan")


class MirrorscanApp:
    """One server, one source, one shared state; every browser tab sees the same live view."""

    def __init__(self, session: Session, source: DepthSource, host: str = "127.0.0.1", port: int = 8080):
        self.server = viser.ViserServer(host=host, port=port, label="mirrorscan")
        self.state = SharedState(Snapshot.build(session, source.background()))
        self.view = SceneView(self.server)
        self.view.show_rig(self.state.current.rig)
        self.loop = LiveLoop(source, self.state, self._on_frame, self._on_error)
        self.panel = LivePanel(self.server, self.view, self.loop, source.name)
        self.server.on_client_connect(self.view.look_from_home)
        self._last_error = ""

    @property
    def port(self) -> int:
        return self.server.get_port()

    def start(self) -> None:
        self.loop.start()

    def stop(self) -> None:
        self.loop.stop()
        self.server.stop()

    def _on_frame(self, frame) -> None:
        self.panel.show(frame)
        self._last_error = ""

    def _on_error(self, exc: Exception) -> None:
        message = f"{type(exc).__name__}: {exc}"
        if message != self._last_error:      # say it once, not thirty times a second
            log.warning("live frame failed: %s", message)
            for client in self.server.get_clients().values():
                client.add_notification("Live frame failed", message, color="red", auto_close_seconds=8.0)
        self._last_error = message
