"""A browser tab as the server sees it, without a browser.

A websocket client speaking viser's protocol (its subprotocol, then a camera report, after which
viser counts the tab as connected), reading every message on a thread, counting the bytes and
answering the server's localStorage reads as a browser does (the app polls every tab that way, and
takes a late answer for a tab that lags). The app then builds a Tab for it, which benchmarks measure
and tests drive.
"""

from __future__ import annotations

import threading
import time
import uuid

import msgspec
import viser
import websockets.sync.client
import zstandard

from mirrorscan.tab import PAGE_KEY

# what a browser tab sends first: its view of the scene
CAMERA_MESSAGE = msgspec.msgpack.encode(
    {
        "type": "ViewerCameraMessage",
        "wxyz": [1.0, 0.0, 0.0, 0.0],
        "position": [0.0, 0.0, 0.0],
        "fov": 1.0,
        "near": 0.01,
        "far": 100.0,
        "image_height": 480,
        "image_width": 640,
        "look_at": [0.0, 0.0, 1.0],
        "up_direction": [0.0, -1.0, 0.0],
    }
)


def wait_for(condition, seconds: float = 30.0, what: str = "condition"):
    """Poll condition() until it returns something true, or fail after `seconds`.

    Parameters
    ----------
    condition : callable
        Called with no arguments every 20 ms.
    seconds : float, optional
    what : str, optional
        Named in the failure.

    Returns
    -------
    object
        What condition() returned.

    Raises
    ------
    AssertionError
        When `seconds` pass first.
    """
    deadline = time.monotonic() + seconds
    while True:
        value = condition()
        if value:
            return value
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.02)


class HeadlessTab:
    """Connect to `app` as a tab.

    Set .answer_delay (seconds) to answer the server's localStorage reads that much later, as a
    browser that draws more slowly than frames come (the messages before a read wait to be drawn).

    Parameters
    ----------
    app : MirrorscanApp
        A started app.
    page : str, optional
        The name the page gives when asked which it is (the same for a reload of it; by default
        a new page's own).

    Attributes
    ----------
    tab : Tab
        The app's Tab for it.
    bytes, messages : int
        What it received.
    answer_delay : float
        Seconds.
    """

    def __init__(self, app, page: str | None = None):
        self.page = page or uuid.uuid4().hex
        before = set(app.tabs)
        self.ws = websockets.sync.client.connect(
            f"ws://127.0.0.1:{app.port}",
            subprotocols=[f"viser-v{viser.__version__}"],
            max_size=None,
        )
        self.ws.send(CAMERA_MESSAGE)
        self.bytes = self.messages = 0
        self.answer_delay = 0.0
        self._unzip = zstandard.ZstdDecompressor()
        self._closed = threading.Event()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        # ids start at 0: a set
        new = wait_for(lambda: set(app.tabs) - before, what="the tab to connect")
        self.tab = app.tabs[new.pop()]

    def _read(self) -> None:
        """Receive messages until closed, counting them and answering the reads."""
        try:
            while not self._closed.is_set():
                message = self.ws.recv()
                self.bytes += len(message)
                self.messages += 1
                self._answer(message)
        except (websockets.ConnectionClosed, OSError):
            pass

    def _answer(self, window: bytes) -> None:
        """Answer each localStorage read in a window of messages.

        The window is in viser's wire format: the sizes of the msgpack metadata, raw and
        zstd-compressed, then the metadata, then binary buffers. The answer is the page's name when
        asked which page it is, else "0" (a tab in view).
        """
        size, packed = int.from_bytes(window[:8], "little"), int.from_bytes(window[8:16], "little")
        metadata = msgspec.msgpack.decode(
            self._unzip.decompress(window[16 : 16 + packed], max_output_size=size)
        )
        for message in metadata["messages"]:
            if message.get("type") == "LocalStorageGetItemRequestMessage":
                time.sleep(self.answer_delay)
                value = self.page if message["key"].startswith(PAGE_KEY) else "0"
                self.ws.send(
                    msgspec.msgpack.encode(
                        {
                            "type": "LocalStorageGetItemResponseMessage",
                            "value": value,
                            "error": None,
                            "request_uuid": message["request_uuid"],
                        }
                    )
                )

    def close(self) -> None:
        """Close the connection and stop reading (waiting up to 5 s)."""
        self._closed.set()
        self.ws.close()
        self._reader.join(timeout=5)

    def __enter__(self) -> "HeadlessTab":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
