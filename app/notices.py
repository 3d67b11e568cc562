"""What the browser tool tells the technician: notifications on one tab or every tab, each also
a line of the server's log, the refusal or failure of a user's action, and a notification that
stays on every tab while it is true (LastingNote).

viser shows notifications at the top left of the 3D view, over the depth frame's corner; it offers
no option to place them. Each tab's page is given a style sheet (`place_notes`, through viser's
message that runs a script, as it loads plotly) that stacks them over the foot of the side panel,
newest at the bottom, every older one collapsed to its title (its text shows under the pointer), as
is viser's own notice that the browser draws without a GPU, which stays until closed.
"""
from __future__ import annotations

import json
import logging
import threading
from typing import Callable

import viser

from mirrorcore.base.errors import MirrorscanError

from .markup import shown
from .presence import run_js
from .wording import refusal

log = logging.getLogger("mirrorscan")
# a notification's colour by its kind
NOTE_COLOURS = {"error": "red", "warning": "orange", "info": "blue"}
NOTE_SECONDS = 8.0        # seconds: a notification closes after this
# seconds: the note of long work's result closes after this; its report stays in the panel, and
# the note must not cover the depth frame's corner for long at 1024x600
RESULT_NOTE_SECONDS = 45.0
# CSS px: the notifications' width, within the side panel (400 px wide, docked right) and clear
# of its scroll bar
NOTE_WIDTH = 360
NOTE_MARGIN = 16          # CSS px from the page's right and bottom edges
NOTES_STYLE_ID = "mirrorscan-notes"
NOTES_CSS = """
.mantine-Notifications-root {{
  top: auto !important; left: auto !important;
  right: {margin}px !important; bottom: {margin}px !important;
  width: {width}px !important; --notifications-container-width: {width}px !important;
}}
.mantine-Notification-root:not(:last-child):not(:hover) {{ padding-top: 4px; padding-bottom: 4px; }}
.mantine-Notification-root:not(:last-child):not(:hover) .mantine-Notification-description,
#webgl-software-rendering:not(:hover) .mantine-Notification-description {{ display: none; }}
"""
NOTES_JS = """(() => {{
  let style = document.getElementById("{id}");
  if (!style) {{
    style = document.createElement("style");
    style.id = "{id}";
    document.head.appendChild(style);
  }}
  style.textContent = {css};
}})();"""


def place_notes(client: viser.ClientHandle) -> None:
    """Stack the tab's notifications over the foot of the side panel (see the module docstring).

    Parameters
    ----------
    client : viser.ClientHandle
    """
    css = NOTES_CSS.format(margin=NOTE_MARGIN, width=NOTE_WIDTH)
    run_js(client, NOTES_JS.format(id=NOTES_STYLE_ID, css=json.dumps(css)))


class Notifier:
    """The notifications of the app.

    Mixed into `mirrorscan.server.MirrorscanApp`, whose `server` it uses.
    """

    server: viser.ViserServer

    def act(self, client: viser.ClientHandle | None, action: Callable[[], object]) -> None:
        """Run a user's action; a refusal, a file error or a bug becomes a notification on that tab.

        A refusal is MirrorscanError; a bug is logged with its traceback: a click never fails in
        silence.

        Parameters
        ----------
        client : viser.ClientHandle or None
            The tab the action came from (None: every tab).
        action : callable
            Called with no arguments.
        """
        try:
            action()
        except (MirrorscanError, OSError) as exc:
            self.notify(client, "Not done", str(exc))
        # a bug must still be told on the tab that clicked
        except Exception as exc:  # noqa: BLE001
            log.exception("an action failed")
            self.notify(client, "Failed (a bug: see the server's log)",
                        f"{type(exc).__name__}: {exc}")

    def notify(self, client: viser.ClientHandle | None, title: str, message: str,
               kind: str = "error", stay: bool = False,
               logged: bool = True) -> viser.NotificationHandle | None:
        """Show a notification on one tab or every tab in its kind's colour (NOTE_COLOURS); log it.

        A message longer than a headline (HEADLINE_WORDS) is cut to its first clause
        (`mirrorscan.wording.refusal`); the log keeps it whole.

        It closes after NOTE_SECONDS, or RESULT_NOTE_SECONDS when `stay` (the result of long work,
        whose report may be out of view).

        Parameters
        ----------
        client : viser.ClientHandle or None
            The tab; None for every tab.
        title, message : str
        kind : str, optional
            A key of NOTE_COLOURS.
        stay : bool, optional
        logged : bool, optional
            False for each tab's note of a shared job's end, which the job logs once.

        Returns
        -------
        viser.NotificationHandle or None
            The one tab's notification (to take it away once it is not true), else None.
        """
        if logged:
            log.info("%s: %s", title, message)
        targets = [client] if client is not None else list(self.server.get_clients().values())
        seconds = RESULT_NOTE_SECONDS if stay else NOTE_SECONDS
        # no longer than a headline: the whole message is in the log
        headline = refusal(message).headline
        notes = [target.add_notification(shown(title), shown(headline), color=NOTE_COLOURS[kind],
                                         auto_close_seconds=seconds)
                 for target in targets]
        return notes[0] if client is not None else None


class LastingNote:
    """A notification on every tab, new tabs too, until it is no longer true (a failed save).

    It has no close button and closes only on `clear`.

    Parameters
    ----------
    server : viser.ViserServer
        The app's server.
    """

    def __init__(self, server: viser.ViserServer):
        self._server = server
        self._lock = threading.Lock()
        # (title, message, kind) while it is shown
        self._shown: tuple[str, str, str] | None = None
        self._notes: dict[int, viser.NotificationHandle] = {}

    @property
    def shown(self) -> tuple[str, str, str] | None:
        """(title, message, kind) while it is shown, else None."""
        return self._shown

    @property
    def tabs(self) -> set[int]:
        """The client ids of the tabs that show it."""
        with self._lock:
            return set(self._notes)

    def set(self, note: tuple[str, str, str] | None) -> None:
        """Show it on every tab (replacing what it said), unless it says that already.

        Parameters
        ----------
        note : tuple of str or None
            (title, message, kind), kind a key of NOTE_COLOURS; None takes it away.
        """
        with self._lock:
            if self._shown == note:
                return
            self._remove()
            self._shown = note
            if note is not None:
                for client in list(self._server.get_clients().values()):
                    self._add(client)

    def connected(self, client: viser.ClientHandle) -> None:
        """Show it on a tab that just connected, while it is shown.

        Parameters
        ----------
        client : viser.ClientHandle
        """
        with self._lock:
            if self._shown is not None and client.client_id not in self._notes:
                self._add(client)

    def disconnected(self, client: viser.ClientHandle) -> None:
        """Forget a tab that closed.

        Parameters
        ----------
        client : viser.ClientHandle
        """
        with self._lock:
            self._notes.pop(client.client_id, None)

    def _add(self, client: viser.ClientHandle) -> None:
        """Show it on one tab."""
        title, message, kind = self._shown
        self._notes[client.client_id] = client.add_notification(
            title, message, color=NOTE_COLOURS[kind], auto_close_seconds=None,
            with_close_button=False)

    def _remove(self) -> None:
        """Take it away from the tabs that show it."""
        notes, self._notes = self._notes, {}
        for note in notes.values():
            note.remove()
