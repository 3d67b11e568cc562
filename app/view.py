"""One tab's 3D scene: the depth camera, each mirror (a translucent pane) and the virtual cameras of the mirrors and
of their sequences, each named; the live cloud (one node per source, float16 offsets from a centre), and the dense
result in a layer of its own (its own colours, a label, its box). Every node belongs to the tab's client, so each
tab shows and streams only what it looks at."""
from __future__ import annotations

import threading

import numpy as np
import viser
import viser.transforms as tf

from mirrorcore.geometry.camera import Intrinsics, pixels_on_plane
from mirrorcore.base.palette import source_colour, source_name
from mirrorcore.rig.model import Rig

from .results import DenseResult
from .stream import SourcePart

FRUSTUM_SCALE = 0.15       # metres: the depth camera and the virtual cameras, drawn small
VIRTUAL_LABEL_RISE = 1.2   # a virtual camera's name this many of its frustum's sizes above it: seen from home, above
                           # the mirror's name (2.5 sizes under it, as it was, sat on the walking figure's head)
HEAT_DIRECT_SIZE = 0.5     # the heat map's points seen directly, as large as the point size times this
SAME_PLACE = 0.10          # metres: virtual cameras closer than this share one label (hinged mirrors at 360 / n
                           # degrees put images through two and three mirrors within a few cm: 1.3 to 5.4 measured)
DENSE_COLOUR = (120, 200, 190)   # the dense result's own colour (a pale teal, unlike any source)
BOX_COLOUR = (90, 90, 90)
HOME_DIRECTION = np.array([0.0, -0.9, -1.4])    # from the scene's centre towards the first view (right, up, front):
                                                # from behind the depth camera, 33 degrees from above, so that every
                                                # virtual camera is in view (seen from the right, 45 degrees round,
                                                # the right mirror's was behind the panel: helpers) and above the
                                                # object (at 24 degrees, over its top)
CAMERA_LABEL = (0.0, FRUSTUM_SCALE, 0.0)   # metres: the depth camera's name, under it (y down)
MIN_DISTANCE = 0.3         # metres: the first view stands at least this far from what it frames
SEQUENCE_FONT = 0.85       # a virtual camera's name through several mirrors, this much smaller: they stand between
                           # the others, and full size two of them ran into each other at 1024x600 (a helper)


def frustum_angles(intr: Intrinsics) -> tuple[float, float]:
    """(vertical field of view in radians, aspect ratio) of a camera."""
    return 2 * np.arctan2(intr.height / 2, intr.fy), intr.width / intr.height


def same_place(cameras: list) -> list[list]:
    """Virtual cameras (rig.virtual_cameras' items) grouped by place: each group those within SAME_PLACE of its
    first, in the given order."""
    groups: list[list] = []
    for camera in cameras:
        for group in groups:
            if np.linalg.norm(group[0].pose[:3, 3] - camera.pose[:3, 3]) < SAME_PLACE:
                group.append(camera)
                break
        else:
            groups.append([camera])
    return groups


def _frustum_scale(camera) -> float:
    """Metres: a virtual camera through one mirror drawn as large as the depth camera, through several smaller."""
    return FRUSTUM_SCALE * (1.0 if len(camera.sequence) == 1 else 0.7)


def mirror_outline(intr: Intrinsics, mirror) -> np.ndarray | None:
    """(b, 3) metres: a calibrated mirror's boundary lifted onto its plane, or None."""
    if mirror.plane is None or mirror.boundary is None:
        return None
    outline = pixels_on_plane(intr, mirror.boundary, mirror.plane)
    return outline if np.all(np.isfinite(outline)) else None


def label_anchor(outline: np.ndarray) -> np.ndarray:
    """(3,) metres: where a mirror's name goes, the middle of its outline's two highest corners (up is -y): the top
    edge's middle for a pane, and apart for two mirrors hinged at a shared top corner. outline : (b, 3) metres."""
    return outline[np.argsort(outline[:, 1], kind="stable")[:2]].mean(axis=0)


def virtual_label_anchor(camera) -> np.ndarray:
    """(3,) metres: where a virtual camera's name goes (rig.virtual_cameras' item): VIRTUAL_LABEL_RISE of its
    frustum's size above it (along -y of its pose, the camera's up: a vertical mirror keeps it the world's), or as
    far below it for a camera through several mirrors (on four mirrors their names had stacked on those of the
    cameras through one beside them: a helper)."""
    rise = VIRTUAL_LABEL_RISE * _frustum_scale(camera) * (-1.0 if len(camera.sequence) > 1 else 1.0)
    return camera.pose[:3, 3] - rise * camera.pose[:3, 1]          # up is -y


def virtual_label_sides(cameras: list) -> list[str]:
    """Which corner of each virtual camera's name (rig.virtual_cameras' items) sits at its anchor (viser's label
    anchor, see virtual_label_anchor): centred on the camera, but the leftmost's runs right and the rightmost's left,
    towards the rig (centred, those ran off the 3D view; run inwards from every camera beyond the mirrors, the names
    of the cameras between ran into each other: helpers)."""
    xs = [float(camera.pose[0, 3]) for camera in cameras]
    sides = ["center"] * len(xs)
    if xs:
        left, right = int(np.argmin(xs)), int(np.argmax(xs))
        if xs[left] < 0:
            sides[left] = "left"
        if xs[right] > 0:
            sides[right] = "right"
    return [("top-" if len(camera.sequence) > 1 else "bottom-") + side for camera, side in zip(cameras, sides)]


def scene_points(rig: Rig) -> np.ndarray:
    """(k, 3) metres: the points the first view must show, the camera and its name, the mirrors' corners, where the
    object is expected (in front of the mirrors, on the optical axis at 2 m without them), and the virtual cameras
    with their names' anchors."""
    outlines = [o for o in (mirror_outline(rig.intrinsics, m) for m in rig.mirrors) if o is not None]
    points = [np.array([(0.0, 0.0, 0.0), CAMERA_LABEL])] + outlines
    centres = [o.mean(axis=0) for o in outlines]
    points.append((0.85 * np.mean(centres, axis=0) if centres else np.array([0.0, 0.0, 2.0]))[None])
    cameras = [camera for camera in rig.virtual_cameras() if camera.sequence]
    points += [np.array([camera.pose[:3, 3], virtual_label_anchor(camera)]) for camera in cameras]
    return np.concatenate(points)


def box_edges(half: np.ndarray) -> np.ndarray:
    """(12, 2, 3) float32: the edges of a box centred at the origin with half-sizes `half` (3,) metres."""
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    pairs = [(i, j) for i in range(8) for j in range(i + 1, 8) if np.count_nonzero(corners[i] != corners[j]) == 1]
    return (corners[np.array(pairs)] * np.asarray(half, float)).astype(np.float32)


def beside_offset(result: DenseResult) -> np.ndarray:
    """(3,) metres: where the dense result is drawn beside the live cloud, one box width to the left (-x) and one box
    depth towards the camera (-z), with 10 cm between."""
    size = np.asarray(result.high) - np.asarray(result.low)
    return np.array([-(size[0] + 0.1), 0.0, -(size[2] + 0.1)])


def home_pose(points: np.ndarray, fov: float, aspect: float, margin: float = 1.1) -> tuple[np.ndarray, np.ndarray]:
    """(camera position, look-at point) in metres that frame `points` (k, 3) for a view of vertical field of view
    `fov` (radians) and `aspect` (width / height), up -y: looking from HOME_DIRECTION at the middle of their bounding
    box, as near as keeps every point inside the view's middle 1 / `margin` (its bounding sphere, as before, left the
    rig half as large once the virtual cameras were framed too)."""
    centre = (points.min(axis=0) + points.max(axis=0)) / 2
    direction = HOME_DIRECTION / np.linalg.norm(HOME_DIRECTION)
    right = np.cross(-direction, [0.0, -1.0, 0.0])
    right /= np.linalg.norm(right)
    down = np.cross(-direction, right)
    half_height = np.tan(fov / 2) / margin
    offsets = points - centre
    # a point at `offsets` is in view from `distance` along `direction` when its sideways offset is within the
    # half-width times its depth (distance - offsets . direction)
    needed = np.maximum(np.abs(offsets @ right) / (half_height * aspect), np.abs(offsets @ down) / half_height)
    distance = max(float(np.max(needed + offsets @ direction)), MIN_DISTANCE)
    return centre + distance * direction, centre


class TabScene:
    """Owns one tab's scene nodes: /camera, /mirrors/<id>/..., /cloud/<source>, /dense/..."""

    def __init__(self, client: viser.ClientHandle, point_size: float = 0.006):
        self.client, self.scene = client, client.scene
        self.point_size = point_size
        self._clouds: dict[tuple[int, int], viser.PointCloudHandle] = {}    # (source, half) -> node
        self._clouds_lock = threading.Lock()    # the stream thread adds nodes while GUI callbacks restyle them
        self.clouds_visible = True
        self._labels: list[viser.LabelHandle] = []
        self._marks_lock = threading.RLock()    # labels, virtual cameras and box: redrawn by the frames' and the
                                                # session's threads while GUI callbacks show or hide them
        self._dense: list = []                     # the dense result's nodes (result, label)
        self._dense_lock = threading.Lock()
        self._virtual: list = []                   # the virtual cameras' frusta
        self._virtual_labels: list[viser.LabelHandle] = []    # and their names
        self.virtual_visible = True
        self._box = None
        self._box_label = None
        self.labels_visible = True
        self.scene.set_up_direction("-y")

    def show_rig(self, rig: Rig, mirror_ids: tuple[int, ...]) -> None:
        """(Re)draw the camera and the calibrated mirrors, each in the colour of its id; the clouds are kept."""
        intr = rig.intrinsics
        fov, aspect = frustum_angles(intr)
        with self._marks_lock:     # and the camera: viser's add_* writes a node's pose after registering it, so
                                   # two threads re-adding /camera at once failed ('on a removed CameraFrustumHandle')
            self.scene.add_camera_frustum("/camera", fov, aspect, scale=FRUSTUM_SCALE, color=(60, 60, 60))
            self.scene.remove_by_name("/mirrors")
            self._labels = [self.scene.add_label("/mirrors/camera", "depth camera", position=CAMERA_LABEL,
                                                 visible=self.labels_visible)]   # with the names
            for mirror, mirror_id in zip(rig.mirrors, mirror_ids):
                outline = mirror_outline(intr, mirror)
                if outline is None:
                    continue
                colour = tuple(int(c) for c in source_colour(1, (mirror_id,)))
                faces = np.array([[0, k, k + 1] for k in range(1, len(outline) - 1)], dtype=np.uint32)
                self.scene.add_mesh_simple(f"/mirrors/{mirror_id}/glass", outline.astype(np.float32), faces,
                                           color=colour, opacity=0.2, side="double")
                self._labels.append(self.scene.add_label(f"/mirrors/{mirror_id}/label", mirror.name,
                                                         position=label_anchor(outline),
                                                         visible=self.labels_visible))
            self._show_virtual_cameras(rig, mirror_ids, fov, aspect)

    def _show_virtual_cameras(self, rig: Rig, mirror_ids: tuple[int, ...], fov: float, aspect: float) -> None:
        """The camera as each mirror, and each sequence of mirrors, shows it (rig.virtual_cameras): the views
        Algorithm 1 and the dense methods use, in their source's colour, those through several mirrors smaller, each
        named after its view ('camera in left', 'camera in left then right')."""
        self.scene.remove_by_name("/virtual")
        self.scene.remove_by_name("/virtual_labels")
        self._virtual, self._virtual_labels = [], []
        names = [m.name for m in rig.mirrors]
        cameras = [camera for camera in rig.virtual_cameras() if camera.sequence]
        for camera in cameras:
            colour = tuple(int(c) for c in source_colour(camera.source, mirror_ids))
            self._virtual.append(self.scene.add_camera_frustum(
                f"/virtual/{camera.source}", fov, aspect, scale=_frustum_scale(camera), color=colour,
                wxyz=tf.SO3.from_matrix(camera.pose[:3, :3]).wxyz, position=camera.pose[:3, 3],
                visible=self.virtual_visible and self.labels_visible))
        groups = same_place(cameras)
        for group, side in zip(groups, virtual_label_sides([group[0] for group in groups])):
            first = group[0]
            self._virtual_labels.append(self.scene.add_label(
                f"/virtual_labels/{first.source}",
                "camera in " + " · in ".join(source_name(camera.source, names) for camera in group),
                position=virtual_label_anchor(first), anchor=side,
                font_screen_scale=1.0 if len(first.sequence) == 1 else SEQUENCE_FONT,
                visible=self.virtual_visible and self.labels_visible))

    def show_virtual_cameras(self, visible: bool) -> None:
        with self._marks_lock:
            self.virtual_visible = visible
            for handle in self._virtual + self._virtual_labels:
                handle.visible = visible and self.labels_visible

    def show_labels(self, visible: bool) -> None:
        """Show or hide the names of the camera, the mirrors, the virtual cameras (those shown, and their frusta) and
        the dense box (hidden while the depth frame is in view: no label over it, and no frustum above it: a
        helper)."""
        with self._marks_lock:
            self.labels_visible = visible
            for label in self._labels + ([self._box_label] if self._box_label is not None else []):
                label.visible = visible
            for handle in self._virtual_labels + self._virtual:
                handle.visible = visible and self.virtual_visible

    def show_cloud(self, parts: list[SourcePart], mirror_ids: tuple[int, ...], half: int | None = None) -> None:
        """Update the live cloud's nodes (one per source and half, placed at the part's centre) from `parts`: only
        the given half, or both (None); nodes of sources beyond the parts are removed."""
        with self._clouds_lock, self.client.atomic():      # always in this order: never a deadlock
            for part in parts:
                if half is None or part.half == half:
                    self._show_part(part, mirror_ids)
            sources = {p.source for p in parts}
            for key in [k for k in self._clouds if k[0] not in sources]:
                self._clouds.pop(key).remove()

    def _show_part(self, part: SourcePart, mirror_ids: tuple[int, ...]) -> None:
        handle = self._clouds.get(part.key)
        precision = "float16" if part.offsets.dtype == np.float16 else "float32"
        if handle is not None and handle.precision == precision:
            handle.points = part.offsets
            if not np.array_equal(handle.position, part.centre):    # a kept centre (app.stream.Anchors): no update
                handle.position = tuple(part.centre)
            return
        if handle is not None:
            handle.remove()
        colour = tuple(int(c) for c in source_colour(part.source, mirror_ids))
        self._clouds[part.key] = self.scene.add_point_cloud(
            f"/cloud/{part.source}/{part.half}", part.offsets, colour, point_size=self.point_size,
            precision=precision, point_shape="circle", position=tuple(part.centre), visible=self.clouds_visible)

    def show_heat(self, points: np.ndarray | None, colours: np.ndarray | None,
                  direct: np.ndarray | None = None) -> None:
        """A frame's points (n, 3) metres coloured one by one (n, 3) uint8 (the heat map of the calibration), or
        none; those the camera sees directly (`direct` (n,) bool) drawn HEAT_DIRECT_SIZE as large, so that the
        mirrors' colours show between them where both views see the surface (drawn alike, the camera's grey hid
        them: a helper saw a strip of pink dots)."""
        if points is None:
            self.scene.remove_by_name("/heat")
            return
        direct = np.zeros(len(points), bool) if direct is None else np.asarray(direct, bool)
        points = np.asarray(points, np.float32)
        self.scene.add_point_cloud("/heat", np.ascontiguousarray(points[~direct]), colours[~direct],
                                   point_size=self.point_size, precision="float32", point_shape="circle")
        self.scene.add_point_cloud("/heat/direct", np.ascontiguousarray(points[direct]), colours[direct],
                                   point_size=self.point_size * HEAT_DIRECT_SIZE, precision="float32",
                                   point_shape="circle")

    def recolour(self, mirror_ids: tuple[int, ...]) -> None:
        """Colour each cloud node by its mirror's id (after mirrors were removed or reordered)."""
        with self._clouds_lock:
            for (source, _), handle in self._clouds.items():
                handle.colors = source_colour(source, mirror_ids)

    def show_clouds(self, visible: bool) -> None:
        self.clouds_visible = visible
        with self._clouds_lock:
            for handle in self._clouds.values():
                handle.visible = visible

    def set_point_size(self, size: float) -> None:
        self.point_size = size
        with self._clouds_lock:
            for handle in self._clouds.values():
                handle.point_size = size

    def show_dense(self, result: DenseResult | None, visible: bool, beside: bool) -> None:
        """The dense result in its own colour, with a label: at its place, or beside the live cloud (towards the
        camera and to the left, clear of the mirrors); or nothing."""
        with self._dense_lock:                         # a DenseChanged event and a GUI callback may both call it
            self._replace_dense(result, visible, beside)

    def _replace_dense(self, result: DenseResult | None, visible: bool, beside: bool) -> None:
        if self._dense:
            self._dense[0].remove()                  # the frame, and the result and label under it
        self._dense = []
        if result is None:
            return
        shift = beside_offset(result) if beside else np.zeros(3)
        frame = self.scene.add_frame("/dense", show_axes=False, position=tuple(shift), visible=visible)
        if result.faces is None:
            node = self.scene.add_point_cloud("/dense/result", result.vertices, DENSE_COLOUR, point_size=result.voxel,
                                              precision="float32")
        else:
            node = self.scene.add_mesh_simple("/dense/result", result.vertices.astype(np.float32),
                                              result.faces.astype(np.uint32), color=DENSE_COLOUR)
        top = np.array([(result.low[0] + result.high[0]) / 2, result.low[1], (result.low[2] + result.high[2]) / 2])
        self._dense = [frame, node, self.scene.add_label("/dense/label", f"dense: {result.method}", position=top)]

    def show_dense_layer(self, visible: bool) -> None:
        """Show or hide the dense result (and its label)."""
        with self._dense_lock:
            if self._dense:
                self._dense[0].visible = visible

    def show_box(self, low: np.ndarray | None, high: np.ndarray | None) -> None:
        """The dense reconstruction's box as a wireframe, named at its bottom corner nearest the camera on the left
        (the mirrors' and virtual cameras' names stand above the cloud, the result's own label at the middle of its
        top), or none."""
        with self._marks_lock:
            if self._box is not None:
                self._box.remove()                      # and its label under it
                self._box = self._box_label = None
            if low is None or high is None or not np.all(np.asarray(high) > np.asarray(low)):
                return
            low, high = np.asarray(low, float), np.asarray(high, float)
            self._box = self.scene.add_line_segments(        # its 12 edges (a wireframe box also draws its faces'
                "/dense_box", box_edges((high - low) / 2), BOX_COLOUR,      # diagonals: it looked broken, a helper)
                thickness=2.0, thickness_units="screen", position=tuple((low + high) / 2))
            corner = (low - high) / 2 * (1.0, -1.0, 1.0)                       # -x, down (+y), -z
            self._box_label = self.scene.add_label("/dense_box/label", "dense box", visible=self.labels_visible,
                                                   position=tuple(corner))
