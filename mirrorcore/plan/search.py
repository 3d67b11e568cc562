"""The search for a rig's layout (docs/planning.md, "The search"): the hand-made layouts first (a
symmetric V, or an arc, over their angle, reach and the camera's tilt; coarse samples) and a compass
search of the best; then differential evolution (scipy) from it over every mirror's place, turn,
lean, height and size and the camera's tilt (finer samples); a mirror left seeing almost nothing
placed anew; each result judged on many samples at the end.

A layout's score puts coverage first, then the overlap between views, then low noise:
coverage + OVERLAP_WEIGHT * coverage_2 - NOISE_WEIGHT * mean noise in mm; a layout that breaks a
limit (mirrorcore.plan.layout) scores below every layout that keeps them.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.optimize import differential_evolution

from mirrorcore.base.errors import Cancelled, MirrorscanError
from mirrorcore.base.progress import Progress, Ratchet, cancel_requested
from mirrorcore.plan.coverage import Coverage, CoverageModel, Glass
from mirrorcore.plan.layout import CLEARANCE, PER_MIRROR, TILT_LIMIT, LayoutSpace
from mirrorcore.plan.setup import PlanCamera, PlanRoom
from mirrorcore.plan.subject import Subject, make_subject, sample_surface

OVERLAP_WEIGHT = 0.1       # 10 points of overlap weigh as 1 point of coverage
NOISE_WEIGHT = 0.0005      # 1 mm of mean noise weighs as 0.05 points of coverage
# a mirror whose views see less than this share of the surface is placed anew (_revive)
IDLE_SHARE = 0.01
# metres the subject keeps from the room's walls, and from the camera beyond its nearest depth
_WALL_MARGIN = 0.3


@dataclass(frozen=True)
class SearchSettings:
    """How hard the search looks (plan.json's `search`).

    Attributes
    ----------
    coarse_samples, fine_samples, final_samples : int
        Surface samples for the hand-made layouts, the evolution and the final figures.
    generations : int
        The most generations of differential evolution.
    population : int
        Its population per entry of the vector (scipy's popsize).
    seed : int
    """

    coarse_samples: int = 1000
    fine_samples: int = 2500
    final_samples: int = 20000
    generations: int = 20
    population: int = 5
    seed: int = 0

    def to_json(self) -> dict:
        """plan.json's `search` settings."""
        return {**asdict(self), "overlap_weight": OVERLAP_WEIGHT, "noise_weight": NOISE_WEIGHT}


@dataclass(frozen=True, eq=False)
class PlanResult:
    """A searched layout and the best hand-made one, judged on the final samples.

    Attributes
    ----------
    spec : str
        The subject's SPEC.
    space : LayoutSpace
    x : (1 + 7 m,) array
        The plan's vector (x[0] the camera's tilt, degrees).
    coverage : Coverage
    hand_made : (float, float, float, float)
        The best hand-made layout: the camera's tilt and the V's angle (degrees), its apex's
        reach behind the subject and the mirrors' shift from the apex (metres); or the arc's
        tilt, span, radius and 0 for three or more mirrors (LayoutSpace.hand_made).
    hand_made_coverage : Coverage
    camera : PlanCamera
    bounces : int
    settings : SearchSettings
    """

    spec: str
    space: LayoutSpace
    x: np.ndarray
    coverage: Coverage
    hand_made: tuple[float, float, float, float]
    hand_made_coverage: Coverage
    camera: PlanCamera
    bounces: int
    settings: SearchSettings

    @property
    def glass(self) -> Glass:
        """The plan's mirrors, level frame."""
        return self.space.glass(self.x)

    @property
    def tilt(self) -> float:
        """The camera's tilt down, degrees."""
        return float(self.x[0])


def score(cov: Coverage) -> float:
    """A layout's score (see the module docstring)."""
    return cov.coverage + OVERLAP_WEIGHT * cov.coverage_2 - NOISE_WEIGHT * cov.mean_noise_mm()


def _objective(space: LayoutSpace, model: CoverageModel, x: np.ndarray) -> float:
    """The value differential evolution minimises: -score, or 1 + the violation."""
    bad = space.violation(x)
    if bad > 0:
        return 1.0 + bad
    return -score(model.evaluate(space.glass(x), float(x[0])))


def subject_distances(spec: str, room: PlanRoom, camera: PlanCamera,
                      distance: float | None) -> list[Subject]:
    """The subject at the given distance, or at three distances the room allows.

    Parameters
    ----------
    spec : str
    room : PlanRoom
    camera : PlanCamera
    distance : float or None
        Metres from the camera to the subject's middle.

    Returns
    -------
    list of Subject

    Raises
    ------
    MirrorscanError
        The room cannot hold the subject with room for mirrors behind it.
    """
    probe = make_subject(spec, 1.0, room.floor_y)
    reach, tall = probe.radius, probe.height
    far = room.depth - reach - _WALL_MARGIN - CLEARANCE
    near = max(camera.min_depth + reach, reach + _WALL_MARGIN)
    if tall > room.height or 2 * (reach + CLEARANCE) > room.width or far < near:
        raise MirrorscanError(
            f"--room: {room.width:g} x {room.depth:g} x {room.height:g} m cannot hold the subject "
            f"({2 * reach:.2f} m wide, {tall:.2f} m tall) with mirrors around it")
    if distance is not None:
        if not near <= distance <= far:
            raise MirrorscanError(f"--distance: the subject fits {near:.2f} to {far:.2f} m from "
                                  f"the camera in this room, got {distance:g}")
        return [make_subject(spec, distance, room.floor_y)]
    return [make_subject(spec, float(d), room.floor_y)
            for d in np.linspace(near, near + 0.6 * (far - near), 3)]


def _hand_made_grid(space: LayoutSpace) -> list[tuple[float, float, float, float]]:
    """The hand-made layouts tried (tilt, angle, reach, shift): angles, reaches, shifts, tilts."""
    c = space.subject.centre
    aim = float(np.degrees(np.arctan2(c[1], c[2])))
    tilts = np.clip([aim - 8.0, aim, aim + 8.0], -TILT_LIMIT, TILT_LIMIT)
    back = space.room.depth - c[2]
    low = space.subject.radius + CLEARANCE
    if space.mirrors == 2:
        angles, shifts = np.arange(60.0, 171.0, 10.0), (0.0, 0.3)
    else:
        angles, shifts = np.arange(60.0, 241.0, 20.0), (0.0,)
    layouts = []
    for angle in angles:
        lowest = low / np.sin(np.radians(angle) / 2) if space.mirrors == 2 else low + 0.05
        for reach in np.linspace(lowest, max(back, lowest), 5):
            layouts += [(float(t), float(angle), float(reach), s) for t in tilts for s in shifts]
    return layouts


def _refine_hand_made(space: LayoutSpace, model: CoverageModel,
                      params: tuple[float, float, float, float]) -> tuple[float, ...]:
    """A compass search of a hand-made layout's (tilt, angle, reach, shift), halving the steps."""
    best = np.array(params)
    value = _objective(space, model, space.hand_made(*best))
    steps = np.array([4.0, 5.0, 0.1, 0.1 if space.mirrors == 2 else 0.0])
    for _ in range(3):
        moved = True
        while moved:
            moved = False
            for k in np.flatnonzero(steps):
                for sign in (-1.0, 1.0):
                    trial = best.copy()
                    trial[k] += sign * steps[k]
                    if trial[3] < 0:
                        continue
                    v = _objective(space, model, space.hand_made(*trial))
                    if v < value:
                        best, value, moved = trial, v, True
        steps /= 2
    return tuple(float(p) for p in best)


def plan_rig(spec: str, mirrors: int, size: tuple[float, float], room: PlanRoom,
             camera: PlanCamera, distance: float | None = None, bounces: int = 1,
             settings: SearchSettings = SearchSettings(), progress: Progress | None = None,
             cancel=None, start: np.ndarray | None = None) -> PlanResult:
    """Search the layout that sees most of the subject (see the module docstring).

    Parameters
    ----------
    spec : str
        The subject (mirrorcore.plan.subject.parse_spec).
    mirrors : int
    size : (float, float)
        The largest mirror, width and height, metres.
    room : PlanRoom
    camera : PlanCamera
    distance : float, optional
        Metres from the camera to the subject; searched over three when None.
    bounces : int
        The most mirrors a view goes through in turn.
    settings : SearchSettings
    progress : Progress, optional
    cancel : threading.Event-like or callable, optional
    start : (1 + 7 m,) array, optional
        A layout to search from (LayoutSpace's vector; needs `distance`): the evolution starts
        around it instead of the best hand-made layout, and the plan is the best of the three.

    Returns
    -------
    PlanResult

    Raises
    ------
    MirrorscanError
        A bad SPEC, a room that cannot hold the subject, no hand-made layout that fits, a
        `start` without a `distance`.
    Cancelled
        When `cancel` asks to stop.
    """
    if start is not None and distance is None:
        raise MirrorscanError("a plan from a given layout needs the subject's distance")
    bar = Ratchet(progress, 0.1)
    subjects = subject_distances(spec, room, camera, distance)
    best = None
    for k, subject in enumerate(subjects):
        space = LayoutSpace(mirrors, size, room, subject, camera)
        model = CoverageModel(subject, sample_surface(subject, settings.coarse_samples,
                                                      settings.seed), camera, bounces)
        grid = _hand_made_grid(space)
        for i, params in enumerate(grid):
            if i % 50 == 0:
                if cancel_requested(cancel):
                    raise Cancelled("the plan's search was cancelled")
                bar(0.25 * (k + i / len(grid)) / len(subjects))
            value = _objective(space, model, space.hand_made(*params))
            if value < 0 and (best is None or value < best[0]):
                best = (value, space, params)
    if best is None:
        raise MirrorscanError(f"--mirror-size: no layout of {mirrors} mirrors of {size[0]:g} x "
                              f"{size[1]:g} m fits this room around the subject")
    _, space, params = best
    subject = space.subject
    fine = CoverageModel(subject, sample_surface(subject, settings.fine_samples,
                                                 settings.seed + 1), camera, bounces)
    params = _refine_hand_made(space, fine, params)
    made = space.hand_made(*params)
    bar(0.3)
    x = _evolve(space, fine, made if start is None else start, settings, bar, cancel)
    x = _revive(space, fine, x, settings, cancel)
    final = CoverageModel(subject, sample_surface(subject, settings.final_samples,
                                                  settings.seed + 2), camera, bounces)
    planned = final.evaluate(space.glass(x), float(x[0]))
    hand = final.evaluate(space.glass(made), float(made[0]))
    given = [] if start is None or space.violation(start) > 0 else [np.asarray(start, float)]
    for other in [made] + given:
        cov = hand if other is made else final.evaluate(space.glass(other), float(other[0]))
        if score(cov) > score(planned):
            x, planned = other, cov
    bar(1.0)
    return PlanResult(spec, space, np.asarray(x), planned, params, hand, camera, bounces, settings)


def _evolve(space: LayoutSpace, model: CoverageModel, start: np.ndarray,
            settings: SearchSettings, bar: Ratchet, cancel) -> np.ndarray:
    """Differential evolution from a population around `start`; its best vector."""
    bounds = np.array(space.bounds())
    rng = np.random.default_rng(settings.seed)
    count = settings.population * len(bounds)
    spread = 0.08 * (bounds[:, 1] - bounds[:, 0])
    init = np.clip(start + rng.normal(size=(count, len(bounds))) * spread, bounds[:, 0],
                   bounds[:, 1])
    init[0] = np.clip(start, bounds[:, 0], bounds[:, 1])
    generation = [0]
    stopped = [False]

    def step(intermediate_result) -> bool:
        generation[0] += 1
        bar(0.3 + 0.65 * generation[0] / settings.generations)
        stopped[0] = cancel_requested(cancel)
        return stopped[0]

    result = differential_evolution(
        lambda x: _objective(space, model, x), bounds, init=init, maxiter=settings.generations,
        seed=settings.seed, polish=False, tol=1e-3, updating="deferred", callback=step)
    if stopped[0]:
        raise Cancelled("the plan's search was cancelled")
    return result.x


def _revive(space: LayoutSpace, model: CoverageModel, x: np.ndarray, settings: SearchSettings,
            cancel) -> np.ndarray:
    """Place anew each mirror that sees (almost) nothing: differential evolution over that
    mirror's seven numbers alone, the others held, from a population spread over the whole room.
    """
    bounds = np.array(space.bounds())
    x = np.array(x, dtype=np.float64)
    cov = model.evaluate(space.glass(x), float(x[0]))
    for j in range(space.mirrors):
        shares = [share for view, share in zip(cov.views, cov.per_view) if j in view]
        if max(shares) >= IDLE_SHARE:
            continue
        part = slice(1 + PER_MIRROR * j, 1 + PER_MIRROR * (j + 1))

        def value(y: np.ndarray, part: slice = part) -> float:
            trial = x.copy()
            trial[part] = y
            return _objective(space, model, trial)

        result = differential_evolution(
            value, bounds[part], popsize=settings.population * 2, maxiter=settings.generations,
            seed=settings.seed, polish=False, tol=1e-3, x0=np.clip(x[part], *bounds[part].T),
            callback=lambda intermediate_result: cancel_requested(cancel))
        if cancel_requested(cancel):
            raise Cancelled("the plan's search was cancelled")
        if result.fun < value(x[part]):
            x[part] = result.x
    return x
