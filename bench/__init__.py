"""Benchmarks behind `mirrorscan bench`.

Each module in MODULES has run() -> dict of figure name -> value.
"""

from __future__ import annotations

import importlib
import time
from typing import Callable

MODULES = [
    "mirrorscan.bench.alg1",
    "mirrorscan.bench.sim",
    "mirrorscan.bench.serve",
    "mirrorscan.bench.carve",
    "mirrorscan.bench.tsdf",
    "mirrorscan.bench.refine",
    "mirrorscan.bench.batch",
    "mirrorscan.bench.plan",
]


def median_ms(fn: Callable[[], object], repeat: int = 30, warmup: int = 3) -> float:
    """Median wall-clock milliseconds of fn() over `repeat` runs after `warmup` runs.

    Parameters
    ----------
    fn : callable
        Called with no arguments.
    repeat : int, optional
    warmup : int, optional

    Returns
    -------
    float
    """
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t0) * 1e3)
    times.sort()
    return times[len(times) // 2]


def interleaved_ms(
    fns: dict[str, Callable[[], object]], repeat: int = 30, warmup: int = 3
) -> dict[str, float]:
    """Median wall-clock milliseconds of each fn() over `repeat` rounds, after `warmup` rounds.

    Each round calls every fn in turn, so that a busy machine slows them alike.

    Parameters
    ----------
    fns : dict of str to callable
        By figure name; each called with no arguments.
    repeat : int, optional
    warmup : int, optional

    Returns
    -------
    dict of str to float
        By figure name.
    """
    for _ in range(warmup):
        for fn in fns.values():
            fn()
    times: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(repeat):
        for name, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            times[name].append((time.perf_counter() - t0) * 1e3)
    return {name: sorted(t)[len(t) // 2] for name, t in times.items()}


def run_all(progress: Callable[[str], None] | None = None) -> dict[str, float]:
    """Run every benchmark module of MODULES.

    Parameters
    ----------
    progress : callable, optional
        Called with each module's name before it runs.

    Returns
    -------
    dict of str to float
        The modules' figures, merged.
    """
    figures: dict[str, float] = {}
    for name in MODULES:
        if progress:
            progress(name)
        figures.update(importlib.import_module(name).run())
    return figures
