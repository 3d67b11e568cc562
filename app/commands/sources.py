"""`mirrorscan sources`: the kinds of depth source, their specs, and which work on this machine."""

from __future__ import annotations

import argparse

from mirrorcore.sources import KINDS


def register(sub) -> None:
    """Add `mirrorscan sources` to the command line; its parser's `run` default is `run`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The `mirrorscan` parser's subcommands.
    """
    p = sub.add_parser(
        "sources",
        help="list the depth sources, their specs, and which are available here",
        description="Depth source specs for --source and `mirrorscan record`: KIND:TARGET, "
        "options after '?': camera=FILE|kinect_v1|primesense, scale=METRES_PER_UNIT, fps=N, "
        "colour=registered (the cameras).",
    )
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Print each kind of depth source: its spec, what it is, what it does with colour, and
    whether it works here.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit status: 0.
    """
    width = max(len(k.spec) for k in KINDS)
    for kind in KINDS:
        reason = kind.unavailable()
        print(
            f"{kind.spec:<{width}}  {kind.what}\n{'':<{width}}  {kind.colour}\n"
            f"{'':<{width}}  {'available' if reason is None else reason}"
        )
    return 0
