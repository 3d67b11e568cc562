"""Soak test of the browser tool.

The live demo streamed to several simulated browser tabs (websocket clients on 127.0.0.1) for a set
time while the session is edited and autosaved; reports memory (RSS), frames, frame rate, what every
tab received, and whether every edit reached the disk.

.venv/bin/python -m mirrorscan.bench.soak --minutes 10 --clients 4      # the long run; the test
suite runs ~25 s of it
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import tempfile
import threading
import time
import traceback
from dataclasses import asdict, dataclass, field
from pathlib import Path

import viser
import websockets.asyncio.client

from mirrorscan.demo import calibrated_session, demo_source
from mirrorscan.server import MirrorscanApp
from mirrorscan.bench.tabs import CAMERA_MESSAGE
from mirrorcore.io.sessionfile import load_session

WARM_UP = 0.2  # fraction of the run after which memory is taken as the baseline
EDIT_EVERY_S = 5.0  # a mirror is renamed (and autosaved) this often
SAMPLE_EVERY_S = 1.0  # RSS sampled this often
LATE_CLIENT_S = 3.0  # the tab opened at the end listens this long


@dataclass
class SoakReport:
    """What a soak run measured.

    Attributes
    ----------
    seconds : float
        How long it streamed.
    clients : int
        The simulated tabs.
    frames : int
    fps : float
        frames / seconds.
    rss_mb : dict of str to float
        Memory of the whole process (server, live loop and the simulated tabs), MB, at the
        'start', after the warm-up ('warm'), at the 'end', its 'max' and 'growth' = end - warm.
    messages : list of int
        Per tab, in order.
    max_gap_s : float
        The longest silence any tab saw.
    edits : int
        Session renames made.
    edits_on_disk : bool
        The last rename is found in session.json at the end.
    late_messages : int
        What a tab opened at the end received (the whole current state).
    errors : list of str
        Live loop errors.
    """

    seconds: float
    clients: int
    frames: int = 0
    fps: float = 0.0
    rss_mb: dict[str, float] = field(default_factory=dict)
    messages: list[int] = field(default_factory=list)
    max_gap_s: float = 0.0
    edits: int = 0
    edits_on_disk: bool = False
    late_messages: int = 0
    errors: list[str] = field(default_factory=list)


def describe(exc: BaseException) -> str:
    """'Type: message' and the innermost frames (file:line) where it was raised, for the report.

    Parameters
    ----------
    exc : BaseException

    Returns
    -------
    str
    """
    where = "; ".join(
        f"{Path(f.filename).name}:{f.lineno}" for f in traceback.extract_tb(exc.__traceback__)[-4:]
    )
    return f"{type(exc).__name__}: {exc} (at {where})"


def rss_mb() -> float:
    """Resident memory of this process in MB (Linux /proc)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


async def listen(url: str, until: float) -> tuple[int, float]:
    """One simulated tab.

    Connect with viser's protocol, report a camera view (viser counts a tab as connected from
    then on), read every message until time.monotonic() >= until.

    Parameters
    ----------
    url : str
        The server's websocket address.
    until : float
        time.monotonic() at which to stop.

    Returns
    -------
    messages : int
        Messages received.
    gap : float
        The longest gap between two messages, seconds.
    """
    count, gap, last = 0, 0.0, time.monotonic()
    async with websockets.asyncio.client.connect(
        url, subprotocols=[f"viser-v{viser.__version__}"], max_size=None
    ) as ws:
        await ws.send(CAMERA_MESSAGE)
        while (left := until - time.monotonic()) > 0:
            try:
                await asyncio.wait_for(ws.recv(), timeout=min(left, 1.0))
            except asyncio.TimeoutError:
                continue
            now = time.monotonic()
            count, gap, last = count + 1, max(gap, now - last), now
    return count, max(gap, until - last)


async def _tabs(url: str, n: int, until: float) -> list[tuple[int, float]]:
    """Run `n` simulated tabs (listen) side by side until `until`."""
    return list(await asyncio.gather(*(listen(url, until) for _ in range(n))))


def run(seconds: float, clients: int = 4, folder: str | Path | None = None,
        edit_every: float = EDIT_EVERY_S) -> SoakReport:
    """Serve the live demo on 127.0.0.1 (a free port) to `clients` tabs for `seconds`.

    A mirror is renamed every `edit_every` seconds; the session is autosaved in `folder`. Stops by
    itself.

    Parameters
    ----------
    seconds : float
    clients : int, optional
    folder : str or Path, optional
        A temporary folder by default.
    edit_every : float, optional
        Seconds between two edits.

    Returns
    -------
    SoakReport
    """
    report = SoakReport(seconds, clients, rss_mb={"start": rss_mb()})
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(folder or tmp) / "soak"
        source = demo_source()
        app = MirrorscanApp(
            calibrated_session(source, root),
            source,
            port=0,
            autosave=True,
            sessions_dir=root.parent,
        )
        report_error = app.loop.on_error
        app.loop.on_error = lambda exc: (report.errors.append(describe(exc)), report_error(exc))
        url = f"ws://127.0.0.1:{app.port}"
        start = time.monotonic()
        until = start + seconds
        tabs: list[tuple[int, float]] = []
        listener = threading.Thread(
            target=lambda: tabs.extend(asyncio.run(_tabs(url, clients, until))), daemon=True
        )
        try:
            app.start()
            listener.start()
            next_edit, rss = start + edit_every, []
            while (now := time.monotonic()) < until:
                rss.append(rss_mb())
                if "warm" not in report.rss_mb and now - start >= WARM_UP * seconds:
                    report.rss_mb["warm"] = rss[-1]
                if now >= next_edit:
                    report.edits += 1
                    app.editor.rename_mirror(1, f"mirror 1 edit {report.edits}")
                    next_edit += edit_every
                time.sleep(min(SAMPLE_EVERY_S, max(0.0, until - now)))
            report.frames = app.loop.index
            report.fps = report.frames / (time.monotonic() - start)
            listener.join(timeout=30)
            late = asyncio.run(_tabs(url, 1, time.monotonic() + LATE_CLIENT_S))
        finally:
            app.stop()
        memory = report.rss_mb
        memory["end"] = rss_mb()
        memory["max"] = max(rss + [memory["end"]])
        memory["growth"] = memory["end"] - memory.get("warm", memory["start"])
        report.messages = [count for count, _ in tabs]
        report.max_gap_s = max((gap for _, gap in tabs), default=float("inf"))
        report.late_messages = late[0][0]
        report.edits_on_disk = (
            load_session(root).mirrors[0].name
            == app.editor.session.mirrors[0].name
            == (f"mirror 1 edit {report.edits}" if report.edits else "mirror 1")
        )
    return report


def main(argv: list[str] | None = None) -> int:
    """The command line: run the soak and print its report as JSON.

    Parameters
    ----------
    argv : list of str, optional
        The arguments; sys.argv's by default.

    Returns
    -------
    int
        The exit status: 0.
    """
    parser = argparse.ArgumentParser(
        prog="python -m mirrorscan.bench.soak", description=__doc__.splitlines()[0]
    )
    parser.add_argument(
        "--minutes", type=float, default=10.0, help="how long to stream (default 10)"
    )
    parser.add_argument("--clients", type=int, default=4, help="simulated browser tabs (default 4)")
    args = parser.parse_args(argv)
    print(json.dumps(asdict(run(args.minutes * 60, args.clients)), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
