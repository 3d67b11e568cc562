"""The `mirrorscan` command line (the script contract of docs/DESIGN.md).

Exit 0 on success, 2 with a one-line error on bad input, 130 when cancelled.
"""

from __future__ import annotations

import argparse
import gc
import importlib
import sys

from mirrorcore.base.budget import ENV, set_memory_budget
from mirrorcore.base.errors import MirrorscanError

# Subcommand modules under mirrorscan.commands, in the order `mirrorscan --help` lists them.
COMMANDS = [
    "serve",
    "calibrate",
    "reconstruct",
    "fit",
    "simulate",
    "plan",
    "truth",
    "experiment",
    "sources",
    "record",
    "bench",
]
VERBOSE_HELP = "also print the figures behind each line (sigma, counts, before and after), indented"


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose refusals are one line naming the option, without the usage."""

    def error(self, message: str):
        """Print 'PROG: error: --option: what is wrong (see PROG --help)' and exit with 2."""
        said = message.removeprefix("argument ")
        self.exit(2, f"{self.prog}: error: {said} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The parser of `mirrorscan`: --memory, then one subcommand, each with -v/--verbose."""
    parser = OneLineParser(
        prog="mirrorscan",
        description="3D scanning with one depth camera and mirrors.",
        epilog="Each command prints one headline per result; add -v/--verbose after the command "
        "for the figures behind it.",
    )
    parser.add_argument(
        "--memory",
        metavar="SIZE",
        help=f"memory budget for work sized by your numbers, e.g. 8G (default: ${ENV}, else the "
        "smaller of 4G and half this machine's memory)",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"mirrorscan.commands.{name}").register(sub)
        sub.choices[name].add_argument("-v", "--verbose", action="store_true", help=VERBOSE_HELP)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command of `argv`.

    An error of the tool or a file is one line on stderr, without a traceback.

    Parameters
    ----------
    argv : list of str, optional
        Default sys.argv[1:].

    Returns
    -------
    int
        The exit status: the command's, 2 after an error, 130 after Ctrl-C.
    """
    try:
        args = build_parser().parse_args(argv)
    # a refusal of the parser (printed in one line) or --help
    except SystemExit as exc:
        return exc.code if isinstance(exc.code, int) else 2
    try:
        if args.memory is not None:
            set_memory_budget(args.memory)
        return int(args.run(args) or 0)
    except MirrorscanError as exc:
        print(f"mirrorscan {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        # a file that cannot be read or written: named, without a traceback
        print(
            f"mirrorscan {args.command}: error: {exc.filename or ''}: {exc.strerror or exc}",
            file=sys.stderr,
        )
        return 2
    except KeyboardInterrupt:
        print(f"mirrorscan {args.command}: cancelled", file=sys.stderr)
        return 130


def run() -> None:
    """The console script: run `main` on the command line's arguments and exit with its status.

    The garbage is collected once, then the objects left are moved out of the collector's reach
    (gc.freeze): at exit the interpreter's last full collections otherwise take 1 to 3 s after a
    Dask batch, which Ctrl-C must not wait for. The collection comes first because Open3D ends the
    process with status 1 when its tensors are still allocated at exit.
    """
    status = main()
    gc.collect()
    gc.freeze()
    sys.exit(status)


if __name__ == "__main__":
    run()
