"""The simulated rig as a depth source: Simulator renders frames (30 fps, animated objects) with the
sensor model, and their colour images (sim.albedo)."""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.sim.albedo import NOISE_OFFSETS, ColourModel
from mirrorcore.sim.render import MAX_BOUNCES, GroundTruth, Renderer
from mirrorcore.sim.scene import Scene
from mirrorcore.sim.sensor import SensorModel

FPS = 30.0


@dataclass(frozen=True)
class SimFrame:
    """One simulated frame.

    Attributes
    ----------
    depth : (H, W) float32 array
        Metres as the sensor reports it, 0 = no reading.
    truth : GroundTruth
        The ideal view behind it (ideal depth, surfaces, mirrors, real points).
    t : float
        Its time, seconds.
    painter : ColourModel
        The scene's colours, for `colour`.
    noise_offset : int or None
        Where the frame's colour noise starts in the painter's table (None: no noise).
    """

    depth: np.ndarray
    truth: GroundTruth
    t: float
    painter: ColourModel = field(repr=False, compare=False)
    noise_offset: int | None = None

    @cached_property
    def colour(self) -> np.ndarray:
        """(H, W, 3) uint8 RGB on the depth pixel grid: the ideal view's albedo times the tints
        of the mirrors on each ray, plus the colour camera's noise (sim.albedo), made when first
        asked for."""
        return self.painter.image(self.truth, self.noise_offset)


class Simulator:
    """A depth camera and mirrors in a simulated scene, ray cast and passed through a sensor model.

    Parameters
    ----------
    scene : Scene
    sensor : SensorModel, optional
        Default Kinect v1 with noise.
    seed : int
        Frame i draws its noise from np.random.default_rng([seed, i]), so frames are reproducible
        in any order.
    bounces : int
        The most reflections a rendered ray may make (1 to MAX_BOUNCES, see Renderer).
    fps : float
        Frame rate of `frame(i)` (time i / fps).
    """

    def __init__(self, scene: Scene, sensor: SensorModel | None = None, seed: int = 0,
                 bounces: int = MAX_BOUNCES,
                 fps: float = FPS):
        self.scene = scene
        self.sensor = SensorModel.kinect_v1() if sensor is None else sensor
        self.seed = int(seed)
        self.fps = float(fps)
        self._renderer = Renderer(scene, bounces)

    @property
    def intrinsics(self) -> Intrinsics:
        """The scene's camera."""
        return self.scene.camera

    @property
    def planes(self) -> tuple[Plane, ...]:
        """The true mirror planes, session order, docs/DESIGN.md convention."""
        return tuple(m.plane for m in self.scene.mirrors)

    @cached_property
    def painter(self) -> ColourModel:
        """The colour images of the scene's renders (made when first asked for)."""
        return ColourModel(self.scene, self._renderer.render(0.0, with_objects=False),
                           self.sensor.colour_sigma, self.seed)

    @property
    def animated(self) -> bool:
        """True when an object moves (frames differ beyond noise)."""
        return self._renderer.animated

    def render(self, t: float, rng: np.random.Generator, with_objects: bool = True) -> SimFrame:
        """Return the frame at a time.

        Parameters
        ----------
        t : float
            Seconds.
        rng : numpy.random.Generator
            The noise's source.
        with_objects : bool
            False leaves the objects out.

        Returns
        -------
        SimFrame
        """
        truth = self._renderer.render(t, with_objects)
        depth = self.sensor.apply(self.intrinsics, truth.depth, rng)
        # drawn after the depth's noise, which stays as it is without colour
        offset = int(rng.integers(NOISE_OFFSETS)) if self.sensor.colour_sigma > 0 else None
        return SimFrame(depth, truth, float(t), self.painter, offset)

    def frame(self, i: int) -> SimFrame:
        """Return frame i at time i / fps, reproducible from (seed, i).

        Parameters
        ----------
        i : int
            0-based.

        Returns
        -------
        SimFrame
        """
        return self.render(i / self.fps, np.random.default_rng([self.seed, 0, int(i)]))

    def background(self) -> SimFrame:
        """The scene without its objects (for background subtraction), reproducible from seed."""
        return self.render(0.0, np.random.default_rng([self.seed, 1]), with_objects=False)
