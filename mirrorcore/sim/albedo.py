"""The simulated scene's colour: a shading-free albedo per surface, dimmed and tinted by every
mirror a ray reflected on, on the depth pixel grid.

What is modelled: each object carries a 3-D checker of two known colours (cells CHECKER_M wide in
the object's frame, the hit point minus the object's centre, offset by CHECKER_PHASE), the floor,
the back wall, the markers and the mirrors' backs one colour each, and each mirror reflects a
fraction `tint` (per channel, linear in 8-bit levels) of what it shows. The colour camera adds
Gaussian noise of the sensor model's `colour_sigma` levels to each channel (rounded, drawn afresh
each frame), so that a view a mirror dims reads its colour with less signal to the same noise. No
lighting, shading or exposure; the colour is registered exactly to the ideal depth.
"""
from __future__ import annotations

import numpy as np

from mirrorcore.sim.render import MARKER, MIRROR_BACK, NONE, OBJECT, ROOM, GroundTruth
from mirrorcore.sim.scene import Room, Scene

CHECKER_M = 0.05            # metres: the side of an object's checker cell
# metres: the cells' offset from the object's centre, so that the faces of boxes of round sizes
# do not lie on a cell edge (where the cell would flicker with rounding)
CHECKER_PHASE = 0.0173
# (even cell, odd cell) RGB levels of object i's checker: OBJECT_COLOURS[i % len]
OBJECT_COLOURS = (((200, 60, 40), (235, 205, 70)), ((40, 90, 200), (225, 225, 225)),
                  ((50, 160, 80), (150, 60, 170)))
FLOOR_COLOUR = (110, 100, 85)
WALL_COLOUR = (190, 185, 170)
MARKER_COLOUR = (245, 245, 245)
MIRROR_BACK_COLOUR = (60, 60, 60)
# a frame's colour noise is a window of one table of noise, starting at one of this many offsets
NOISE_OFFSETS = 1 << 16


def object_albedo(index: int, local: np.ndarray) -> np.ndarray:
    """Return the albedo of object `index` at points of its own frame.

    Parameters
    ----------
    index : int
        The object's index in scene.objects.
    local : (k, 3) array
        Metres, the hit points minus the object's centre.

    Returns
    -------
    (k, 3) float32 array
        RGB levels 0 to 255: the even or odd colour of the checker cell the point lies in.
    """
    colours = np.asarray(OBJECT_COLOURS[index % len(OBJECT_COLOURS)], dtype=np.float32)
    cells = np.floor((np.asarray(local) + CHECKER_PHASE) / CHECKER_M).astype(np.int64)
    return colours[cells.sum(axis=-1) % 2]


def room_albedo(points: np.ndarray, room: Room) -> np.ndarray:
    """Return the room's colour at points on its floor or back wall.

    Parameters
    ----------
    points : (k, 3) array
        Metres, camera frame.
    room : Room

    Returns
    -------
    (k, 3) float32 array
        FLOOR_COLOUR where the floor's plane is nearer than the back wall's, else WALL_COLOUR.
    """
    points = np.asarray(points).reshape(-1, 3)
    floor = np.abs(points[:, 1] - room.floor_y) < np.abs(points[:, 2] - room.back_z)
    return np.where(floor[:, None], np.float32(FLOOR_COLOUR), np.float32(WALL_COLOUR))


def surface_albedo(scene: Scene, truth: GroundTruth, pixels: np.ndarray) -> np.ndarray:
    """Return the albedo of the real surface each pixel's ray ends on, before any tint.

    Parameters
    ----------
    scene : Scene
        The scene `truth` is a render of.
    truth : GroundTruth
    pixels : (k,) int array
        Flat (row-major) pixel indices.

    Returns
    -------
    (k, 3) float32 array
        RGB levels 0 to 255: an object's checker at its true hit point
        (`object_albedo(index, point - centre)`), the room's colour (`room_albedo`), the
        markers' and the mirrors' backs' colours; NaN where the ray meets no surface.
    """
    pixels = np.asarray(pixels, np.int64).reshape(-1)
    surface = truth.surface.reshape(-1)[pixels]
    albedo = np.full((len(pixels), 3), np.nan, np.float32)
    albedo[surface == MARKER] = MARKER_COLOUR
    albedo[surface == MIRROR_BACK] = MIRROR_BACK_COLOUR
    room = np.flatnonzero(surface == ROOM)
    if len(room) and scene.room is not None:
        albedo[room] = room_albedo(truth.points_at(pixels[room]), scene.room)
    on_object = np.flatnonzero(surface == OBJECT)
    if len(on_object):
        index = truth.object_index.reshape(-1)[pixels[on_object]]
        points = truth.points_at(pixels[on_object])
        for i, obj in enumerate(scene.objects):
            sel = index == i
            albedo[on_object[sel]] = object_albedo(
                i, points[sel] - np.asarray(obj.centre, np.float32))
    return albedo


def _tints(scene: Scene) -> np.ndarray:
    """(m + 1, 3) float32: row 0 ones (no mirror), row j the tint of mirror j."""
    return np.array([(1.0, 1.0, 1.0), *(m.tint for m in scene.mirrors)], np.float32)


def _gain(tints: np.ndarray, mirrors: np.ndarray) -> np.ndarray:
    """(B, k) mirror sequences (0 = none) -> (k, 3) float32 product of the tints on each ray."""
    gain = np.ones((mirrors.shape[1], 3), np.float32)
    for labels in mirrors:
        if labels.any():
            gain *= tints[labels]
    return gain


def _levels(colour: np.ndarray) -> np.ndarray:
    """Float RGB levels -> uint8, rounded."""
    return np.clip(np.rint(colour), 0, 255).astype(np.uint8)


class ColourModel:
    """The colour images of a scene's renders.

    The background (room, markers, mirrors' backs) does not change, so its image is made once from
    the render without objects; a frame then colours only its object pixels.

    Parameters
    ----------
    scene : Scene
    background : GroundTruth
        The scene rendered without its objects.
    sigma : float
        The colour camera's noise, levels per channel (0: none).
    seed : int
        The noise table's seed.
    """

    def __init__(self, scene: Scene, background: GroundTruth, sigma: float = 0.0, seed: int = 0):
        self.scene = scene
        size = background.depth.size * 3 + NOISE_OFFSETS
        self._noise = (np.rint(np.random.default_rng([seed, 3]).normal(0.0, sigma, size))
                       .astype(np.int16) if sigma > 0 else None)
        self._tints = _tints(scene)
        out = np.zeros((*background.depth.shape, 3), np.float32)
        seen = background.surface != NONE
        out[seen] = surface_albedo(scene, background, np.flatnonzero(seen))
        out[seen] *= _gain(self._tints, background.mirrors[:, seen])
        self._background = _levels(out)

    def image(self, truth: GroundTruth, noise_offset: int | None = None) -> np.ndarray:
        """Return the colour image the camera sees.

        Parameters
        ----------
        truth : GroundTruth
            A render of the scene (with or without its objects).
        noise_offset : int, optional
            Where in the noise table this frame's noise starts, 0 to NOISE_OFFSETS - 1; None
            for none.

        Returns
        -------
        (H, W, 3) uint8 array
            RGB on the depth pixel grid (the `Frame.colour` contract): the albedo of the surface
            each ray ends on times the tints of the mirrors it reflected on, rounded, plus the
            noise; 0 where no surface.
        """
        colour = self._albedo(truth)
        if self._noise is None or noise_offset is None:
            return colour
        noise = self._noise[noise_offset:noise_offset + colour.size].reshape(colour.shape)
        noisy = np.add(colour, noise, dtype=np.int16)
        noisy[truth.surface == NONE] = 0
        return np.clip(noisy, 0, 255).astype(np.uint8)

    def _albedo(self, truth: GroundTruth) -> np.ndarray:
        """(H, W, 3) uint8: `image` without noise."""
        colour = self._background.copy()
        hit = np.flatnonzero(truth.surface.reshape(-1) == OBJECT)
        if len(hit) == 0:
            return colour
        albedo = surface_albedo(self.scene, truth, hit)
        mirrors = truth.mirrors.reshape(len(truth.mirrors), -1)[:, hit]
        colour.reshape(-1, 3)[hit] = _levels(albedo * _gain(self._tints, mirrors))
        return colour
