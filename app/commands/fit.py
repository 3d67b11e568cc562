"""`mirrorscan fit {sphere,cylinder} CLOUD.ply`: a shape fitted to a cloud, as the paper measures.

RANSAC fit, then radius, RMSE and mean error (paper section 5); --json for one JSON object.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from mirrorcore.base.errors import FileFormatError
from mirrorcore.geometry.fitting import (
    DEFAULT_RADIUS_RANGE,
    DEFAULT_THRESHOLD,
    fit_cylinder,
    fit_sphere,
)
from mirrorcore.io.ply import read_ply

from . import percent_bar, wording
from .numbers import real, seed

_FITS = {"sphere": fit_sphere, "cylinder": fit_cylinder}


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add `mirrorscan fit` to the command line; its parser's `run` default is `run`.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The `mirrorscan` parser's subcommands.
    """
    parser = subparsers.add_parser(
        "fit",
        help="fit a sphere or a cylinder to a cloud; radius, RMSE and mean error as in the paper",
        description="RANSAC fit, then least squares on the inliers. Errors (paper eq. 4 and 5) "
        "are over all points and per source (when the PLY has a `source` property), and over the "
        "inliers. Lengths are printed in mm; in --json, centre and axis are in metres (camera "
        "frame), figures ending in _mm in mm.",
    )
    parser.add_argument("shape", choices=sorted(_FITS), help="the shape to fit")
    parser.add_argument(
        "cloud", metavar="CLOUD.ply", help="a point cloud PLY (any; a `source` property is used)"
    )
    parser.add_argument(
        "--json", action="store_true", help="print one JSON object instead of a summary"
    )
    parser.add_argument(
        "--threshold",
        type=real(0, unit="mm", above=True),
        default=1e3 * DEFAULT_THRESHOLD,
        metavar="MM",
        help="RANSAC inlier distance in mm (default %(default)g)",
    )
    parser.add_argument(
        "--min-radius",
        type=real(0, unit="mm", above=True),
        default=1e3 * DEFAULT_RADIUS_RANGE[0],
        metavar="MM",
        help="reject models with a smaller radius, mm (default %(default)g)",
    )
    parser.add_argument(
        "--max-radius",
        type=real(0, unit="mm", above=True),
        default=1e3 * DEFAULT_RADIUS_RANGE[1],
        metavar="MM",
        help="reject models with a larger radius, mm (default %(default)g)",
    )
    parser.add_argument(
        "--seed", type=seed, default=0, help="RANSAC random seed (default %(default)s)"
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Fit a sphere or a cylinder to a PLY cloud and print the fit (one JSON object with --json).

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
    FileFormatError
        When the PLY has no points.
    """
    points, sources = read_ply(args.cloud)
    if len(points) == 0:
        raise FileFormatError(f"{args.cloud}: the PLY has no points")
    # RANSAC's samples on stderr after half a second: a cloud that is not the shape draws 20,000
    with percent_bar(f"fitting a {args.shape}") as progress:
        fit = _FITS[args.shape](
            points,
            np.random.default_rng(args.seed),
            threshold=1e-3 * args.threshold,
            sources=sources,
            radius_range=(1e-3 * args.min_radius, 1e-3 * args.max_radius),
            where=args.cloud,
            progress=progress,
        )
    if args.json:
        print(json.dumps({"file": args.cloud, **fit.to_json()}))
    else:
        wording.show(wording.shape_fitted(fit, args.cloud), args.verbose)
    return 0
