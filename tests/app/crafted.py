"""A crafted websocket client of a `mirrorscan serve` process: it speaks viser's protocol as a tab
does, remembers the GUI inputs and notifications the server sends, and sends any message."""
from __future__ import annotations

import os
import re
import subprocess
import sys
import threading
from pathlib import Path

import msgspec
import psutil
import viser
import websockets.sync.client
import zstandard
from mirrorscan.bench.tabs import CAMERA_MESSAGE
from mirrorscan.tab import PAGE_KEY
from viser import _messages

ROOT = Path(__file__).resolve().parents[2]


def encode(message: _messages.Message) -> bytes:
    """A message as a tab sends it."""
    return msgspec.msgpack.encode(message.as_serializable_dict())


class Served:
    """`mirrorscan serve FOLDER --port 0` in a process; `port`, `rss()`, `stop()`.

    Parameters
    ----------
    folder : Path
        The session folder (a new one is made).
    """

    def __init__(self, folder: Path):
        command = [sys.executable, "-m", "mirrorscan.cli", "serve", str(folder), "--port", "0"]
        self.process = subprocess.Popen(command, cwd=ROOT, stderr=subprocess.PIPE, text=True,
                                        env={**os.environ, "PYTHONPATH": str(ROOT)})
        lines = []
        while not any("mirrorscan is at" in line for line in lines):
            line = self.process.stderr.readline()
            assert line, "".join(lines)
            lines.append(line)
        self.port = int(re.search(r"http://127\.0\.0\.1:(\d+)/", lines[-1]).group(1))
        # the log, read on so that the server never blocks on a full pipe
        self.log: list[str] = []
        threading.Thread(target=lambda: self.log.extend(self.process.stderr),
                         daemon=True).start()

    def rss(self) -> int:
        """The server's resident memory, bytes."""
        return psutil.Process(self.process.pid).memory_info().rss

    def stop(self) -> None:
        self.process.kill()
        self.process.wait(timeout=30)


class CraftedTab:
    """A tab of the server on `port`, reading on a thread: `inputs` (label -> its creation message
    as a dict), `notes` (notification titles and bodies) and `send(message)`."""

    def __init__(self, port: int):
        self.ws = websockets.sync.client.connect(
            f"ws://127.0.0.1:{port}", subprotocols=[f"viser-v{viser.__version__}"],
            max_size=None)
        self.ws.send(CAMERA_MESSAGE)
        self.inputs: dict[str, dict] = {}
        self.notes: list[str] = []
        self._unzip = zstandard.ZstdDecompressor()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        try:
            while True:
                window = self.ws.recv()
                size = int.from_bytes(window[:8], "little")
                packed = int.from_bytes(window[8:16], "little")
                metadata = msgspec.msgpack.decode(
                    self._unzip.decompress(window[16:16 + packed], max_output_size=size))
                for message in metadata["messages"]:
                    self._meet(message)
        except (websockets.ConnectionClosed, OSError):
            pass

    def _meet(self, message: dict) -> None:
        kind = message.get("type", "")
        label = (message.get("props") or {}).get("label") if isinstance(message, dict) else None
        if kind.startswith("Gui") and kind.endswith("Message") and isinstance(label, str):
            self.inputs[label] = message
        elif kind in ("NotificationShowMessage", "NotificationUpdateMessage"):
            props = message.get("props", {})
            self.notes.append(f"{props.get('title')}: {props.get('body')}")
        elif kind == "LocalStorageGetItemRequestMessage":
            value = uuid_page() if message["key"].startswith(PAGE_KEY) else "0"
            self.ws.send(msgspec.msgpack.encode({
                "type": "LocalStorageGetItemResponseMessage", "value": value, "error": None,
                "request_uuid": message["request_uuid"]}))

    def input_uuid(self, label_start: str) -> str:
        """The uuid of the input whose label begins with `label_start` (None while not met)."""
        for label, message in list(self.inputs.items()):
            if label.startswith(label_start):
                return message["uuid"]
        return None

    def send(self, message: _messages.Message) -> None:
        self.ws.send(encode(message))

    def close(self) -> None:
        self.ws.close()
        self._reader.join(timeout=5)


_PAGE = os.urandom(8).hex()


def uuid_page() -> str:
    """The page's name, one for this test process."""
    return _PAGE
