"""The paper's experiments on the simulated rig.

Reconstruction error against the angle between the two mirrors (figure 4a, sphere r = 115 mm at 2 m)
and against the object-to-mirror distance (figure 5a, cylinder r = 150 mm). Each trial runs the
whole pipeline: calibrate the mirrors from their markers, select the object against the background,
Algorithm 1, then RANSAC fit of the shape; errors over all points as the paper measures them. The
same frame is also carved (the consistent carving, mirrorcore.carve) and fused (TSDF mesh,
mirrorcore.tsdf) in 2 mm voxels: their RMSE to the true shape beside the raw cloud's (the paper
found its carved clouds less accurate). Each trial is also run as a real rig's markers would be
(issue 11): 3 mm in front of the silver and clicked 2 px off, calibrated from them alone, then
refined from the agreement of the views over 3 frames.
"""

from __future__ import annotations

import io
from pathlib import Path

import matplotlib
import numpy as np
from tqdm import tqdm

from mirrorcore.base.atomic import write_atomic
from mirrorcore.calibration.fit import calibrate_session
from mirrorcore.dense import DenseOptions, dense_volume
from mirrorcore.dense.carve import carve
from mirrorcore.dense.tsdf import fuse
from mirrorcore.base.errors import CalibrationError
from mirrorcore.geometry.fitting import fit_cylinder, fit_sphere
from mirrorcore.rig.pipeline import object_masks, prepare_frame
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.calibration.refine import refine_session
from mirrorcore.rig.model import Rig
from mirrorcore.io.session import Session
from mirrorcore.geometry.shapes import Cylinder, FitErrors, Sphere
from mirrorcore.sim.export import session_mirrors
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.scene import Scene, SceneObject
from mirrorcore.sim.sensor import SensorModel
from mirrorcore.sim.simulator import Simulator

ANGLES = tuple(range(60, 161, 20))  # degrees between the mirror surfaces
MIRROR_DISTANCES = (0.25, 0.35, 0.45, 0.55, 0.65)  # metres from the cylinder's axis to each mirror
COLUMNS = (
    "parameter",
    "seed",
    "rmse_mm",
    "mean_error_mm",
    "mean_abs_error_mm",
    "radius_mm",
    "radius_error_mm",
    "true_rmse_mm",
    "points",
    "mirror_points",
    "carve_true_rmse_mm",
    "carve_points",
    "tsdf_true_rmse_mm",
    "tsdf_vertices",
    "glass_true_rmse_mm",
    "glass_refined_true_rmse_mm",
)
# What the plot shows: the paper's two errors against the fitted shape, and the cloud's error
# against the true one. (The signed mean error about a least-squares fit is zero by construction,
# so the paper's "mean error", which it plots above zero, is read as the mean of |dist - R|.)
PLOTTED = (
    ("rmse_mm", "RMSE (fitted shape)"),
    ("mean_abs_error_mm", "mean error |d - R| (fitted shape)"),
    ("true_rmse_mm", "RMSE to the true shape (raw cloud)"),
    ("carve_true_rmse_mm", "RMSE to the true shape (carved cloud)"),
    ("tsdf_true_rmse_mm", "RMSE to the true shape (TSDF mesh)"),
    ("glass_true_rmse_mm", "RMSE to the true shape, markers 3 mm in front, not refined"),
    ("glass_refined_true_rmse_mm", "RMSE to the true shape, markers 3 mm in front, refined"),
)
# markers this far (metres) in front of the silver, clicks this far off (pixels)
GLASS = (0.003, 2.0)
REFINE_FRAMES = 3


def true_shape(obj: SceneObject) -> Sphere | Cylinder:
    """The analytic shape of a scene's sphere or cylinder.

    Parameters
    ----------
    obj : SceneObject

    Returns
    -------
    Sphere or Cylinder
    """
    if obj.type == "sphere":
        return Sphere(tuple(obj.centre), obj.radius)
    return Cylinder(tuple(obj.centre), tuple(obj.axis), obj.radius)


def run_trial(scene: Scene, seed: int) -> dict[str, float]:
    """The fit's figures of one noisy Kinect frame of `scene` (a sphere or a cylinder).

    Parameters
    ----------
    scene : Scene
    seed : int
        The simulator's seed.

    Returns
    -------
    dict of str to float
    """
    sim = Simulator(scene, SensorModel.kinect_v1(), seed)
    frame, background = sim.frame(0), sim.background().depth
    rng = np.random.default_rng(seed)
    # as a user clicks them
    session = Session(Path("."), sim.intrinsics, session_mirrors(sim, frame.truth))
    rig = Rig.from_session(calibrate_session(session, np.stack([frame.depth, background]), rng)[0])
    # as pipeline.object_cloud selects and smooths
    depth, mask = prepare_frame(rig, frame.depth, background)
    cloud = reconstruct_raw(rig, depth, mask)
    fit = (fit_sphere if scene.objects[0].type == "sphere" else fit_cylinder)(
        cloud.points, rng, sources=cloud.sources
    )
    errors, truth = fit.errors, true_shape(scene.objects[0])
    true_errors = FitErrors.from_deviations(truth.deviations(cloud.points))
    volume = dense_volume(rig, depth, mask, DenseOptions())
    carved, _ = carve(rig, depth, mask, volume).surface_points()
    mesh = fuse(rig, depth, mask, volume).mesh()

    def true_rmse(points: np.ndarray) -> float:
        return 1e3 * FitErrors.from_deviations(truth.deviations(points)).rmse

    return {
        "rmse_mm": 1e3 * errors.rmse,
        "mean_error_mm": 1e3 * errors.mean_error,
        "mean_abs_error_mm": 1e3 * errors.mean_abs_error,
        "radius_mm": 1e3 * fit.shape.radius,
        "radius_error_mm": 1e3 * (fit.shape.radius - truth.radius),
        "true_rmse_mm": 1e3 * true_errors.rmse,
        "points": float(len(cloud)),
        "mirror_points": float(np.count_nonzero(cloud.sources)),
        "carve_true_rmse_mm": true_rmse(carved),
        "carve_points": float(len(carved)),
        "tsdf_true_rmse_mm": true_rmse(mesh.vertices),
        "tsdf_vertices": float(len(mesh.vertices)),
        **glass_trial(scene, seed),
    }


def glass_trial(scene: Scene, seed: int) -> dict[str, float]:
    """The same scene and noise with the markers GLASS.

    The raw cloud's RMSE to the true shape (mm) from the markers alone, then after the refinement
    (NaN when the refinement refuses: at 140 degrees and more the sphere hides what the mirrors and
    the camera would both see).

    Parameters
    ----------
    scene : Scene
    seed : int
        The simulator's seed.

    Returns
    -------
    dict of str to float
    """
    sim = Simulator(scene.with_markers(*GLASS), SensorModel.kinect_v1(), seed)
    frames, background = [sim.frame(i).depth for i in range(REFINE_FRAMES)], sim.background().depth
    session = Session(Path("."), sim.intrinsics, session_mirrors(sim, sim.frame(0).truth))
    session = calibrate_session(
        session, np.stack([frames[0], background]), np.random.default_rng(seed)
    )[0]
    truth = true_shape(scene.objects[0])

    def rmse(session: Session) -> float:
        rig = Rig.from_session(session)
        cloud = reconstruct_raw(rig, *prepare_frame(rig, frames[0], background))
        return 1e3 * FitErrors.from_deviations(truth.deviations(cloud.points)).rmse

    rig = Rig.from_session(session)
    masks = object_masks(rig, np.stack(frames), background)
    try:
        refined = rmse(refine_session(session, np.stack(frames), masks)[0])
    except CalibrationError:
        refined = float("nan")
    return {"glass_true_rmse_mm": rmse(session), "glass_refined_true_rmse_mm": refined}


def experiment_scenes(name: str) -> list[tuple[float, Scene]]:
    """The scenes of an experiment.

    Parameters
    ----------
    name : str
        'angle': (angle, sphere scene) pairs; 'distance': (mirror distance, cylinder scene) pairs.

    Returns
    -------
    list of (float, Scene)
    """
    if name == "angle":
        return [(float(a), paper_scene(angle_deg=a, object="sphere", distance=2.0)) for a in ANGLES]
    return [
        (d, paper_scene(angle_deg=120.0, object="cylinder", distance=2.0, mirror_distance=d))
        for d in MIRROR_DISTANCES
    ]


def run_experiment(name: str, seeds: int, progress: bool = True) -> list[dict[str, float]]:
    """The rows of experiment 'angle' or 'distance', one per parameter and seed, keys COLUMNS.

    Parameters
    ----------
    name : str
        'angle' or 'distance'.
    seeds : int
        Seeds per parameter.
    progress : bool, optional
        Show a progress bar.

    Returns
    -------
    list of dict
    """
    trials = [(p, scene, s) for p, scene in experiment_scenes(name) for s in range(seeds)]
    return [
        {"parameter": p, "seed": float(s), **run_trial(scene, s)}
        for p, scene, s in tqdm(trials, desc=name, unit="trial", disable=not progress)
    ]


def plot_experiment(name: str, rows: list[dict[str, float]], path) -> None:
    """Write the PNG of the PLOTTED errors against the parameter to `path`.

    Each error is drawn as its mean over seeds (line) and standard deviation (band).

    Parameters
    ----------
    name : str
        'angle' or 'distance'.
    rows : list of dict
        As run_experiment gives them.
    path : str or Path
    """
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after choosing the headless backend

    params = np.array([r["parameter"] for r in rows])
    xs = np.unique(params)
    fig, ax = plt.subplots(figsize=(6, 4))
    for key, label in PLOTTED:
        values = np.array([r[key] for r in rows])
        # a refused refinement is NaN: left out of the mean; a parameter where all were refused has
        # no point
        mean, std = (
            np.array(
                [
                    f(v[np.isfinite(v)]) if np.isfinite(v).any() else np.nan
                    for v in (values[params == x] for x in xs)
                ]
            )
            for f in (np.mean, np.std)
        )
        ax.plot(xs, mean, marker="o", label=label)
        ax.fill_between(xs, mean - std, mean + std, alpha=0.25)
    ax.set_xlabel(
        "angle between the mirrors (deg)" if name == "angle" else "object to mirror distance (m)"
    )
    ax.set_ylabel("error (mm)")
    ax.set_title(
        f"simulated Kinect v1, {'sphere r=115 mm' if name == 'angle' else 'cylinder r=150 mm'}, "
        f"{len(rows) // len(xs)} seeds"
    )
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=120)
    plt.close(fig)
    write_atomic(path, png.getvalue())  # the previous plot, or the whole new one
