"""`mirrorscan bench [--json]`: the performance figures (median milliseconds, frames per second)."""

from __future__ import annotations

import argparse
import json
import sys

import mirrorscan.bench as bench


def register(sub) -> None:
    """Add `mirrorscan bench` to the command line; its parser's `run` default is `run`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The `mirrorscan` parser's subcommands.
    """
    p = sub.add_parser("bench", help="the performance figures")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run the benchmarks (their names on stderr); print each figure, or one JSON object (--json).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit status: 0.
    """
    figures = bench.run_all(progress=lambda name: print(f"running {name}...", file=sys.stderr))
    if args.json:
        print(json.dumps(figures))
    else:
        width = max(map(len, figures))
        for name, value in figures.items():
            print(f"{name:<{width}}  {value:10.3f}")
    return 0
