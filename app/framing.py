"""Where a tab's 3D camera looks: home (the rig and the object), the object, a dense result; and
whether the technician has moved it since."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import viser

from .placement import beside_offset, home_pose, scene_points

# Look at the object: the view's nearer edge is this many radii of the object's bounding sphere
# from its middle (its points are drawn as discs of many pixels at that distance).
OBJECT_MARGIN = 1.6
HOME_TOLERANCE = 0.01   # metres: a camera this near where the home view put it was not moved
FOV_DEG = 50.0          # the vertical field of view the tab's camera is given, degrees

if TYPE_CHECKING:
    from .context import Services


class TabFraming:
    """The framing of a tab's 3D view; mixed into `mirrorscan.tab.Tab`.

    Uses the tab's `client`, `services` (the rig and the last frame) and `dense_beside`.
    """

    client: viser.ClientHandle
    services: Services
    dense_beside: bool
    _home_pose: tuple[np.ndarray, np.ndarray] | None

    def look_home(self) -> None:
        """Frame the rig (camera, mirrors) and where the object is for this tab's canvas."""
        points = np.concatenate([scene_points(self.services.snapshot.rig), self._object_points()])
        self._home_pose = self._frame(points)

    def look_at_object(self) -> None:
        """Fill this tab's canvas with the object's cloud, seen as from home.

        The cloud is the last frame's, all its views; the whole rig when there is no object in view.
        """
        points = self._object_points()
        if len(points) < 2:
            self.look_home()
        else:
            self._frame(points, OBJECT_MARGIN)

    def look_at_dense(self, result) -> None:
        """Fill this tab's canvas with the object's cloud and a dense result, seen as from home.

        Where this tab draws the result: beside the cloud or in place.

        Parameters
        ----------
        result : DenseResult
        """
        offset = beside_offset(result) if self.dense_beside else 0.0
        corners = np.array([result.low, result.high], float) + offset
        self._frame(np.concatenate([self._object_points(), corners]), OBJECT_MARGIN)

    def _object_points(self) -> np.ndarray:
        """About 500 of the last frame's object points, (k, 3) metres; none before the first."""
        frame = self.services.last_frame
        if frame is None or not len(frame.cloud):
            return np.zeros((0, 3))
        return frame.cloud.points[:: max(1, len(frame.cloud) // 500)]

    def _frame(self, points: np.ndarray, margin: float = 1.1) -> tuple[np.ndarray, np.ndarray]:
        """Move this tab's camera to frame `points` for its canvas (view.home_pose).

        Parameters
        ----------
        points : (k, 3) ndarray
            Metres.
        margin : float
            Passed to view.home_pose.

        Returns
        -------
        position, look_at : (3,) ndarray
            Where the camera now is and what it looks at, metres.
        """
        camera = self.client.camera
        try:
            aspect = camera.image_width / max(camera.image_height, 1)
        except AssertionError:            # the tab has not reported its canvas yet
            aspect = 16 / 9
        fov = np.radians(FOV_DEG)
        position, target = home_pose(points, fov, aspect, margin)
        with self.client.atomic():
            camera.fov = fov
            camera.up_direction = (0.0, -1.0, 0.0)
            camera.position = tuple(position)
            camera.look_at = tuple(target)
        return position, target

    def _still_home(self) -> bool:
        """Whether this tab's camera is where look_home last put it, within HOME_TOLERANCE.

        Not turned or zoomed since.
        """
        if self._home_pose is None:
            return False
        try:
            position, look_at = self.client.camera.position, self.client.camera.look_at
        except AssertionError:            # the tab has not reported its camera yet
            return False
        return bool(np.allclose(position, self._home_pose[0], atol=HOME_TOLERANCE)
                    and np.allclose(look_at, self._home_pose[1], atol=HOME_TOLERANCE))
