"""The depth frame as a clickable screen in the 3D scene (viser's GUI images take no clicks): an image node standing
behind the depth camera, facing the same way, so that pixel (u, v) sits at the screen's local (x, y)."""
from __future__ import annotations

from typing import Callable

import numpy as np
import viser

from mirrorcore.geometry.camera import Intrinsics

SCREEN_DISTANCE = 1.5   # metres behind the depth camera
SCREEN_HEIGHT = 1.2     # metres
VIEW_FOV_DEG = 50.0     # the tab's vertical field of view when it looks at the screen
VIEW_SHIFT = 0.12       # of the screen's width: the view looks right of centre, the side panel covers the right


class DepthScreen:
    """Shows an RGB rendering of the depth frame and reports clicks as pixel coordinates.

    The image's local x runs with u and its local y with v (viser draws row 0 at local -y); with the identity rotation
    at (0, 0, -SCREEN_DISTANCE), it is seen unmirrored from behind, looking along +z like the depth camera.
    """

    def __init__(self, server: viser.ViserServer, intr: Intrinsics,
                 on_pixel: Callable[[float, float, viser.ClientHandle], None]):
        self.intr, self.on_pixel = intr, on_pixel
        self.height = SCREEN_HEIGHT
        self.width = SCREEN_HEIGHT * intr.width / intr.height
        self.centre = np.array([0.0, 0.0, -SCREEN_DISTANCE])
        self.handle = server.scene.add_image("/depth_frame", np.zeros((intr.height, intr.width, 3), np.uint8),
                                             self.width, self.height, format="jpeg", position=tuple(self.centre))
        self.handle.on_click(self._clicked)

    def show(self, rgb: np.ndarray) -> None:
        """rgb : (H, W, 3) uint8."""
        self.handle.image = rgb

    def pixel_of_ray(self, origin, direction) -> tuple[float, float] | None:
        """Where a ray (world frame) meets the screen, as pixel coordinates (u, v), or None when it misses."""
        origin, direction = np.asarray(origin, float), np.asarray(direction, float)
        if abs(direction[2]) < 1e-12:
            return None
        t = (self.centre[2] - origin[2]) / direction[2]
        if t <= 0:
            return None
        x, y = (origin + t * direction)[:2] - self.centre[:2]
        u = (x / self.width + 0.5) * self.intr.width - 0.5
        v = (y / self.height + 0.5) * self.intr.height - 0.5
        if not (-0.5 <= u <= self.intr.width - 0.5 and -0.5 <= v <= self.intr.height - 0.5):
            return None
        return float(u), float(v)

    def world_of_pixel(self, u: float, v: float) -> np.ndarray:
        """(3,) world point of pixel (u, v) on the screen (the inverse of pixel_of_ray)."""
        x = ((u + 0.5) / self.intr.width - 0.5) * self.width
        y = ((v + 0.5) / self.intr.height - 0.5) * self.height
        return self.centre + np.array([x, y, 0.0])

    def view_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """(camera position, look-at point), metres: squarely behind the screen, the whole depth frame in view."""
        distance = 0.6 * self.height / np.tan(np.radians(VIEW_FOV_DEG) / 2)
        target = self.centre + np.array([VIEW_SHIFT * self.width, 0.0, 0.0])
        return target - np.array([0.0, 0.0, distance]), target

    def look_at(self, client: viser.ClientHandle) -> None:
        """Put a tab's camera at view_pose()."""
        position, target = self.view_pose()
        client.camera.fov = np.radians(VIEW_FOV_DEG)
        client.camera.up_direction = (0.0, -1.0, 0.0)
        client.camera.position = tuple(position)
        client.camera.look_at = tuple(target)

    def _clicked(self, event) -> None:
        pixel = self.pixel_of_ray(event.ray_origin, event.ray_direction)
        if pixel is not None:
            self.on_pixel(pixel[0], pixel[1], event.client)
