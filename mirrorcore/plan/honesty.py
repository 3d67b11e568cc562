"""A plan's figures measured on the simulator: its scene rendered, reconstructed by Algorithm 1 with
the true rig, and compared with the subject's surface (docs/planning.md, "How honest the figures
are").

Coverage: the subject's surface samples, per view, that face the view within the incidence limit
(the simulator renders surfaces up to grazing; a sensor reads none beyond the limit) and whose
virtual point projects next to a pixel that Algorithm 1 reconstructed in that view at the sample's
depth (one of the four pixels around it, within the depth's change across one pixel of the
surface's slope plus 2 mm). The depth is rendered
without noise, shadow or jitter, with the sensor's depth range. Noise: per view, the depth error of
the Kinect v1 model (axial noise and disparity steps; no lateral jitter, which moves edges rather
than depths) at the pixels that see the subject, as the estimate sqrt(pi / 2) * mean |error| of
the axial std, each pixel weighted by the area it covers (Z^2).
"""
from __future__ import annotations

import tempfile
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mirrorcore.base.palette import sequence_label
from mirrorcore.plan.coverage import MAX_INCIDENCE_DEG, Coverage, tilt_rotation
from mirrorcore.plan.search import PlanResult
from mirrorcore.plan.planfile import SUBJECT_MESH, plan_scene, subject_mesh
from mirrorcore.plan.subject import sample_surface
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.sim.export import true_rig
from mirrorcore.sim.sensor import SensorModel
from mirrorcore.sim.scene import Scene
from mirrorcore.sim.simulator import Simulator

_PIXELS = 1.0            # the depth's change across this many pixels of the surface's slope ...
_SLACK = 0.002           # ... plus this many metres is the tolerance of a match


@dataclass(frozen=True)
class Measured:
    """A plan's figures measured on the simulator.

    Attributes
    ----------
    coverage : Coverage
        The samples each view's reconstructed points reach (depth 0 where not).
    noise_mm : (v,) float array
        The axial noise per view, mm (NaN for a view without pixels).
    """

    coverage: Coverage
    noise_mm: np.ndarray


def _label(view: tuple[int, ...]) -> int:
    """The source label of a 0-based view."""
    return sequence_label(tuple(j + 1 for j in view)) if view else 0


def measure(result: PlanResult, samples: int = 20000, seed: int = 7) -> Measured:
    """Render the plan's scene and measure its coverage and noise (see the module docstring).

    Parameters
    ----------
    result : PlanResult
    samples : int
        Surface samples (a different draw from the plan's).
    seed : int

    Returns
    -------
    Measured
    """
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / SUBJECT_MESH
        path.write_bytes(subject_mesh(result))
        return _measure(result, plan_scene(result, str(path)), samples, seed)


def _measure(result: PlanResult, scene: Scene, samples: int, seed: int) -> Measured:
    """`measure` of the plan's scene."""
    camera = result.camera
    R = tilt_rotation(result.tilt)
    drawn = sample_surface(result.space.subject, samples, seed)
    points, normals = drawn.points @ R.T, drawn.normals @ R.T
    ranged = SensorModel(axial_k=0.0, quantise=False, lateral_sigma=0.0, shadow=False,
                         min_range=camera.min_depth, max_range=camera.max_depth)
    rig = replace(true_rig(scene), bounces=result.bounces)
    frame = Simulator(scene, ranged, 0, result.bounces).frame(0)
    cloud = reconstruct_raw(rig, frame.depth, frame.truth.object_mask)
    views = result.coverage.views
    intr = camera.intrinsics
    depth = np.zeros(intr.width * intr.height, np.float32)
    label = np.full(intr.width * intr.height, -1, np.int16)
    depth[cloud.pixel_index] = frame.depth.reshape(-1)[cloud.pixel_index]
    label[cloud.pixel_index] = cloud.sources
    seen = np.zeros((len(views), len(points)), bool)
    for v, view in enumerate(views):
        virtual, vnormal = points, normals
        for j in reversed(view):
            plane = scene.mirrors[j].plane
            virtual = plane.reflect(virtual)
            vnormal = vnormal - 2 * (vnormal @ plane.n)[:, None] * plane.n
        cos = -(vnormal * virtual).sum(axis=1) / np.linalg.norm(virtual, axis=1)
        facing = cos >= np.cos(np.radians(MAX_INCIDENCE_DEG))
        z = virtual[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = intr.fx * virtual[:, 0] / z + intr.cx
            w = intr.fy * virtual[:, 1] / z + intr.cy
            slope = np.sqrt(np.maximum(1 - cos ** 2, 0)) / np.maximum(cos, 1e-3)
        tolerance = _PIXELS * z / intr.fx * slope + _SLACK
        for du, dw in ((0, 0), (0, 1), (1, 0), (1, 1)):
            col, row = np.floor(u).astype(np.int64) + du, np.floor(w).astype(np.int64) + dw
            inside = facing & (z > 0) & (col >= 0) & (col < intr.width) & (row >= 0) & (
                row < intr.height)
            pix = np.where(inside, row * intr.width + col, 0)
            seen[v] |= inside & (label[pix] == _label(view)) & (
                np.abs(depth[pix] - z) <= tolerance)
    noise = _noise(result, scene, views)
    return Measured(Coverage(views, seen, np.zeros(seen.shape, np.float32), drawn.weight), noise)


def _noise(result: PlanResult, scene: Scene, views) -> np.ndarray:
    """(v,) the measured axial noise per view, mm (see the module docstring)."""
    sensor = replace(SensorModel.kinect_v1(), lateral_sigma=0.0, shadow=False,
                     min_range=result.camera.min_depth, max_range=result.camera.max_depth)
    truth = Simulator(scene, sensor, 0, result.bounces).frame(0).truth
    ideal, source = truth.depth, truth.source
    rng = np.random.default_rng(3)
    noise = []
    for view in views:
        pix = (source == _label(view)) & truth.object_mask & (ideal > 0)
        errors, weights = [], []
        for _ in range(4):
            measured = sensor.apply(scene.camera, ideal, rng)
            ok = pix & (measured > 0)
            errors.append(np.abs(measured[ok] - ideal[ok]))
            weights.append(ideal[ok].astype(np.float64) ** 2)
        e, w = np.concatenate(errors), np.concatenate(weights)
        noise.append(np.sqrt(np.pi / 2) * (e * w).sum() / w.sum() * 1e3 if len(e) else np.nan)
    return np.array(noise)
