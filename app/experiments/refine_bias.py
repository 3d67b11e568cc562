"""Where the refinement's plane errors come from (issue 11).

Refine the planes of the simulated rig starting from the TRUE planes, with the sensor's effects
switched on one at a time, one frame per refinement, over many frames.

What a refinement from the truth ends at is its error: the mean over frames is its bias, the spread
over frames its noise (compared with the 1-sigma the refinement reports of itself), and the
correlation between the two mirrors says whether the error is common to both (the views' common
offset, which on the paper's rig only the camera-mirror overlap at the silhouettes determines). Run
as `python -m mirrorscan.experiments.refine_bias [--object figure] ...`.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, replace

import numpy as np

from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.calibration.planestep import offset_at
from mirrorcore.calibration.refine import refine_planes
from mirrorcore.sim.export import true_rig
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.presets import object_extent
from mirrorcore.sim.sensor import SensorModel
from mirrorcore.sim.simulator import Simulator

KINECT = SensorModel.kinect_v1()
SENSORS = {  # the Kinect v1 model with its effects one at a time
    "ideal": SensorModel.ideal(),
    "disparity-noise": replace(KINECT, quantise=False, lateral_sigma=0.0),
    "lateral-jitter": replace(SensorModel.ideal(), lateral_sigma=KINECT.lateral_sigma),
    "kinect-noiseless": SensorModel.kinect_v1(noise=False),
    "kinect": KINECT,
}
DISTANCE = {"sphere": 2.0, "figure": 3.0}  # metres, as in tests/cli/test_calibrate.py


@dataclass(frozen=True)
class BiasRow:
    """One sensor's refinements from the truth, one frame each.

    Attributes
    ----------
    sensor : str
    frames : int
    mean_mm, spread_mm : tuple of float
        Per mirror (two), the mean and the spread (std over frames) of the plane's error at the
        object (mm, > 0 away from the camera).
    reported_mm : float
        The 1-sigma the refinement reported (mean over frames, mm).
    correlation : float
        The correlation of the two mirrors' errors over frames.
    """

    sensor: str
    frames: int
    mean_mm: tuple[float, float]
    spread_mm: tuple[float, float]
    reported_mm: float
    correlation: float


def errors_from_truth(obj: str, sensor: str, seed: int, frames: range) -> np.ndarray:
    """Each frame's refinement from the true planes: the offset error and the reported 1-sigma.

    Parameters
    ----------
    obj : str
        The scene's object, a key of DISTANCE.
    sensor : str
        A key of SENSORS.
    seed : int
        The simulator's seed.
    frames : range
        The frames, one refinement each.

    Returns
    -------
    np.ndarray, shape (len(frames), 2, 2)
        Per frame and mirror: (offset error mm, reported 1-sigma mm).
    """
    scene = paper_scene(object=obj, distance=DISTANCE[obj])
    sim, rig = Simulator(scene, SENSORS[sensor], seed=seed), true_rig(scene)
    # the body's middle (the figure's centre is its feet)
    centre = object_extent(scene.objects[0])[0]
    background = sim.background().depth
    out = []
    for i in frames:
        depth = sim.frame(i).depth
        result = refine_planes(
            rig, depth[None], prepare_frame(rig, depth, background)[1][None], with_="surfaces"
        )
        out.append(
            [
                (1e3 * (offset_at(m.after, centre) - offset_at(t.plane, centre)), m.shift_std_mm)
                for m, t in zip(result.mirrors, rig.mirrors)
            ]
        )
    return np.asarray(out)


def bias_row(obj: str, sensor: str, seed: int, frames: int) -> BiasRow:
    """One sensor's refinements from the truth, one frame each, as a BiasRow.

    Parameters
    ----------
    obj : str
        The scene's object.
    sensor : str
    seed : int
        The simulator's seed.
    frames : int

    Returns
    -------
    BiasRow
        Spread NaN for one frame, correlation NaN for two or fewer.
    """
    found = errors_from_truth(obj, sensor, seed, range(frames))
    spread = found[:, :, 0].std(axis=0, ddof=1) if frames > 1 else np.full(2, np.nan)
    correlation = (
        np.corrcoef(found[:, :, 0].T)[0, 1] if frames > 2 and spread.min() > 1e-6 else float("nan")
    )
    return BiasRow(
        sensor,
        frames,
        tuple(found[:, :, 0].mean(axis=0)),
        tuple(spread),
        float(found[:, :, 1].mean()),
        float(correlation),
    )


def main(argv=None) -> None:
    """The command line: print a BiasRow per sensor.

    Parameters
    ----------
    argv : list of str, optional
        The arguments; sys.argv's by default.
    """
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--object", choices=sorted(DISTANCE), default="sphere")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--frames", type=int, default=12, help="frames, one refinement each")
    p.add_argument(
        "--sensors", default=",".join(SENSORS), help=f"comma-separated, of {', '.join(SENSORS)}"
    )
    args = p.parse_args(argv)
    print(
        "sensor            frames  mean error (mm)   spread over frames (mm)  reported 1-sigma  "
        "correlation"
    )
    for name in args.sensors.split(","):
        row = bias_row(args.object, name, args.seed, args.frames)
        print(
            f"{row.sensor:17s} {row.frames:6d}  {row.mean_mm[0]:+.2f} {row.mean_mm[1]:+.2f}       "
            f"{row.spread_mm[0]:.2f} {row.spread_mm[1]:.2f}                {row.reported_mm:.2f}   "
            f"       {row.correlation:.2f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
