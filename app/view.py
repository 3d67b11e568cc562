"""One tab's 3D scene: the depth camera, each mirror (a translucent pane) and the virtual cameras of
the mirrors and of their sequences, each named; the live cloud (one node per source, float16 offsets
from a centre, in the source's colour or each point's), and the dense result in a layer of its own
(its own colours, a label, its box). Every node belongs to the tab's client, so each tab shows and
streams only what it looks at."""
from __future__ import annotations

import threading

import numpy as np
import viser
import viser.transforms as tf

from mirrorcore.base.palette import source_colour, source_name
from mirrorcore.rig.model import Rig

from .densedraw import draw_dense
from .results import DenseResult
from .placement import (CAMERA_LABEL, FRUSTUM_SCALE, SEQUENCE_FONT, beside_offset, box_edges,
                        frustum_angles, frustum_scale, home_pose, label_anchor, mirror_outline,
                        same_place, scene_points, virtual_label_anchor, virtual_label_sides)
from .stream import SourcePart

__all__ = ["HEAT_DIRECT_SIZE", "TabScene", "beside_offset", "home_pose", "label_anchor",
           "same_place", "scene_points"]

# the heat map's points seen directly, as large as the point size times this
HEAT_DIRECT_SIZE = 0.5
BOX_COLOUR = (90, 90, 90)


class TabScene:
    """Owns one tab's scene nodes: /camera, /mirrors/<id>/..., /cloud/<source>, /dense/...

    Parameters
    ----------
    client : viser.ClientHandle
        The tab.
    point_size : float, optional
        The live cloud's point size (metres).
    """

    def __init__(self, client: viser.ClientHandle, point_size: float = 0.006):
        self.client, self.scene = client, client.scene
        self.point_size = point_size
        # (source, half) -> node
        self._clouds: dict[tuple[int, int], viser.PointCloudHandle] = {}
        # the stream thread adds nodes while GUI callbacks restyle them
        self._clouds_lock = threading.Lock()
        self.clouds_visible = True
        self._labels: list[viser.LabelHandle] = []
        # labels, virtual cameras and box: redrawn by the frames' and the session's threads while
        # GUI callbacks show or hide them
        self._marks_lock = threading.RLock()
        self._dense: list = []                     # the dense result's nodes (result, label)
        self._dense_lock = threading.Lock()
        self._virtual: list = []                   # the virtual cameras' frusta
        self._virtual_labels: list[viser.LabelHandle] = []    # the virtual cameras' names
        self.virtual_visible = True
        self._box = None
        self._box_label = None
        self.labels_visible = True
        self.scene.set_up_direction("-y")

    def show_rig(self, rig: Rig, mirror_ids: tuple[int, ...]) -> None:
        """(Re)draw the camera and the calibrated mirrors, each in its id's colour; clouds are kept.

        Parameters
        ----------
        rig : Rig
            The camera and the mirrors' planes.
        mirror_ids : tuple of int
            The ids of `rig.mirrors`, in order.
        """
        intr = rig.intrinsics
        fov, aspect = frustum_angles(intr)
        # The camera too: viser's add_* writes a node's pose after registering it, so two threads
        # must not re-add /camera at once.
        with self._marks_lock:
            self.scene.add_camera_frustum("/camera", fov, aspect, scale=FRUSTUM_SCALE,
                                          color=(60, 60, 60))
            self.scene.remove_by_name("/mirrors")
            self._labels = [self.scene.add_label("/mirrors/camera", "depth camera",
                                                 position=CAMERA_LABEL,
                                                 visible=self.labels_visible)]
            for mirror, mirror_id in zip(rig.mirrors, mirror_ids):
                outline = mirror_outline(intr, mirror)
                if outline is None:
                    continue
                colour = tuple(int(c) for c in source_colour(1, (mirror_id,)))
                faces = np.array([[0, k, k + 1] for k in range(1, len(outline) - 1)],
                                 dtype=np.uint32)
                self.scene.add_mesh_simple(f"/mirrors/{mirror_id}/glass",
                                           outline.astype(np.float32), faces, color=colour,
                                           opacity=0.2, side="double")
                self._labels.append(self.scene.add_label(f"/mirrors/{mirror_id}/label", mirror.name,
                                                         position=label_anchor(outline),
                                                         visible=self.labels_visible))
            self._show_virtual_cameras(rig, mirror_ids, fov, aspect)

    def _show_virtual_cameras(self, rig: Rig, mirror_ids: tuple[int, ...], fov: float,
                              aspect: float) -> None:
        """Draw the camera as each mirror and sequence of mirrors shows it (rig.virtual_cameras).

        The views Algorithm 1 and the dense methods use, in their source's colour, those through
        several mirrors smaller, each named after its view ('camera in left', 'camera in left then
        right').
        """
        self.scene.remove_by_name("/virtual")
        self.scene.remove_by_name("/virtual_labels")
        self._virtual, self._virtual_labels = [], []
        names = [m.name for m in rig.mirrors]
        cameras = [camera for camera in rig.virtual_cameras() if camera.sequence]
        for camera in cameras:
            colour = tuple(int(c) for c in source_colour(camera.source, mirror_ids))
            self._virtual.append(self.scene.add_camera_frustum(
                f"/virtual/{camera.source}", fov, aspect, scale=frustum_scale(camera), color=colour,
                wxyz=tf.SO3.from_matrix(camera.pose[:3, :3]).wxyz, position=camera.pose[:3, 3],
                visible=self.virtual_visible and self.labels_visible))
        groups = same_place(cameras)
        for group, side in zip(groups, virtual_label_sides([group[0] for group in groups])):
            first = group[0]
            self._virtual_labels.append(self.scene.add_label(
                f"/virtual_labels/{first.source}",
                "camera in " + " · in ".join(source_name(camera.source, names)
                                             for camera in group),
                position=virtual_label_anchor(first), anchor=side,
                font_screen_scale=1.0 if len(first.sequence) == 1 else SEQUENCE_FONT,
                visible=self.virtual_visible and self.labels_visible))

    def show_virtual_cameras(self, visible: bool) -> None:
        """Show or hide the virtual cameras' frusta and names (shown only while the labels are).

        Parameters
        ----------
        visible : bool
        """
        with self._marks_lock:
            self.virtual_visible = visible
            for handle in self._virtual + self._virtual_labels:
                handle.visible = visible and self.labels_visible

    def show_labels(self, visible: bool) -> None:
        """Show or hide the names of the camera, the mirrors, the virtual cameras and the dense box.

        The virtual cameras' frusta go with their names (those shown); they are hidden while the
        depth frame is in view.

        Parameters
        ----------
        visible : bool
        """
        with self._marks_lock:
            self.labels_visible = visible
            for label in self._labels + ([self._box_label] if self._box_label is not None else []):
                label.visible = visible
            for handle in self._virtual_labels + self._virtual:
                handle.visible = visible and self.virtual_visible

    def show_cloud(self, parts: list[SourcePart], mirror_ids: tuple[int, ...],
                   half: int | None = None) -> None:
        """Update the live cloud's nodes, one per source and half, placed at the part's centre.

        Nodes of sources beyond the parts are removed.

        Parameters
        ----------
        parts : list of SourcePart
            The live cloud's parts.
        mirror_ids : tuple of int
            The mirrors' ids, which set the sources' colours.
        half : int or None, optional
            Update only this half, or both (None).
        """
        # always in this order: never a deadlock
        with self._clouds_lock, self.client.atomic():
            for part in parts:
                if half is None or part.half == half:
                    self._show_part(part, mirror_ids)
            sources = {p.source for p in parts}
            for key in [k for k in self._clouds if k[0] not in sources]:
                self._clouds.pop(key).remove()

    def _show_part(self, part: SourcePart, mirror_ids: tuple[int, ...]) -> None:
        """Update one part's node in place, or add it (again, when its precision changed)."""
        handle = self._clouds.get(part.key)
        precision = "float16" if part.offsets.dtype == np.float16 else "float32"
        colours = (source_colour(part.source, mirror_ids) if part.colours is None
                   else part.colours)
        if handle is not None and handle.precision == precision:
            # points and colours in one batch (the caller's atomic()): their counts always agree
            handle.points = part.offsets
            handle.colors = colours
            # a kept centre (mirrorscan.stream.Anchors): no update
            if not np.array_equal(handle.position, part.centre):
                handle.position = tuple(part.centre)
            return
        if handle is not None:
            handle.remove()
        self._clouds[part.key] = self.scene.add_point_cloud(
            f"/cloud/{part.source}/{part.half}", part.offsets, colours, point_size=self.point_size,
            precision=precision, point_shape="circle", position=tuple(part.centre),
            visible=self.clouds_visible)

    def show_heat(self, points: np.ndarray | None, colours: np.ndarray | None,
                  direct: np.ndarray | None = None) -> None:
        """Show a frame's points coloured one by one (the heat map of the calibration), or none.

        Parameters
        ----------
        points : (n, 3) ndarray or None
            Metres; None removes the heat map.
        colours : (n, 3) uint8 ndarray or None
        direct : (n,) bool ndarray, optional
            The points the camera sees directly, drawn HEAT_DIRECT_SIZE as large, so that the
            mirrors' colours show between them where both views see the surface.
        """
        if points is None:
            self.scene.remove_by_name("/heat")
            return
        direct = np.zeros(len(points), bool) if direct is None else np.asarray(direct, bool)
        points = np.asarray(points, np.float32)
        self.scene.add_point_cloud("/heat", np.ascontiguousarray(points[~direct]),
                                   colours[~direct], point_size=self.point_size,
                                   precision="float32", point_shape="circle")
        self.scene.add_point_cloud("/heat/direct", np.ascontiguousarray(points[direct]),
                                   colours[direct], point_size=self.point_size * HEAT_DIRECT_SIZE,
                                   precision="float32", point_shape="circle")

    def recolour(self, mirror_ids: tuple[int, ...]) -> None:
        """Colour each cloud node by its mirror's id (after mirrors were removed or reordered).

        Parameters
        ----------
        mirror_ids : tuple of int
            The mirrors' ids in session order.
        """
        with self._clouds_lock:
            for (source, _), handle in self._clouds.items():
                # a node in true colour keeps its points' colours
                if handle.colors.shape == (3,):
                    handle.colors = source_colour(source, mirror_ids)

    def show_clouds(self, visible: bool) -> None:
        """Show or hide the live cloud.

        Parameters
        ----------
        visible : bool
        """
        self.clouds_visible = visible
        with self._clouds_lock:
            for handle in self._clouds.values():
                handle.visible = visible

    def set_point_size(self, size: float) -> None:
        """Set the live cloud's point size.

        Parameters
        ----------
        size : float
            Metres.
        """
        self.point_size = size
        with self._clouds_lock:
            for handle in self._clouds.values():
                handle.point_size = size

    def show_dense(self, result: DenseResult | None, visible: bool, beside: bool) -> None:
        """The dense result (mirrorscan.densedraw), with a label, or nothing.

        Parameters
        ----------
        result : DenseResult or None
            None removes it.
        visible : bool
            Whether it is shown.
        beside : bool
            Place it beside the live cloud (towards the camera and to the left, clear of the
            mirrors) rather than at its place.
        """
        # a DenseChanged event and a GUI callback may both call it
        with self._dense_lock:
            self._replace_dense(result, visible, beside)

    def _replace_dense(self, result: DenseResult | None, visible: bool, beside: bool) -> None:
        """Remove the dense result's nodes and draw `result`, if any."""
        if self._dense:
            # the frame, and the result and label under it
            self._dense[0].remove()
        self._dense = []
        if result is None:
            return
        shift = beside_offset(result) if beside else np.zeros(3)
        frame = self.scene.add_frame("/dense", show_axes=False, position=tuple(shift),
                                     visible=visible)
        node = draw_dense(self.scene, "/dense/result", result)
        top = np.array([(result.low[0] + result.high[0]) / 2, result.low[1],
                        (result.low[2] + result.high[2]) / 2])
        label = self.scene.add_label("/dense/label", f"dense: {result.method}", position=top)
        self._dense = [frame, node, label]

    def show_dense_layer(self, visible: bool) -> None:
        """Show or hide the dense result (and its label).

        Parameters
        ----------
        visible : bool
        """
        with self._dense_lock:
            if self._dense:
                self._dense[0].visible = visible

    def show_box(self, low: np.ndarray | None, high: np.ndarray | None) -> None:
        """The dense reconstruction's box as a wireframe, or none.

        Named at its bottom corner nearest the camera on the left (the mirrors' and virtual cameras'
        names stand above the cloud, the result's own label at the middle of its top).

        Parameters
        ----------
        low, high : np.ndarray, shape (3,), or None
            Its opposite corners (metres); None, or `high` not above `low` on every axis, removes
            it.
        """
        with self._marks_lock:
            if self._box is not None:
                # the box, with its label under it
                self._box.remove()
                self._box = self._box_label = None
            if low is None or high is None or not np.all(np.asarray(high) > np.asarray(low)):
                return
            low, high = np.asarray(low, float), np.asarray(high, float)
            # its 12 edges as line segments (a wireframe box would also draw its faces' diagonals)
            self._box = self.scene.add_line_segments(
                "/dense_box", box_edges((high - low) / 2), BOX_COLOUR,
                thickness=2.0, thickness_units="screen", position=tuple((low + high) / 2))
            # -x, down (+y), -z
            corner = (low - high) / 2 * (1.0, -1.0, 1.0)
            self._box_label = self.scene.add_label("/dense_box/label", "dense box",
                                                   visible=self.labels_visible,
                                                   position=tuple(corner))
