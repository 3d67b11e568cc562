"""`mirrorscan experiment NAME`: the experiments on the simulated rig, as CSV and PNG.

The paper's figures 4a and 5a on the simulated rig, the error against the angle of two hinged
mirrors seen through several mirrors in turn, and the effect of temporal smoothing on the walking
figure, as CSV and PNG.
"""

from __future__ import annotations

import argparse
import csv
import io
from pathlib import Path

from mirrorscan.experiments import kaleidoscope as experiment_kaleidoscope
from mirrorscan.experiments import temporal as temporal_experiment
from mirrorscan.experiments.paper import COLUMNS, plot_experiment, run_experiment
from mirrorcore.base.atomic import write_atomic
from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.outputs import check_output

from .numbers import whole


def register(sub) -> None:
    """Add `mirrorscan experiment` to the command line; its parser's `run` default is `run`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The `mirrorscan` parser's subcommands.
    """
    p = sub.add_parser(
        "experiment",
        help="the paper's error-vs-angle (fig. 4a) or error-vs-distance (fig. 5a) experiment on "
        "the simulated rig, the kaleidoscope's error-vs-angle, or temporal smoothing on the "
        "walking figure",
    )
    p.add_argument("name", choices=["angle", "distance", "kaleidoscope", "temporal"])
    p.add_argument(
        "-o",
        "--out",
        default=None,
        help="output prefix: writes PREFIX.csv and PREFIX.png (default experiment-NAME)",
    )
    p.add_argument(
        "--seeds",
        type=whole(1),
        default=3,
        help="angle, distance: noise seeds per point (default 3)",
    )
    p.add_argument(
        "--neighbours", type=whole(1), default=2, help="temporal: frames on each side (default 2)"
    )
    p.add_argument(
        "--frames",
        type=whole(1),
        default=30,
        help="temporal: frames measured (default 30, one stride)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run an experiment on the simulated rig and write its CSV and PNG beside --out.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit status: 0.

    Raises
    ------
    MirrorscanError
        When --out's folder does not exist.
    """
    prefix = Path(args.out or f"experiment-{args.name}")
    if not prefix.parent.is_dir():
        raise MirrorscanError(f"{prefix.parent}: no such folder")
    for path in (prefix.with_suffix(".csv"), prefix.with_suffix(".png")):
        check_output(path)  # before minutes of work: never over a session's files
    if args.name == "temporal":
        return run_temporal(args, prefix)
    if args.name == "kaleidoscope":
        rows = experiment_kaleidoscope.run_kaleidoscope(args.seeds, progress=not args.quiet)
        write_csv(prefix.with_suffix(".csv"), experiment_kaleidoscope.COLUMNS, rows)
        experiment_kaleidoscope.plot_kaleidoscope(rows, prefix.with_suffix(".png"))
    else:
        rows = run_experiment(args.name, args.seeds, progress=not args.quiet)
        write_csv(prefix.with_suffix(".csv"), COLUMNS, rows)
        plot_experiment(args.name, rows, prefix.with_suffix(".png"))
    print(f"wrote {prefix.with_suffix('.csv')} and {prefix.with_suffix('.png')}")
    return 0


def run_temporal(args: argparse.Namespace, prefix: Path) -> int:
    """Run the temporal experiment, write its CSV and PNG, and print its summary per part.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    prefix : Path
        The output files' path without suffix.

    Returns
    -------
    int
        The exit status: 0.
    """
    rows = temporal_experiment.run_temporal_experiment(
        args.neighbours, args.frames, progress=not args.quiet
    )
    write_csv(prefix.with_suffix(".csv"), temporal_experiment.COLUMNS, rows)
    temporal_experiment.plot_temporal(rows, args.neighbours, prefix.with_suffix(".png"))
    for part, figures in temporal_experiment.summary(rows).items():
        print(
            f"{part} parts: RMSE {figures['rmse_mm']:.2f} mm as read, "
            f"{figures['temporal_rmse_mm']:.2f} mm with --temporal {args.neighbours} "
            f"({figures['change_pct']:+.0f} %), median over {args.frames} frames"
        )
    print(f"wrote {prefix.with_suffix('.csv')} and {prefix.with_suffix('.png')}")
    return 0


def write_csv(path: Path, columns: tuple[str, ...], rows: list[dict]) -> None:
    """Write `rows` as CSV with a header, atomically.

    Parameters
    ----------
    path : Path
    columns : tuple of str
        The header, in order.
    rows : list of dict
        One per line, keyed by column.
    """
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=columns)
    writer.writeheader()
    writer.writerows(rows)
    write_atomic(path, text.getvalue().encode("utf-8"))
