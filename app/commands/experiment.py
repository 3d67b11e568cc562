"""`mirrorscan experiment {angle,distance,kaleidoscope}`: the paper's figures 4a and 5a on the simulated rig, and the
error against the angle of two hinged mirrors seen through several mirrors in turn, as CSV and PNG."""
from __future__ import annotations

import argparse
import csv
import io
from pathlib import Path

from app import experiment_kaleidoscope
from app.experiments import COLUMNS, plot_experiment, run_experiment
from mirrorcore.atomic import write_atomic
from mirrorcore.errors import MirrorscanError
from mirrorcore.outputs import check_output


def register(sub) -> None:
    p = sub.add_parser("experiment", help="the paper's error-vs-angle (fig. 4a) or error-vs-distance (fig. 5a) "
                                          "experiment on the simulated rig, or the kaleidoscope's error-vs-angle")
    p.add_argument("name", choices=["angle", "distance", "kaleidoscope"])
    p.add_argument("-o", "--out", default=None, help="output prefix: writes PREFIX.csv and PREFIX.png "
                                                     "(default experiment-NAME)")
    p.add_argument("--seeds", type=int, default=3, help="noise seeds per point (default 3)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    if args.seeds < 1:
        raise MirrorscanError(f"--seeds: at least 1, got {args.seeds}")
    prefix = Path(args.out or f"experiment-{args.name}")
    if not prefix.parent.is_dir():
        raise MirrorscanError(f"{prefix.parent}: no such folder")
    for path in (prefix.with_suffix(".csv"), prefix.with_suffix(".png")):
        check_output(path)                     # before minutes of work: never over a session's files
    if args.name == "kaleidoscope":
        columns = experiment_kaleidoscope.COLUMNS
        rows = experiment_kaleidoscope.run_kaleidoscope(args.seeds, progress=not args.quiet)
    else:
        columns, rows = COLUMNS, run_experiment(args.name, args.seeds, progress=not args.quiet)
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=columns)
    writer.writeheader()
    writer.writerows(rows)
    write_atomic(prefix.with_suffix(".csv"), text.getvalue().encode("utf-8"))
    if args.name == "kaleidoscope":
        experiment_kaleidoscope.plot_kaleidoscope(rows, prefix.with_suffix(".png"))
    else:
        plot_experiment(args.name, rows, prefix.with_suffix(".png"))
    print(f"wrote {prefix.with_suffix('.csv')} and {prefix.with_suffix('.png')}")
    return 0
