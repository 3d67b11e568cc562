"""What a plan is made within: the depth camera (intrinsics and depth range) and the room."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.camerafiles import load_open3d_json, load_opencv_yaml

# the Intel RealSense D435's depth stream at 848x480 (87 x 58 degrees), its range for a scan
_D435 = Intrinsics(848, 480, 426.0, 426.0, 423.5, 239.5)
CAMERA_PRESETS = {"kinect_v1": (Intrinsics.kinect_v1(), 0.5, 4.5),
                  "primesense": (Intrinsics.primesense(), 0.5, 4.5),
                  "realsense_d435": (_D435, 0.3, 3.0)}
FILE_DEPTH_RANGE = (0.5, 4.5)    # metres, for a camera given as a file
DEFAULT_ROOM_HEIGHT = 2.5        # metres


@dataclass(frozen=True)
class PlanCamera:
    """A depth camera for planning.

    Attributes
    ----------
    intrinsics : Intrinsics
    min_depth, max_depth : float
        Metres: the depths (z of the point, through the mirrors the virtual point's) it reads.
    """

    intrinsics: Intrinsics
    min_depth: float
    max_depth: float

    def to_json(self) -> dict:
        """plan.json's `camera` object."""
        i = self.intrinsics
        return {"width": i.width, "height": i.height, "fx": i.fx, "fy": i.fy, "cx": i.cx,
                "cy": i.cy, "min_depth": self.min_depth, "max_depth": self.max_depth}


def plan_camera(name: str) -> PlanCamera:
    """Return a preset camera or one read from a file.

    Parameters
    ----------
    name : str
        kinect_v1, primesense, realsense_d435, or an Open3D intrinsics JSON or OpenCV camera YAML
        file (depth range FILE_DEPTH_RANGE).

    Returns
    -------
    PlanCamera

    Raises
    ------
    MirrorscanError
        Neither a preset nor a readable file.
    """
    if name in CAMERA_PRESETS:
        return PlanCamera(*CAMERA_PRESETS[name])
    path = Path(name)
    if not path.is_file():
        raise MirrorscanError(f"--camera: {name!r} is neither kinect_v1, primesense, "
                              "realsense_d435 nor a camera file")
    load = load_opencv_yaml if path.suffix.lower() in (".yaml", ".yml") else load_open3d_json
    return PlanCamera(load(path), *FILE_DEPTH_RANGE)


@dataclass(frozen=True)
class PlanRoom:
    """The room a rig must fit in, around a camera standing level in it.

    Attributes
    ----------
    width : float
        Metres, centred on the camera (x from -width / 2 to width / 2).
    depth : float
        Metres from the camera forward (z from 0 to depth).
    height : float
        Metres from the floor up.
    camera_height : float
        Metres from the floor to the camera (the floor is y = camera_height).
    """

    width: float
    depth: float
    height: float
    camera_height: float

    @property
    def floor_y(self) -> float:
        """The floor's y, metres (level frame)."""
        return self.camera_height

    @property
    def ceiling_y(self) -> float:
        """The ceiling's y, metres (level frame)."""
        return self.camera_height - self.height

    def to_json(self) -> dict:
        """plan.json's `room` object."""
        return {"width": self.width, "depth": self.depth, "height": self.height,
                "camera_height": self.camera_height}


def parse_room(text: str, camera_height: float) -> PlanRoom:
    """Read `--room W,D[,H]` (metres).

    Parameters
    ----------
    text : str
    camera_height : float
        Metres.

    Returns
    -------
    PlanRoom

    Raises
    ------
    MirrorscanError
        Not two or three positive numbers, or a camera above the ceiling.
    """
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) not in (2, 3) or not all(0 < v <= 100 for v in values):
        raise MirrorscanError(f"--room: {text!r} must be W,D or W,D,H in metres (0 to 100)")
    height = values[2] if len(values) == 3 else DEFAULT_ROOM_HEIGHT
    if not 0 < camera_height < height:
        raise MirrorscanError(f"--camera-height: {camera_height:g} m must be above the floor and "
                              f"below the room's {height:g} m ceiling")
    return PlanRoom(values[0], values[1], height, camera_height)
