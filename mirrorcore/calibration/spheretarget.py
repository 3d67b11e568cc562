"""Mirror planes from a sphere seen directly and in each mirror (a calibration ball; the paper's own
object): what the refinement (refine.py) gives when the object is a sphere.

A mirror maps the sphere's centre to the centre of the sphere its view sees (a virtual sphere behind
the glass), so the mirror's plane is the perpendicular bisector of the two centres: its normal along
their difference, through their midpoint. Each view sees a different cap of the sphere; their
centres come from all of its readings, not from where the views overlap (at grazing angles on their
rims, which is what limits the refinement from the surfaces).

Each frame's views are fitted together (one centre per view, one radius), by least squares on the
distances to the sphere, over the readings within INLIER_SIGMAS of each view's own RANSAC sphere.
That fit is biased by the depth noise along the rays (errors in the variables): on the paper's
sphere at 2 m with the Kinect v1's noise the centres come out 1.1 to 2.3 mm towards the camera and
the planes 1.9 mm too near. Simulation-extrapolation (SIMEX, Cook & Stefanski
1994) takes the bias off: the fit is repeated SIMEX_REPEATS times with more noise of the sensor's
kind in the disparity (SIMEX_LEVELS times its variance: noise.axial_sigma's, scaled to how the
view's readings scatter about the fit), and the parabola through the mean fits at 0 to 2 is followed
back to no noise (-1).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirrorcore.base.errors import CalibrationError, Cancelled, MirrorscanError
from mirrorcore.geometry.fitting import fit_sphere
from mirrorcore.geometry.plane import Plane
from mirrorcore.depth.noise import axial_sigma
from mirrorcore.base.progress import Progress, cancel_requested
from mirrorcore.calibration.readings import LATERAL_PX
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.rig.model import Rig
from mirrorcore.geometry.shapes import Sphere

MIN_POINTS = 300             # readings of the sphere each view needs in every frame
# a reading within this many of its view's depth noise of its view's sphere is on it...
INLIER_SIGMAS = 3.0
MIN_THRESHOLD = 0.01         # ... or within this many metres
# the object is a sphere when at least this share of each view's readings are on it...
ON_SPHERE = 0.9
RADII_AGREE = 0.05           # ... and the views' radii agree to this share
RADIUS_RANGE = (0.03, 0.5)   # metres: a calibration ball, not a wall or a torso
# at most, for each view's first sphere: with ON_SPHERE of the readings on it, 4 samples find it
# with 0.9999 confidence in 10...
RANSAC_ITERATIONS = 200
# ... on at most this many of its readings: a person is refused in 0.03 s, not 0.3
DETECT_POINTS = 2000
SIMEX_LEVELS = (0.5, 1.0, 1.5, 2.0)  # noise added, in multiples of the readings' own variance
SIMEX_REPEATS = 8            # fits per level and frame
# the most a view's readings may scatter about the sphere (RMS, in multiples of what the depth noise
# explains) for the refinement to take the sphere unasked: 1.0 to 1.03 on the simulator; a real
# inflatable globe (TUM RGB-D, Kinect-class) 1.45, and the correction, which takes the scatter for
# the camera's noise, would put its radius 5 mm larger
SCATTER_AUTO = 1.25
# from this many frames on, how well a plane is known, as reported (here and by the refinement of
# the surfaces), also comes from the spread of the planes each frame alone gives (the fits' own
# estimates are 2.5 to 3 times too small); the refinement's refusals keep to the fit's own (the
# overlap's geometry)
SCATTER_FRAMES = 3
FIT_ITERATIONS = 20
FIT_SETTLED = 1e-8           # metres


class NotASphere(CalibrationError):
    """The object is not a sphere that every view sees.

    The refinement then compares the views' surfaces.
    """


@dataclass(frozen=True)
class SpherePlanes:
    """Planes from the sphere's centres.

    Attributes
    ----------
    planes : dict of int to Plane
        {mirror j (1-based): plane}.
    shift_std : dict of int to float
        {j: metres}, 1 sigma along its normal at `centre`.
    tilt_std : dict of int to float
        {j: degrees}, 1 sigma in tilt.
    radius : float
        Metres.
    centre : (3,) array
        Metres, the sphere's centre seen directly (mean over the frames).
    frames : int
        Frames used.
    """

    planes: dict[int, Plane]
    shift_std: dict[int, float]
    tilt_std: dict[int, float]
    radius: float
    centre: np.ndarray
    frames: int


def sphere_planes(rig: Rig, depths: np.ndarray, masks: np.ndarray, mirrors: list[int],
                  rng: np.random.Generator,
                  progress: Progress | None = None, cancel=None,
                  max_scatter: float = np.inf) -> SpherePlanes:
    """Find the planes of mirrors from the sphere seen directly and in each of them, over frames.

    The rig labels the pixels (its boundaries and its planes as they are); its planes give only the
    sides of the new ones.

    Parameters
    ----------
    rig : Rig
    depths : (F, H, W) float array
        Metres as measured.
    masks : (F, H, W) bool array
        Each frame's object.
    mirrors : list of int
        1-based.
    rng : numpy.random.Generator
    progress : Progress, optional
        progress(fraction) after each frame.
    cancel : optional
        Stops it with Cancelled when it asks to.
    max_scatter : float
        The most a view's readings may scatter about the sphere, in RMS multiples of what the depth
        noise explains (SCATTER_AUTO when the object was not said to be a sphere: a ball that is not
        round).

    Returns
    -------
    SpherePlanes

    Raises
    ------
    NotASphere
        Naming the frame and the view, when a view sees too little of the object, the object is not
        a sphere, or it scatters more than max_scatter.
    Cancelled
    """
    views = [0, *mirrors]
    fits, radii = [], []
    for k, (depth, mask) in enumerate(zip(depths, masks)):
        if cancel_requested(cancel):
            raise Cancelled("refinement cancelled")
        readings, start = _view_readings(rig, depth, mask, views, k)
        x0, scales = _plain_fit(readings, start, rig.intrinsics.fx)
        for j, scale in zip(views, scales):
            if scale > max_scatter ** 2:
                name = "the camera" if j == 0 else rig.mirrors[j - 1].name
                raise NotASphere(f"frame {k}: the readings of {name} scatter about the sphere "
                                 f"{np.sqrt(scale):.2f} "
                                 f"times what the depth noise explains (at most {max_scatter}): "
                                 "not a round ball, "
                                 "or a camera noisier than the model")
        x, spread = _debiased_fit(readings, x0, scales, rng)
        fits.append((x, spread))
        radii.append(x[-1])
        if progress is not None:
            progress((k + 1) / len(depths))
    centre = np.mean([x[:3] for x, _ in fits], axis=0)
    planes, shift_std, tilt_std = {}, {}, {}
    for i, j in enumerate(mirrors, start=1):
        side = rig.mirrors[j - 1].plane
        each = [_bisector(x[:3], x[3 * i:3 * i + 3], side) for x, _ in fits]
        planes[j] = _mean_plane(each, centre)
        shift_std[j], tilt_std[j] = _plane_std(each, [spread[i - 1] for _, spread in fits], centre)
    return SpherePlanes(planes, shift_std, tilt_std, float(np.mean(radii)), centre, len(fits))


def _view_readings(rig: Rig, depth: np.ndarray, mask: np.ndarray, views: list[int], frame: int
                   ) -> tuple[list[tuple[np.ndarray, np.ndarray]], np.ndarray]:
    """Each view's readings on the sphere as measured (a mirror's virtual, behind its glass): [(rays
    (n, 3) float64, unit-depth directions (x/z, y/z, 1); depths (n,) float64 metres)] in the order
    of `views`, and a start for their joint fit ((3 k + 1,) float64 metres: each view's own sphere's
    centre, their median radius). NotASphere when a view sees fewer than MIN_POINTS readings, fewer
    than ON_SPHERE of them on its own sphere, or when the radii differ."""
    cloud = reconstruct_raw(rig, depth, mask)
    flat = np.asarray(depth, np.float64).reshape(-1)
    out, spheres = [], []
    for j in views:
        pixels = cloud.pixel_index[cloud.sources == j]
        name = "the camera" if j == 0 else rig.mirrors[j - 1].name
        if len(pixels) < MIN_POINTS:
            raise NotASphere(f"frame {frame}: {name} sees {len(pixels)} readings of the object, "
                             f"{MIN_POINTS} are "
                             "needed to find a sphere's centre")
        x_rays, y_rays = (r.reshape(-1)[pixels] for r in rig.intrinsics.rays)
        rays = np.column_stack([x_rays, y_rays, np.ones(len(pixels))]).astype(np.float64)
        z = flat[pixels]
        on, sphere = _on_sphere(rays * z[:, None], z,
                                f"frame {frame}: the object is not a sphere in the view of {name}")
        out.append((rays[on], z[on]))
        spheres.append(sphere)
    radii = [s.radius for s in spheres]
    if max(radii) > (1 + RADII_AGREE) * min(radii):
        raise NotASphere(
            f"frame {frame}: the views see spheres of different radii ({1e3 * min(radii):.0f} to "
                         f"{1e3 * max(radii):.0f} mm): not one sphere")
    return out, np.concatenate([*(s.centre for s in spheres), [np.median(radii)]])


def _on_sphere(points: np.ndarray, z: np.ndarray, refusal: str) -> tuple[np.ndarray, Sphere]:
    """A view's own sphere (RANSAC, fitting.fit_sphere, on at most DETECT_POINTS of its points,
    evenly spread) -> (the points within INLIER_SIGMAS of the depth noise of it: (n,) bool; the
    sphere). points (n, 3), z (n,) metres. NotASphere (`refusal` and why) without one of
    RADIUS_RANGE, or with fewer than ON_SPHERE on it."""
    threshold = max(INLIER_SIGMAS * float(axial_sigma(np.median(z))), MIN_THRESHOLD)
    sample = points[::max(len(points) // DETECT_POINTS, 1)]
    try:
        sphere = fit_sphere(sample, np.random.default_rng(0), threshold, radius_range=RADIUS_RANGE,
                            max_iterations=RANSAC_ITERATIONS).shape
    except MirrorscanError:
        low, high = (round(1e3 * r) for r in RADIUS_RANGE)
        raise NotASphere(
            f"{refusal} (no sphere of radius {low} to {high} mm fits its readings)") from None
    on = np.abs(sphere.deviations(points)) <= threshold
    if on.mean() < ON_SPHERE:
        raise NotASphere(
            f"{refusal} (only {100 * on.mean():.0f} % of its readings lie on the best sphere, "
                         f"{100 * ON_SPHERE:.0f} % are needed)")
    return on, sphere


def _joint_fit(groups: list[np.ndarray], start: np.ndarray) -> np.ndarray:
    """One sphere per view with a common radius, least squares on the distances (Gauss-Newton on the
    normal equations, a 4 x 4 block per view): groups [(n_k, 3) float64 metres] -> (3 k + 1,)
    float64 [centre of each view..., radius], from `start` (the same layout)."""
    x = start.copy()
    for _ in range(FIT_ITERATIONS):
        normal, gradient = np.zeros((len(x), len(x))), np.zeros(len(x))
        for k, points in enumerate(groups):
            offsets = points - x[3 * k:3 * k + 3]
            distance = np.linalg.norm(offsets, axis=1)
            block = np.column_stack([-offsets / distance[:, None], -np.ones(len(points))])
            columns = [3 * k, 3 * k + 1, 3 * k + 2, len(x) - 1]
            normal[np.ix_(columns, columns)] += block.T @ block
            gradient[columns] += block.T @ (distance - x[-1])
        step = -np.linalg.solve(normal, gradient)
        x += step
        if np.abs(step).max() < FIT_SETTLED:
            break
    return x


def _plain_fit(readings: list[tuple[np.ndarray, np.ndarray]], start: np.ndarray, fx: float
               ) -> tuple[np.ndarray, list[float]]:
    """The joint fit of one frame's views as measured, from `start` (_view_readings) -> (x (3 k +
    1,) float64 metres, [centres..., radius]; each view's noise scale, _noise_scale; fx pixels)."""
    x0 = _joint_fit([r * z[:, None] for r, z in readings], start)
    return x0, [_noise_scale(r, z, x0[3 * k:3 * k + 3], x0[-1], fx) for k,
                (r, z) in enumerate(readings)]


def _debiased_fit(readings: list[tuple[np.ndarray, np.ndarray]], x0: np.ndarray,
                  scales: list[float],
                  rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """SIMEX of the joint fit over one frame's views, from its plain fit x0 and the views' noise
    scales (_plain_fit) -> (x (3 k + 1,) float64 metres, [centres..., radius] taken back to no
    noise; spread (k - 1, 2) float64: for each mirror's view (the views after the camera's), the
    standard deviation over the repeats at noise level 1 of its plane's offset (metres) and tilt
    (radians), the fit's own noise)."""
    means, level_one = [x0], []
    for level in SIMEX_LEVELS:
        repeats = [_joint_fit([r * _noisier(z, level * scale, rng)[:, None] for (r, z),
                               scale in zip(readings, scales)],
                              x0) for _ in range(SIMEX_REPEATS)]
        means.append(np.mean(repeats, axis=0))
        level_one = repeats if level == 1.0 else level_one
    trend = np.polyfit([0.0, *SIMEX_LEVELS], np.asarray(means), 2)
    return trend[0] - trend[1] + trend[2], _repeat_spread(level_one, len(readings))


def _noise_scale(rays: np.ndarray, z: np.ndarray, centre: np.ndarray, radius: float,
                 fx: float) -> float:
    """How noisy a view's readings are in depth, as a multiple of the variance noise.axial_sigma
    gives: the mean square of their distances to the fitted sphere, less what a lateral uncertainty
    of readings.LATERAL_PX explains (a neighbour's depth read: it moves a reading along the surface
    more than off it), over the depth noise along the sphere's normal; where the rays meet the
    sphere within 60 degrees of its normal. On the simulator 1.0 to 1.05 with the Kinect v1's noise
    (1.1 without the lateral term), 0.3 with its quantisation alone, 0 for exact readings
    (which then need no correction). fx : the focal length, pixels."""
    points = rays * z[:, None]
    offsets = points - centre
    distance = np.linalg.norm(offsets, axis=1)
    cos = np.abs(np.sum(points * offsets, axis=1)) / (np.linalg.norm(points, axis=1) * distance)
    near = cos > 0.5
    if not near.any():
        return 1.0
    lateral = LATERAL_PX * z[near] / fx * np.sqrt(1.0 - cos[near] ** 2)
    depth = axial_sigma(z[near]) * cos[near]
    return max(float(np.sum((distance[near] - radius) ** 2 - lateral ** 2) / np.sum(depth ** 2)),
               0.0)


def _noisier(z: np.ndarray, level: float, rng: np.random.Generator) -> np.ndarray:
    """Depths (n,) metres with `level` times their own noise variance added in the disparity (1 /
    z), as a structured-light camera's noise is: noise.axial_sigma(z) / z^2 per reading."""
    return 1.0 / (1.0 / z + rng.standard_normal(len(z)) * np.sqrt(level) * axial_sigma(z) / z ** 2)


def _repeat_spread(repeats: list[np.ndarray], views: int) -> np.ndarray:
    """(views - 1, 2): per mirror's view, the std over the repeats of its plane's offset (metres, at
    the first repeat's direct centre) and of its normal's direction (radians, _normal_spread)."""
    at = repeats[0][:3]
    out = []
    for i in range(1, views):
        planes = [_bisector(x[:3], x[3 * i:3 * i + 3], None) for x in repeats]
        out.append((np.std([p.signed_distance(at) for p in planes], ddof=1),
                    _normal_spread(planes)))
    return np.asarray(out)


def _normal_spread(planes: list[Plane]) -> float:
    """Radians: the standard deviation of the planes' normals along the direction they scatter
    most."""
    return float(np.sqrt(np.linalg.eigvalsh(np.cov(np.array([p.n for p in planes]).T)).max()))


def _bisector(direct: np.ndarray, virtual: np.ndarray, side: Plane | None) -> Plane:
    """The plane that reflects `virtual` (3,) onto `direct` (3,): their perpendicular bisector, its
    normal on the side of `side`'s (or towards the direct centre without one)."""
    n = direct - virtual
    n /= np.linalg.norm(n)
    if side is not None and n @ side.n < 0:
        n = -n
    return Plane.from_point_normal((direct + virtual) / 2, n)


def _mean_plane(planes: list[Plane], centre: np.ndarray) -> Plane:
    """The mean of frames' planes: the mean normal, at the mean offset at `centre` (3,) metres."""
    n = np.mean([p.n for p in planes], axis=0)
    n /= np.linalg.norm(n)
    offset = float(np.mean([p.signed_distance(centre) for p in planes]))
    return Plane.from_abcd([*n, offset - float(n @ centre)])


def _plane_std(planes: list[Plane], spreads: list[np.ndarray], centre: np.ndarray) -> tuple[
    float, float]:
    """How well the mean plane is known: (metres along its normal at `centre`, degrees), the larger
    of the frames' own noise (their SIMEX repeats' spread) and, from SCATTER_FRAMES frames on, the
    spread of their planes, over the square root of the number of frames."""
    root = np.sqrt(len(planes))
    shift, tilt = np.sqrt(np.mean(np.square(spreads), axis=0))
    if len(planes) >= SCATTER_FRAMES:
        shift = max(shift, float(np.std([p.signed_distance(centre) for p in planes], ddof=1)))
        tilt = max(tilt, _normal_spread(planes))
    return float(shift / root), float(np.degrees(tilt) / root)
