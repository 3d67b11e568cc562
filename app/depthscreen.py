"""The depth frame as a clickable screen in one tab's 3D scene (viser's GUI images take no clicks):
an image node standing behind the depth camera, facing the same way, so that pixel (u, v) sits at
the screen's local (x, y)."""
from __future__ import annotations

from typing import Callable

import numpy as np
import viser

from mirrorcore.geometry.camera import Intrinsics

SCREEN_DISTANCE = 1.5   # metres behind the depth camera
SCREEN_HEIGHT = 1.2     # metres
VIEW_FOV_DEG = 50.0     # the tab's vertical field of view when it looks at the screen
MARGIN = 1.04           # the frame fills the free area but for this much room around it


class DepthScreen:
    """Shows an RGB rendering of the depth frame in one tab and reports its clicks as pixels.

    The image's local x runs with u and its local y with v (viser draws row 0 at local -y); with the
    identity rotation at (0, 0, -SCREEN_DISTANCE), it is seen unmirrored from behind, looking along
    +z like the depth camera.

    Parameters
    ----------
    client : viser.ClientHandle
    intr : Intrinsics
        The depth camera's.
    on_pixel : callable
        Called with (u, v) of each click on the screen.
    """

    def __init__(self, client: viser.ClientHandle, intr: Intrinsics,
                 on_pixel: Callable[[float, float], None]):
        self.client, self.intr, self.on_pixel = client, intr, on_pixel
        self.height = SCREEN_HEIGHT
        self.width = SCREEN_HEIGHT * intr.width / intr.height
        self.centre = np.array([0.0, 0.0, -SCREEN_DISTANCE])
        blank = np.zeros((intr.height, intr.width, 3), np.uint8)
        self.handle = client.scene.add_image("/depth_frame", blank, self.width, self.height,
                                             format="jpeg", jpeg_quality=85,
                                             position=tuple(self.centre), visible=False)
        self.handle.on_click(self._clicked)

    def set_visible(self, visible: bool) -> None:
        """Show the screen while the tab looks at it.

        Hidden in the 3D view, where it would stand behind the camera when zoomed out. Its image is
        still refreshed, so that it is current when looked at.

        Parameters
        ----------
        visible : bool
        """
        self.handle.visible = visible

    def show(self, rgb: np.ndarray) -> None:
        """Show an image on the screen.

        Parameters
        ----------
        rgb : np.ndarray, shape (H, W, 3), uint8
        """
        self.handle.image = rgb

    def pixel_of_ray(self, origin, direction) -> tuple[float, float] | None:
        """Where a ray meets the screen, as pixel coordinates.

        Parameters
        ----------
        origin, direction : array_like, shape (3,)
            The ray, world frame.

        Returns
        -------
        tuple of float or None
            (u, v), or None when it misses.
        """
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
        """The world point of a pixel on the screen (the inverse of pixel_of_ray).

        Parameters
        ----------
        u, v : float
            Pixels.

        Returns
        -------
        np.ndarray, shape (3,)
            Metres.
        """
        x = ((u + 0.5) / self.intr.width - 0.5) * self.width
        y = ((v + 0.5) / self.intr.height - 0.5) * self.height
        return self.centre + np.array([x, y, 0.0])

    def view_pose(self, aspect: float) -> tuple[np.ndarray, np.ndarray]:
        """Where the tab's camera sees the whole depth frame: squarely behind the screen, centred.

        Parameters
        ----------
        aspect : float
            The tab's canvas, width / height; the view is VIEW_FOV_DEG high.

        Returns
        -------
        position, look_at : np.ndarray, shape (3,)
            Metres.
        """
        tan_half = np.tan(np.radians(VIEW_FOV_DEG) / 2)
        distance = MARGIN * max(self.height / 2 / tan_half, self.width / 2 / (tan_half * aspect))
        return self.centre - np.array([0.0, 0.0, distance]), self.centre.copy()

    def look_at(self) -> None:
        """Put the tab's camera at view_pose() for its canvas."""
        camera = self.client.camera
        try:
            aspect = camera.image_width / max(camera.image_height, 1)
        # the tab has not reported its canvas yet
        except Exception:  # noqa: BLE001
            aspect = 16 / 9
        position, target = self.view_pose(aspect)
        with self.client.atomic():
            camera.fov = np.radians(VIEW_FOV_DEG)
            camera.up_direction = (0.0, -1.0, 0.0)
            camera.position = tuple(position)
            camera.look_at = tuple(target)

    def _clicked(self, event) -> None:
        """Report a click on the screen as a pixel, when the ray meets it."""
        pixel = self.pixel_of_ray(event.ray_origin, event.ray_direction)
        if pixel is not None:
            self.on_pixel(*pixel)
