"""The effect of temporal smoothing (`reconstruct --temporal N`) on the walking figure.

mirrorcore.depth.temporal on the simulator's walking figure (two mirrors at 120 deg, 3 m, Kinect v1
noise, perfect calibration): each frame's cloud (Algorithm 1, the whole pipeline) with and without,
its RMSE to the true surface of the figure at that moment, on the still and the moving parts of the
body.

A point's part is read from the true surface nearest to it: 'still' where that surface moves along
its own normal slower than STILL (the torso and head bob up and down with the gait, which a depth
camera does not see: the surface slides along itself), 'moving' where faster than MOVING (swinging
arms and legs, the feet). RMSE is over the points within INLIER of the true surface; the share of
points farther (two-bounce rays, mixed pixels at edges) is given beside it."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import open3d as o3d
from tqdm import tqdm

from mirrorcore.base.budget import check_memory
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.rig.pipeline import object_cloud
from mirrorcore.sim.export import true_rig
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.objects import object_geometry
from mirrorcore.sim.simulator import Simulator
from mirrorcore.depth.temporal import WINDOW_PIXEL_BYTES, temporal_smooth

STILL, MOVING = 0.02, 0.2  # m/s along the surface's normal
INLIER = 0.03  # metres
DEPTH_BYTES = 4  # a pixel of a depth frame held: float32 metres
PARTS = ("still", "moving")
COLUMNS = (
    "frame",
    "part",
    "points",
    "rmse_mm",
    "temporal_rmse_mm",
    "outliers_pct",
    "temporal_outliers_pct",
)


def surface_errors(
    geometry, t: float, fps: float, points: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Distances of points to the figure's true surface at time t, and that surface's speed.

    Parameters
    ----------
    points : (n, 3) float
        Metres, camera frame.

    Returns
    -------
    distances : (n,) float
        Metres to the nearest true surface.
    speeds : (n,) float
        m/s of that surface along its normal (central difference over one frame either side).
    """
    vertices, faces = geometry.mesh_at(t)
    before, _ = geometry.mesh_at(t - 1 / fps)
    after, _ = geometry.mesh_at(t + 1 / fps)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(vertices), o3d.core.Tensor(faces))
    nearest = scene.compute_closest_points(o3d.core.Tensor(np.asarray(points, np.float32)))
    distance = np.linalg.norm(nearest["points"].numpy() - points, axis=1)
    triangles = faces[nearest["primitive_ids"].numpy()]
    a, b, c = (vertices[triangles[:, k]].astype(np.float64) for k in range(3))
    normal = np.cross(b - a, c - a)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
    velocity = (after - before)[triangles].mean(axis=1) * fps / 2
    return distance, np.abs(np.sum(velocity * normal, axis=1))


def run_temporal_experiment(
    neighbours: int = 2, frames: int = 30, scale: float = 1.0, seed: int = 0, progress: bool = True
) -> list[dict]:
    """Rows (keys COLUMNS), one per frame and part, of `frames` frames (30: one stride).

    Parameters
    ----------
    neighbours : int, optional
        Each frame is smoothed with this many frames on each side.
    frames : int, optional
    scale : float, optional
        The camera is 640x480 * scale.
    seed : int
        The simulator's seed.
    progress : bool, optional
        Show a progress bar.

    Returns
    -------
    list of dict

    Raises
    ------
    MemoryBudgetError
        When the frames held and one window being smoothed would pass the memory budget (checked
        before any frame is rendered).
    """
    camera = Intrinsics.kinect_v1().scaled(scale)
    held = frames + 2 * neighbours
    check_memory(float(camera.width * camera.height) * (
        held * DEPTH_BYTES + (2 * neighbours + 1) * WINDOW_PIXEL_BYTES),
                 f"--neighbours {neighbours}, --frames {frames}: {held:,} frames of "
                 f"{camera.width}x{camera.height} held")
    scene = paper_scene(object="figure", distance=3.0, camera=camera)
    sim = Simulator(scene, seed=seed)
    rig, background = true_rig(scene), sim.background().depth
    geometry = object_geometry(scene.objects[0])
    depths = [sim.frame(i).depth for i in range(frames + 2 * neighbours)]
    rows = []
    for i in tqdm(
        range(neighbours, neighbours + frames), desc="temporal", unit="frame", disable=not progress
    ):
        smoothed = temporal_smooth(
            np.stack(depths[i - neighbours : i + neighbours + 1]), neighbours
        )
        figures = {}
        for name, depth in (("", depths[i]), ("temporal_", smoothed)):
            cloud, _ = object_cloud(rig, depth, background)
            distance, speed = surface_errors(geometry, i / sim.fps, sim.fps, cloud.points)
            for part, selected in zip(PARTS, (speed < STILL, speed > MOVING)):
                d = distance[selected]
                inlier = d[d < INLIER]
                figures.setdefault(part, {"frame": i, "part": part, "points": len(d)})
                figures[part][f"{name}rmse_mm"] = 1e3 * float(np.sqrt(np.mean(inlier**2)))
                figures[part][f"{name}outliers_pct"] = 100.0 * (1 - len(inlier) / max(len(d), 1))
        rows += [figures[part] for part in PARTS]
    return rows


def summary(rows: list[dict]) -> dict[str, dict[str, float]]:
    """Per part: the median RMSE over frames without and with smoothing (mm), and its change (%).

    Parameters
    ----------
    rows : list of dict
        As run_temporal_experiment gives them.

    Returns
    -------
    dict of str to dict
        {part: {'rmse_mm', 'temporal_rmse_mm', 'change_pct'}}.
    """
    out = {}
    for part in PARTS:
        before = np.median([r["rmse_mm"] for r in rows if r["part"] == part])
        after = np.median([r["temporal_rmse_mm"] for r in rows if r["part"] == part])
        out[part] = {
            "rmse_mm": float(before),
            "temporal_rmse_mm": float(after),
            "change_pct": float(100 * (after / before - 1)),
        }
    return out


def plot_temporal(rows: list[dict], neighbours: int, path: str | Path) -> None:
    """Write the PNG of the per-frame RMSE with and without smoothing, still and moving parts.

    Parameters
    ----------
    rows : list of dict
        As run_temporal_experiment gives them.
    neighbours : int
        The smoothing's neighbours, for the legend.
    path : str or Path
    """
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after choosing the headless backend

    fig, ax = plt.subplots(figsize=(6, 4))
    for part, colour in zip(PARTS, ("tab:blue", "tab:orange")):
        frames = [r["frame"] for r in rows if r["part"] == part]
        ax.plot(
            frames,
            [r["rmse_mm"] for r in rows if r["part"] == part],
            color=colour,
            linestyle="--",
            label=f"{part} parts, as read",
        )
        ax.plot(
            frames,
            [r["temporal_rmse_mm"] for r in rows if r["part"] == part],
            color=colour,
            label=f"{part} parts, --temporal {neighbours}",
        )
    ax.set_xlabel("frame (30 fps)")
    ax.set_ylabel("RMSE to the true surface (mm)")
    ax.set_title(
        f"walking figure at 3 m, two mirrors, Kinect v1 noise (points within {INLIER * 1e3:g} mm)",
        fontsize=10,
    )
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
