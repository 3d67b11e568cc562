"""`mirrorscan reconstruct SESSION -o OUT --frame all`: one PLY per frame and a manifest.

On this machine's cores or a Dask cluster (mirrorcore.batch), with a progress bar; a rerun does only
the frames missing.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from tqdm import tqdm

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.batch import BatchJob, BatchProgress, BatchReport, Where, run_batch
from mirrorcore.dense import DenseOptions

from . import ctrl_c_cancels, wording


def run_all(args: argparse.Namespace, out: Path, options: DenseOptions) -> int:
    """Every frame into the folder `out` (mirrorcore.batch.run_batch) with a progress bar.

    Ctrl-C stops cleanly (the frames finished and the manifest are kept; a rerun goes on) and
    exits with 130.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    out : Path
        The output folder.
    options : DenseOptions
        The dense methods' options of the command line (metres).

    Returns
    -------
    int
        The exit status (see _summary).

    Raises
    ------
    MirrorscanError
        When --frames is not 1.
    """
    if args.frames != 1:
        raise MirrorscanError(
            "--frames: with --frame all each frame is reconstructed alone (people move); --frames "
            "fuses several frames into one result"
        )
    job = BatchJob(Path(args.session), out, args.method, options, args.temporal, args.bounces,
                   args.colour)
    where = Where(args.workers, args.scheduler)
    if where.scheduler:
        print(f"connecting to the Dask cluster at {where.scheduler}...", flush=True)
    elif not where.in_process:
        print(f"starting {where.local_workers} local Dask workers...", flush=True)
    with _ProgressBar(args.method) as bar, ctrl_c_cancels() as cancel:
        report = run_batch(job, where, args.frames_per_task, args.overwrite, bar.show, cancel)
    return _summary(report, args.verbose)


class _ProgressBar:
    """A tqdm bar of the frames done, with their rate and the time left; failures and retries after.

    It is made at the first progress report; the frames kept from an earlier run count as done, not
    in the rate.
    """

    def __init__(self, desc: str):
        self.desc = desc
        self.bar: tqdm | None = None

    def __enter__(self) -> _ProgressBar:
        return self

    def __exit__(self, *exc) -> None:
        if self.bar is not None:
            self.bar.close()

    def show(self, progress: BatchProgress) -> None:
        if self.bar is None:
            if progress.dashboard:
                print(f"Dask dashboard: {progress.dashboard}", flush=True)
            self.bar = tqdm(
                total=progress.total, initial=progress.kept, desc=self.desc, unit="frame"
            )
        self.bar.set_postfix(
            {
                k: v
                for k, v in (("failed", progress.failed), ("retried", len(progress.retried)))
                if v
            },
            refresh=False,
        )
        self.bar.update(progress.done - self.bar.n)


def _summary(report: BatchReport, verbose: bool) -> int:
    """Print how the batch went.

    Raises
    ------
    MirrorscanError
        When frames failed (exit 2).
    KeyboardInterrupt
        When cancelled (exit 130).
    """
    wording.show(wording.batch_done(report), verbose)
    for worker in sorted(set(report.retried.values())):
        frames = [i for i, w in report.retried.items() if w == worker]
        wording.show(wording.retried(worker, frames), verbose)
    if report.cancelled:
        raise KeyboardInterrupt
    if report.failed:
        first, message = next(iter(report.failed.items()))
        raise MirrorscanError(
            f"{len(report.failed)} frame(s) failed ({wording.frame_list(list(report.failed))}; see "
            f"{report.manifest}), frame {first}: {message}"
        )
    return 0
