"""What a tab may send: uploads within their budgets, and GUI values within their inputs' ranges.

limit_inputs() puts its checks first in line for viser's upload and GUI update messages. viser
hands each message to the server's handlers (in the order registered) and then, in a later step of
its event loop, to the handlers of the tab's own GUI; a check registered first on the server runs
before either of them stores anything.

- **Uploads** are counted by the bytes received, not by the sizes they declare. An upload is
  refused as it starts when its declared size passes `max_upload_bytes` or the memory budget, when
  its tab already has MAX_UPLOADS_PER_TAB uploads being received, or when all the uploads being
  received would declare more than MAX_UPLOADS_IN_FLIGHT together; it is dropped at the first part
  that takes it past its declared size or `max_upload_bytes` (so the bytes held stay within
  MAX_UPLOADS_IN_FLIGHT). A refused part is never stored and the parts held so far are dropped; the
  tab is told once.
- **GUI values**: a tab may change only an input's value, and only to one its input offers: a
  slider's, number's or vector's value within its min and max (finite), a dropdown's or button
  group's among its options. Anything else is dropped with one log line.
"""
from __future__ import annotations

import logging
import math
from collections.abc import Callable

import viser
from viser import _messages

from mirrorcore.base.budget import check_memory
from mirrorcore.base.errors import MirrorscanError

log = logging.getLogger("mirrorscan.security")

MAX_UPLOAD_BYTES = 20 << 20          # one upload (the Session panel's background PNG)
MAX_UPLOADS_IN_FLIGHT = 64 << 20     # bytes of every upload being received, all tabs together
MAX_UPLOADS_PER_TAB = 4              # uploads one tab may have being received at once
# a message whose uuid no input or upload has: viser ignores it
IGNORED = ""


def limit_inputs(server: viser.ViserServer, max_upload_bytes: int = MAX_UPLOAD_BYTES) -> None:
    """Install the upload budgets and the GUI value checks into a running viser server.

    Parameters
    ----------
    server : viser.ViserServer
    max_upload_bytes : int
        The largest upload.

    Raises
    ------
    MirrorscanError
        When viser's message handlers cannot be found (a viser version whose internals differ).
    """
    uploads = _Uploads(server, max_upload_bytes)
    _first(server, _messages.FileTransferStartUpload, uploads.on_start)
    _first(server, _messages.FileTransferPart, uploads.on_part)
    _first(server, _messages.GuiUpdateMessage, lambda client_id, message: _check_update(
        server, client_id, message))


def _first(server: viser.ViserServer, kind: type, check: Callable) -> None:
    """Register `check` before every other server handler of messages of `kind`."""
    handlers = getattr(server._websock_server, "_incoming_handlers", None)
    if not isinstance(handlers, dict):
        raise MirrorscanError("cannot limit what a tab may send; refusing to run unprotected "
                              "(check the viser version)")
    handlers.setdefault(kind, []).insert(0, check)


def _guis(server: viser.ViserServer, client_id: int) -> list:
    """The GUIs a tab's message may reach: the server's, and the tab's own."""
    client = server.get_clients().get(client_id)
    return [server.gui] + ([client.gui] if client is not None else [])


# ---------------------------------------------------------------------- uploads
class _Uploads:
    """The upload checks of one server (see the module docstring)."""

    def __init__(self, server: viser.ViserServer, max_upload_bytes: int):
        self.server, self.max_upload_bytes = server, max_upload_bytes

    def held(self) -> list[dict]:
        """Every upload being received, as viser holds them: its state dicts."""
        guis = [self.server.gui] + [c.gui for c in self.server.get_clients().values()]
        return [state for gui in guis for state in gui._current_file_upload_states.values()]

    def on_start(self, client_id: int, message: _messages.FileTransferStartUpload) -> None:
        """Refuse an upload by its declared size and the uploads in flight, before viser sees it."""
        held = self.held()
        name, size = str(message.filename)[:80], message.size_bytes
        reason = None
        if not (isinstance(size, int) and isinstance(message.part_count, int)) or size < 0:
            reason = f"{name}: a malformed upload (size {str(size)[:40]!r})"
        elif size > self.max_upload_bytes:
            reason = (f"{name}: {size / 2**20:.1f} MB is more than the "
                      f"{self.max_upload_bytes / 2**20:g} MB an upload may have; upload a smaller "
                      "file")
        elif sum(s["client_id"] == client_id for s in held) >= MAX_UPLOADS_PER_TAB:
            reason = (f"{name}: {MAX_UPLOADS_PER_TAB} uploads from this tab are still coming; "
                      "wait for them, then try again")
        elif sum(s["total_bytes"] for s in held) + size > MAX_UPLOADS_IN_FLIGHT:
            reason = f"{name}: too many uploads at once; try again"
        else:
            try:
                check_memory(2 * size, f"upload {name}")
            except MirrorscanError as exc:
                reason = str(exc)
        if reason is not None:
            message.source_component_uuid = IGNORED
            self._tell(client_id, reason)

    def on_part(self, client_id: int, message: _messages.FileTransferPart) -> None:
        """Drop an upload whose received bytes pass its budget, before viser stores the part."""
        uuid = message.transfer_uuid
        states = [(gui, gui._current_file_upload_states.get(uuid))
                  for gui in _guis(self.server, client_id)]
        states = [(gui, state) for gui, state in states if state is not None]
        if not states:
            return
        state, index = states[0][1], message.part_index
        name = str(state["filename"])[:80]
        if not isinstance(index, int) or not isinstance(message.content, bytes):
            reason = f"{name}: a malformed part"
        elif index in state["parts"] or not 0 <= index < state["part_count"]:
            return   # viser ignores it
        elif state["transferred_bytes"] + len(message.content) > min(state["total_bytes"],
                                                                     self.max_upload_bytes):
            reason = (f"{name}: more bytes than it declared (or than the "
                      f"{self.max_upload_bytes / 2**20:g} MB an upload may have)")
        else:
            return
        for gui, _ in states:
            gui._current_file_upload_states.pop(uuid, None)
        self._tell(client_id, reason)

    def _tell(self, client_id: int, reason: str) -> None:
        """Log a refusal and tell the tab."""
        log.warning("refused an upload: %s", reason)
        client = self.server.get_clients().get(client_id)
        if client is not None:
            client.add_notification("Upload refused", reason, color="red", auto_close_seconds=8.0)


# ---------------------------------------------------------------------- GUI values
def _check_update(server: viser.ViserServer, client_id: int,
                  message: _messages.GuiUpdateMessage) -> None:
    """Let a tab's GUI update through only when it sets an input's value to one the input offers."""
    handle = None
    for gui in _guis(server, client_id):
        handle = gui._gui_input_handle_from_uuid.get(message.uuid, handle)
    if handle is None:
        return
    updates = message.updates if isinstance(message.updates, dict) else {}
    reason = refusal(handle._impl.props, handle._impl.value, updates)
    if reason is not None:
        label = str(getattr(handle._impl.props, "label", message.uuid))[:80]
        log.warning("refused a GUI update of %r from a tab: %s", label, reason)
        message.uuid = IGNORED


def refusal(props, current, updates: dict) -> str | None:
    """Why a tab may not apply `updates` to an input with `props`, or None when it may.

    Parameters
    ----------
    props : viser GUI props
        The input's (min, max, options where it has them).
    current : object
        The input's value now (a tuple for a vector or a multi-slider: the new one has its length).
    updates : dict
        The update's properties and values.

    Returns
    -------
    str or None
        A one-line reason.
    """
    others = sorted(str(k) for k in updates if k != "value")
    if others or "value" not in updates:
        return f"a tab may set only the value, not {', '.join(others)[:80] or 'nothing'}"
    value = updates["value"]
    options = getattr(props, "options", None)
    if options is not None:
        return None if value in tuple(options) else f"{str(value)[:40]!r} is not an option"
    if not hasattr(props, "min"):
        return None
    values = value if isinstance(value, (list, tuple)) else (value,)
    if isinstance(current, tuple) != isinstance(value, (list, tuple)) or len(values) != len(
            current if isinstance(current, tuple) else (current,)):
        return f"{str(value)[:40]!r} is not a value of this input"
    lows, highs = (_bounds(getattr(props, k, None), len(values)) for k in ("min", "max"))
    for v, low, high in zip(values, lows, highs):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            return f"{str(v)[:40]!r} is not a finite number"
        if (low is not None and v < low) or (high is not None and v > high):
            return f"{v:g} is outside {low} to {high}"
    return None


def _bounds(bound, n: int) -> tuple:
    """A min or max (None, a number, or one per element) as n of them."""
    return tuple(bound) if isinstance(bound, (list, tuple)) else (bound,) * n


__all__ = ["MAX_UPLOAD_BYTES", "MAX_UPLOADS_IN_FLIGHT", "MAX_UPLOADS_PER_TAB", "limit_inputs",
           "refusal"]
