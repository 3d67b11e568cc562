"""One module per `mirrorscan` subcommand.

Each has register(subparsers) that sets the parser's `run` default. Here: what several share.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

from tqdm import tqdm

from mirrorcore.base.progress import Progress


@contextmanager
def percent_bar(desc: str, disable: bool = False) -> Iterator[Progress]:
    """A tqdm bar (stderr) of the fraction done.

    The bar shows after half a second and is cleared at the end, so that a refusal stays one line.

    Parameters
    ----------
    desc : str
        The bar's label.
    disable : bool, optional
        Show no bar.

    Yields
    ------
    Progress
        progress(fraction), fraction from 0 to 1.
    """
    with tqdm(
        total=100,
        desc=desc,
        unit="%",
        leave=False,
        delay=0.5,
        bar_format="{l_bar}{bar}| {elapsed}",
        disable=disable,
    ) as bar:
        yield lambda fraction: bar.update(100 * fraction - bar.n)


@contextmanager
def ctrl_c_cancels() -> Iterator[threading.Event]:
    """While inside, Ctrl-C sets the yielded threading.Event instead of interrupting.

    The computation stops at its next chunk; the previous handler is restored on the way out.
    """
    event = threading.Event()
    previous = signal.signal(signal.SIGINT, lambda *_: event.set())
    try:
        yield event
    finally:
        signal.signal(signal.SIGINT, previous)
