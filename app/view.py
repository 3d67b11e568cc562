"""The 3D scene in the browser: the depth camera, each mirror (translucent quad and virtual camera), and the live
merged cloud as one point cloud per source in the source colours."""
from __future__ import annotations

import numpy as np
import viser
import viser.transforms as tf

from mirrorcore.cloud import Cloud
from mirrorcore.geometry.camera import Intrinsics, pixels_on_plane
from mirrorcore.palette import source_colour, source_name
from mirrorcore.rig import Rig

MAX_POINTS = 60_000        # points sent to the browser per frame (evenly strided), all sources together
FRUSTUM_SCALE = 0.25       # metres


def frustum_angles(intr: Intrinsics) -> tuple[float, float]:
    """(vertical field of view in radians, aspect ratio) of a camera."""
    return 2 * np.arctan2(intr.height / 2, intr.fy), intr.width / intr.height


def downsample(cloud: Cloud, max_points: int) -> Cloud:
    """Every k-th point so that at most max_points remain (the order is row-major, so this thins evenly)."""
    step = max(1, int(np.ceil(len(cloud) / max_points)))
    return cloud if step == 1 else cloud.select(slice(None, None, step))


def initial_view(rig: Rig) -> tuple[np.ndarray, np.ndarray]:
    """(camera position, look-at point) in metres for a newly opened tab: above, to the right of and a little in front
    of the object, so that its front (direct) and back (mirrors) both show; the object is taken to stand in front of
    the mirrors (on the optical axis at 2 m without mirrors)."""
    centres = [pixels_on_plane(rig.intrinsics, m.boundary, m.plane).mean(axis=0)
               for m in rig.mirrors if m.plane is not None and m.boundary is not None]
    centres = [c for c in centres if np.all(np.isfinite(c))]
    target = 0.85 * np.mean(centres, axis=0) if centres else np.array([0.0, 0.0, 2.0])
    return target + np.array([2.2, -1.2, -1.4]), target


class SceneView:
    """Owns the scene nodes: /camera, /mirrors/<j>/..., /cloud/<source>."""

    def __init__(self, server: viser.ViserServer):
        self.server = server
        self.point_size = 0.006
        self._clouds: dict[int, viser.PointCloudHandle] = {}
        server.scene.set_up_direction("-y")

    def show_rig(self, rig: Rig) -> None:
        """(Re)draw the camera and the mirrors of a rig; the cloud nodes are kept."""
        scene, intr = self.server.scene, rig.intrinsics
        fov, aspect = frustum_angles(intr)
        scene.add_camera_frustum("/camera", fov, aspect, scale=FRUSTUM_SCALE, color=(40, 40, 40))
        self.home = initial_view(rig)
        scene.remove_by_name("/mirrors")
        for j, mirror in enumerate(rig.mirrors, start=1):
            if mirror.plane is None or mirror.boundary is None:
                continue
            colour = tuple(int(c) for c in source_colour(j))
            outline = pixels_on_plane(intr, mirror.boundary, mirror.plane)
            if not np.all(np.isfinite(outline)):
                continue
            faces = np.array([[0, k, k + 1] for k in range(1, len(outline) - 1)], dtype=np.uint32)
            scene.add_mesh_simple(f"/mirrors/{j}/glass", outline.astype(np.float32), faces, color=colour,
                                  opacity=0.25, side="double")
            pose = mirror.plane.virtual_camera_pose()
            scene.add_camera_frustum(f"/mirrors/{j}/virtual_camera", fov, aspect, scale=FRUSTUM_SCALE, color=colour,
                                     wxyz=tf.SO3.from_matrix(pose[:3, :3]).wxyz, position=pose[:3, 3])
            scene.add_label(f"/mirrors/{j}/label", mirror.name, position=outline[np.argmin(outline[:, 1])])

    def show_cloud(self, cloud: Cloud, n_sources: int) -> None:
        """Replace the live cloud: one node per source (0..n_sources-1), downsampled to MAX_POINTS in all."""
        cloud = downsample(cloud, MAX_POINTS)
        with self.server.atomic():
            for j in range(n_sources):
                part = cloud.points[cloud.sources == j]
                handle = self._clouds.get(j)
                if handle is None:
                    self._clouds[j] = self.server.scene.add_point_cloud(
                        f"/cloud/{source_name(j).replace(' ', '_')}", np.ascontiguousarray(part),
                        tuple(int(c) for c in source_colour(j)), point_size=self.point_size, precision="float32",
                        point_shape="circle")
                else:
                    handle.points = np.ascontiguousarray(part)
            for j in [k for k in self._clouds if k >= n_sources]:
                self._clouds.pop(j).remove()

    def look_from_home(self, client: viser.ClientHandle) -> None:
        """Point a tab's camera at the rig (see initial_view), with -y up as in the camera frame."""
        position, target = self.home
        client.camera.up_direction = (0.0, -1.0, 0.0)
        client.camera.position = tuple(position)
        client.camera.look_at = tuple(target)

    def set_point_size(self, size: float) -> None:
        self.point_size = size
        for handle in self._clouds.values():
            handle.point_size = size
