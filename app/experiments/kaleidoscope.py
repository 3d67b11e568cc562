"""The kaleidoscope experiment on the simulated rig.

Two mirrors hinged at the apex (mirrorcore.sim.layouts. kaleidoscope_scene), the paper's sphere (r =
115 mm at 2 m), the angle between the mirrors from 45 to 120 degrees. Below about 90 degrees the
camera also sees the sphere through two and three mirrors in turn. Each trial runs the whole
pipeline on one Kinect v1 frame rendered with up to three bounces (markers -> calibration -> object
selection -> Algorithm 1 following up to 3 mirrors, and again following 1), then fits the sphere:
the share of points seen through several mirrors, how much larger the cloud is than with one bounce,
the points farther than 2 cm from the true sphere (ghosts), and the error of each kind of view
(direct, through 1, 2 and 3 mirrors).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import matplotlib
import numpy as np
from tqdm import tqdm

from mirrorcore.calibration.fit import calibrate_session
from mirrorcore.geometry.fitting import fit_sphere
from mirrorcore.base.palette import source_orders
from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.rig.model import Rig
from mirrorcore.io.session import Session
from mirrorcore.geometry.shapes import Sphere
from mirrorcore.sim.export import session_mirrors
from mirrorcore.sim.layouts import kaleidoscope_scene
from mirrorcore.sim.scene import Scene
from mirrorcore.sim.sensor import SensorModel
from mirrorcore.sim.simulator import Simulator

ANGLES = (45, 60, 72, 90, 120)  # degrees between the mirror surfaces
KINDS = ("direct", "first", "second", "third")  # views through 0, 1, 2, 3 mirrors
FAR = 0.02  # metres: a point this far from the true sphere is a ghost
COLUMNS = (
    "parameter",
    "seed",
    "points",
    "points_one_bounce",
    "growth",
    "multi_share",
    "far_share",
    "radius_mm",
    "radius_error_mm",
    "rmse_mm",
    *(f"{k}_rmse_mm" for k in KINDS),
    *(f"{k}_true_rmse_mm" for k in KINDS),
)
PLOTTED = (
    ("direct_rmse_mm", "direct"),
    ("first_rmse_mm", "through 1 mirror"),
    ("second_rmse_mm", "through 2 mirrors"),
    ("third_rmse_mm", "through 3 mirrors"),
)
RIGHT_PLOTTED = (
    ("multi_share", "share of points through 2-3 mirrors"),
    ("growth", "points gained against 1 bounce (share of its cloud)"),
    ("far_share", "share farther than 2 cm from the sphere"),
)


def experiment_scenes() -> list[tuple[float, Scene]]:
    """(angle, scene) pairs of the experiment."""
    return [(float(a), kaleidoscope_scene(float(a))) for a in ANGLES]


def run_trial(scene: Scene, seed: int, noise: str = "kinect") -> dict[str, float]:
    """One frame of `scene` through the whole pipeline, through 3 and through 1 mirror.

    Parameters
    ----------
    scene : Scene
    seed : int
        The simulator's seed.
    noise : str, optional
        The sensor model's name.

    Returns
    -------
    dict of str to float
        The figures of COLUMNS (besides parameter and seed); errors in mm, NaN for a kind of view
        with no point.
    """
    sim = Simulator(scene, SensorModel.from_name(noise), seed)
    frame, background = sim.frame(0), sim.background().depth
    rng = np.random.default_rng(seed)
    # as a user clicks them
    session = Session(Path("."), sim.intrinsics, session_mirrors(sim, frame.truth))
    rig = Rig.from_session(calibrate_session(session, np.stack([frame.depth, background]), rng)[0])
    depth, mask = prepare_frame(rig, frame.depth, background)
    cloud = reconstruct_raw(rig, depth, mask)
    one = reconstruct_raw(dataclasses.replace(rig, bounces=1), depth, mask)
    fit = fit_sphere(cloud.points, rng, sources=cloud.sources)
    truth = Sphere(tuple(scene.objects[0].centre), scene.objects[0].radius)
    true_deviation = truth.deviations(cloud.points)
    order = source_orders(cloud.sources)
    row = {
        "points": float(len(cloud)),
        "points_one_bounce": float(len(one)),
        "growth": len(cloud) / len(one),
        "multi_share": float(np.mean(order >= 2)),
        "far_share": float(np.mean(np.abs(true_deviation) > FAR)),
        "radius_mm": 1e3 * fit.shape.radius,
        "radius_error_mm": 1e3 * (fit.shape.radius - truth.radius),
        "rmse_mm": 1e3 * fit.errors.rmse,
    }
    for k, kind in enumerate(KINDS):
        row[f"{kind}_rmse_mm"] = _rms_mm(fit.deviations[order == k])
        row[f"{kind}_true_rmse_mm"] = _rms_mm(true_deviation[order == k])
    return row


def _rms_mm(deviations: np.ndarray) -> float:
    """RMS of deviations (metres) in mm; NaN for none."""
    return float(1e3 * np.sqrt(np.mean(deviations**2))) if len(deviations) else float("nan")


def run_kaleidoscope(seeds: int, progress: bool = True) -> list[dict[str, float]]:
    """The experiment's rows, one per angle and seed, keys COLUMNS.

    Parameters
    ----------
    seeds : int
        Seeds per angle.
    progress : bool, optional
        Show a progress bar.

    Returns
    -------
    list of dict
    """
    trials = [(p, scene, s) for p, scene in experiment_scenes() for s in range(seeds)]
    return [
        {"parameter": p, "seed": float(s), **run_trial(scene, s)}
        for p, scene, s in tqdm(trials, desc="kaleidoscope", unit="trial", disable=not progress)
    ]


def _nan_stat(stat, values: np.ndarray) -> float:
    """stat (np.nanmean, np.nanstd) of values; NaN when none is finite.

    A kind of view absent at an angle has no finite value.
    """
    return float(stat(values)) if np.isfinite(values).any() else float("nan")


def plot_kaleidoscope(rows: list[dict[str, float]], path) -> None:
    """Write the experiment's PNG to `path`.

    Left, the RMSE (to the fitted sphere) of each kind of view against the angle (mean line,
    standard deviation band over seeds; a value far above the others is written at the top); right,
    the share of points seen through several mirrors, the cloud's growth against one bounce and the
    ghosts.

    Parameters
    ----------
    rows : list of dict
        As run_kaleidoscope gives them.
    path : str or Path
    """
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after choosing the headless backend

    params = np.array([r["parameter"] for r in rows])
    xs = np.unique(params)
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    means = []
    for ax, keys in ((left, PLOTTED), (right, RIGHT_PLOTTED)):
        for key, label in keys:
            values = np.array([r[key] - (key == "growth") for r in rows])
            mean, std = (
                np.array([_nan_stat(f, values[params == x]) for x in xs])
                for f in (np.nanmean, np.nanstd)
            )
            ax.plot(xs, mean, marker="o", label=label)
            ax.fill_between(xs, mean - std, mean + std, alpha=0.25)
            means += [(x, m) for x, m in zip(xs, mean)] if ax is left else []
        ax.set_xlabel("angle between the hinged mirrors (deg)")
        ax.grid(True, alpha=0.3)
        ax.legend()
    left.set_ylabel("RMSE to the fitted sphere (mm)")
    # a few stray points must not flatten the rest
    top = 2.0 * np.nanpercentile([m for _, m in means], 80)
    left.set_ylim(0, top)
    for x, m in means:
        if m > top:
            left.annotate(f"{m:.0f} mm", (x, 0.97 * top), ha="center", va="top", fontsize=8)
    right.set_ylabel("share of the cloud")
    right.set_ylim(0, 1)
    fig.suptitle(
        "simulated Kinect v1, sphere r=115 mm, two hinged mirrors, up to 3 bounces, "
        f"{len(rows) // len(xs)} seeds"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
