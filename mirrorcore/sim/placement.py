"""Where a technician sticks a mirror's markers: where the camera sees them. A layout puts six
markers near each mirror's corners and edges' middles; on some rigs most of them are hidden (an arc
of three around the walking figure: the middle mirror, raised above the figure, has its upper
markers out of the image and its lower ones behind the mirrors beside it and the figure), and
such a mirror cannot be fitted from its markers. `markers_in_view` moves the hidden ones of such a
mirror to places on its glass that the camera sees, in every moment of the object's motion."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from mirrorcore.geometry.camera import project_points
from mirrorcore.sim.render import MARKER, GroundTruth, Renderer
from mirrorcore.sim.scene import Scene, SceneMirror

# markers a mirror needs in view for a fit: where fewer of a layout's are seen, the hidden move
MIN_SEEN = 3
SPACING = 0.25         # ... this share of the mirror's smaller side from the other markers,
# ... to the nearest of GRID x GRID places over its glass (inset by INSET of each half-side)
GRID = 12
# that the camera sees whole (the pixels within WINDOW of the place all show its glass)
INSET = 0.9
WINDOW = 2
# an animated object is rendered at this many moments of one second (a stride at 1 Hz)
MOMENTS = 4


def markers_in_view(scene: Scene, max_range: float) -> Scene:
    """Move each mirror's markers where the camera sees them.

    A mirror of which fewer than MIN_SEEN markers are seen (within `max_range`, in every moment)
    has each hidden one moved to the nearest place on its glass that is seen, SPACING of its smaller
    side from the others (where none is left, it stays). The other mirrors keep their markers.

    Parameters
    ----------
    scene : Scene
    max_range : float
        Metres.

    Returns
    -------
    Scene
    """
    renderer = Renderer(scene, 1)
    moments = np.arange(MOMENTS) / MOMENTS if renderer.animated else np.zeros(1)
    views = [renderer.render(float(t)) for t in moments]
    mirrors = tuple(_placed(scene, j, mirror, views, max_range) for j,
                    mirror in enumerate(scene.mirrors))
    return replace(scene, mirrors=mirrors)


def _placed(scene: Scene, j: int, mirror: SceneMirror, views: list[GroundTruth],
            max_range: float) -> SceneMirror:
    """Mirror j (0-based) with its hidden markers moved, when fewer than MIN_SEEN are seen."""
    markers = np.asarray(mirror.markers, float).reshape(-1, 2)
    seen = _seen(scene, mirror.marker_centres(), views, max_range, 0,
                 lambda v: (v.surface == MARKER)
                 # at its centre's pixel, as a session's clicks are
                 & (v.first_mirror == 0))
    if np.count_nonzero(seen) >= MIN_SEEN:
        return mirror
    half = INSET * np.array([mirror.width, mirror.height]) / 2
    axis = np.linspace(-1.0, 1.0, GRID)
    grid = np.stack(np.meshgrid(axis * half[0], axis * half[1]), axis=-1).reshape(-1, 2)
    free = grid[_seen(scene, mirror.local_to_camera(grid), views, max_range, WINDOW,
                      lambda v: (v.first_mirror == j + 1) & (v.surface != MARKER))]
    kept = list(markers[seen])
    spacing = SPACING * min(mirror.width, mirror.height)
    for hidden in markers[~seen]:
        apart = np.array([all(np.linalg.norm(q - k) >= spacing for k in kept) for q in free], bool)
        choices = free[apart] if apart.any() else hidden[None]
        kept.append(choices[np.argmin(np.linalg.norm(choices - hidden, axis=1))])
    return replace(mirror, markers=tuple((float(s), float(t)) for s, t in kept))


def _seen(scene: Scene, points: np.ndarray, views: list[GroundTruth], max_range: float, window: int,
          shows) -> np.ndarray:
    """(k,) bool: which points (k, 3) metres, camera frame, lie within max_range metres of depth,
    with the pixels within `window` of theirs inside the image and showing them in every view
    (shows(view) -> (H, W) bool)."""
    camera = scene.camera
    uv, z = project_points(camera, points)
    pix = np.round(uv).astype(int)
    inside = (z > 0) & (z <= max_range) & np.all(pix >= window, axis=1) \
        & (pix[:, 0] < camera.width - window) & (pix[:, 1] < camera.height - window)
    offsets = np.arange(-window, window + 1)
    du, dv = (o.reshape(-1) for o in np.meshgrid(offsets, offsets))
    u = np.clip(pix[:, :1] + du, 0, camera.width - 1)
    v = np.clip(pix[:, 1:] + dv, 0, camera.height - 1)
    return inside & np.all([shows(view)[v, u].all(axis=1) for view in views], axis=0)
