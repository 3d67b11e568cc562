"""Recorded depth sources that users already have: session folders, folders of 16-bit PNG and TUM
RGB-D folders (.npz stacks are in npz). All are seekable: frame_count frames, read(i) for any i
(modulo frame_count: playing loops)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from mirrorcore.depth.files import read_colour, read_depth_png
from mirrorcore.base.errors import FileFormatError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.camerafiles import load_open3d_json, load_opencv_yaml
from mirrorcore.base.jsonfile import read_json
from mirrorcore.io.fields import shown
from mirrorcore.io.session import Session
from mirrorcore.sources.base import DepthSource, Frame

CAMERA_SIDECAR = "camera.json"             # docs/DESIGN.md's camera object, beside a folder's PNGs
OPEN3D_SIDECAR = "intrinsic.json"          # Open3D's PinholeCameraIntrinsic JSON
TUM_DEPTH_SCALE = 1.0 / 5000.0             # TUM RGB-D: metres x 5000
TUM_MAX_COLOUR_GAP = 0.02                  # seconds; TUM's associate.py default
# seconds: TUM stamps are Unix times (1.3e9 in the benchmark); 1e10 is the year 2286
TUM_MAX_STAMP = 1e10
# frames per second that a TUM list's stamps may imply: depth cameras deliver 1 to 100
TUM_FPS_RANGE = (0.1, 1000.0)
PRESETS = {"kinect_v1": Intrinsics.kinect_v1, "primesense": Intrinsics.primesense}


class ImageSequenceSource(DepthSource):
    """Depth PNGs (uint16, depth_scale metres per unit) played in order, with timestamps and colour.

    Parameters
    ----------
    name : str
    intrinsics : Intrinsics
    paths : list of Path
        N depth images.
    timestamps : (N,) float64 array
        Seconds.
    colour_paths : list of (Path or None), optional
        N colour images (or None entries); None for none.
    fps : float

    Raises
    ------
    FileFormatError
        No depth frames.
    """

    def __init__(self, name: str, intrinsics: Intrinsics, paths: list[Path], timestamps: np.ndarray,
                 colour_paths: list[Path | None] | None = None, fps: float = 30.0):
        self.name, self.intrinsics, self.fps = name, intrinsics, float(fps)
        self.paths, self.colour_paths = list(paths), colour_paths
        self.timestamps = np.asarray(timestamps, float)
        self.frame_count = len(self.paths)
        if not self.frame_count:
            raise FileFormatError(f"{name}: no depth frames")

    def read(self, i: int) -> Frame:
        """Return frame i (see `DepthSource.read`).

        Parameters
        ----------
        i : int
            The frame's index.

        Returns
        -------
        Frame

        Raises
        ------
        MirrorscanError, FileFormatError
            With a one-line message.
        """
        i = self._wrap(i)
        depth = read_depth_png(self.paths[i], self.intrinsics.depth_scale, self.intrinsics.shape)
        colour = None if self.colour_paths is None else read_colour(self.colour_paths[i],
                                                                    self.intrinsics)
        return Frame(depth, float(self.timestamps[i]), colour)

    @property
    def has_colour(self) -> bool:
        """True when a colour image goes with at least one frame (frames without one read None)."""
        return self.colour_paths is not None and any(p is not None for p in self.colour_paths)


class SessionSource(ImageSequenceSource):
    """A session's recorded frames at `fps`, with its timestamps (else i / fps) and colour frames.

    Parameters
    ----------
    session : Session
    fps : float
    """

    def __init__(self, session: Session, fps: float = 30.0):
        self.session = session
        root = Path(session.root)
        stamps = session.timestamps
        if stamps is None:
            stamps = np.arange(len(session.frames)) / fps
        colour = None if session.colour_frames is None else [root / c
                                                             for c in session.colour_frames]
        super().__init__(f"session {shown(root.name)}", session.camera,
                         [root / f for f in session.frames],
                         np.asarray(stamps, float), colour, fps)

    def background(self) -> np.ndarray | None:
        """The session's background as (H, W) float32 metres, or None."""
        return self.session.read_background()


def open_png_folder(folder: str | Path, camera: Intrinsics | None = None,
                    depth_scale: float | None = None,
                    fps: float = 30.0) -> ImageSequenceSource:
    """Play a folder of 16-bit depth PNGs in name order at `fps` (timestamps i / fps).

    Parameters
    ----------
    folder : str or Path
    camera : Intrinsics, optional
        Else the folder's camera.json (docs/DESIGN.md's camera object) or intrinsic.json (Open3D).
    depth_scale : float, optional
        Metres per unit; else camera.json's, else 0.001.
    fps : float

    Returns
    -------
    ImageSequenceSource

    Raises
    ------
    FileFormatError
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise FileFormatError(f"{folder}: no such folder of depth PNGs")
    paths = sorted(folder.glob("*.png"))
    if not paths:
        raise FileFormatError(f"{folder}: no .png files")
    camera = camera or folder_camera(folder)
    if depth_scale is not None:
        camera = Intrinsics(**{**camera.to_dict(), "depth_scale": depth_scale})
    return ImageSequenceSource(f"PNG folder {shown(folder.name)}", camera, paths,
                               np.arange(len(paths)) / fps, fps=fps)


def folder_camera(folder: Path) -> Intrinsics:
    """Return the camera described beside a folder's images: camera.json, else intrinsic.json.

    Parameters
    ----------
    folder : Path

    Returns
    -------
    Intrinsics

    Raises
    ------
    FileFormatError
        Neither file, or a bad one.
    """
    if (folder / CAMERA_SIDECAR).is_file():
        path = folder / CAMERA_SIDECAR
        return Intrinsics.from_dict(read_json(path, "camera file"), str(path))
    if (folder / OPEN3D_SIDECAR).is_file():
        return load_open3d_json(folder / OPEN3D_SIDECAR)
    raise FileFormatError(f"{folder}: no {CAMERA_SIDECAR} or {OPEN3D_SIDECAR}; give the camera as "
                          f"?camera=FILE|{'|'.join(PRESETS)}")


def load_camera(value: str, depth_scale: float = 0.001) -> Intrinsics:
    """Load a camera from a preset name (kinect_v1, primesense) or a file.

    Parameters
    ----------
    value : str
        A preset, or a .yaml/.yml (OpenCV) or .json file (the session's camera object,
        docs/DESIGN.md, or Open3D's PinholeCameraIntrinsic).
    depth_scale : float
        Metres per unit, where the camera does not say.

    Returns
    -------
    Intrinsics

    Raises
    ------
    FileFormatError
    """
    if value in PRESETS:
        return Intrinsics(**{**PRESETS[value]().to_dict(), "depth_scale": depth_scale})
    path = Path(value)
    if path.suffix.lower() in (".yaml", ".yml"):
        return load_opencv_yaml(path, depth_scale)
    data = read_json(path, "camera file")
    if isinstance(data, dict) and "intrinsic_matrix" in data:
        return load_open3d_json(path, depth_scale)
    return Intrinsics.from_dict({"depth_scale": depth_scale, **data} if isinstance(data, dict)
                                else data, str(path))


def open_tum(folder: str | Path, camera: Intrinsics | None = None, depth_scale: float | None = None
             ) -> ImageSequenceSource:
    """Play a TUM RGB-D folder.

    depth.txt lists a timestamp and a path per line ('#' comments); depth PNGs are in metres x 5000;
    colour comes from rgb.txt associated by nearest timestamp (within 0.02 s, else none).

    Parameters
    ----------
    folder : str or Path
    camera : Intrinsics, optional
        Default TUM's recommended 525 / 525 / 319.5 / 239.5 at 640x480.
    depth_scale : float, optional
        Metres per unit.

    Returns
    -------
    ImageSequenceSource

    Raises
    ------
    FileFormatError
    """
    folder = Path(folder)
    depth_stamps, depth_paths = read_tum_list(folder / "depth.txt")
    scale = TUM_DEPTH_SCALE if depth_scale is None else depth_scale
    camera = Intrinsics(**{**(camera or Intrinsics.primesense()).to_dict(), "depth_scale": scale})
    colour = None
    if (folder / "rgb.txt").is_file():
        colour_stamps, colour_paths = read_tum_list(folder / "rgb.txt")
        nearest = nearest_stamps(colour_stamps, depth_stamps)
        ok = np.abs(colour_stamps[nearest] - depth_stamps) <= TUM_MAX_COLOUR_GAP
        colour = [colour_paths[j] if good else None for j, good in zip(nearest, ok)]
    fps = tum_rate(depth_stamps, folder / "depth.txt")
    return ImageSequenceSource(f"TUM {shown(folder.name)}", camera, depth_paths, depth_stamps,
                               colour, fps)


def tum_rate(stamps: np.ndarray, where: Path) -> float:
    """The frames per second that sorted TUM stamps imply (30 for a single frame).

    Parameters
    ----------
    stamps : (N,) float64 array
        Seconds, sorted.
    where : Path
        The list file, for the message.

    Returns
    -------
    float
        Within TUM_FPS_RANGE.

    Raises
    ------
    FileFormatError
        Naming the file, when the stamps imply a rate outside TUM_FPS_RANGE.
    """
    if len(stamps) < 2:
        return 30.0
    span = float(stamps[-1] - stamps[0])
    low, high = TUM_FPS_RANGE
    if not (len(stamps) - 1) / high <= span <= (len(stamps) - 1) / low:
        raise FileFormatError(f"{where}: {len(stamps)} frames over {span:g} s is not a camera's "
                              f"rate ({low:g} to {high:g} frames a second); check the timestamps")
    return (len(stamps) - 1) / span


def read_tum_list(path: Path) -> tuple[np.ndarray, list[Path]]:
    """Read a TUM list file.

    Parameters
    ----------
    path : Path

    Returns
    -------
    timestamps : (N,) float64 array
        Seconds, sorted, within ±TUM_MAX_STAMP.
    paths : list of Path
        N paths relative to the file's folder.

    Raises
    ------
    FileFormatError
        Naming the file and the line: no such file, a line that is not 'timestamp path', a
        timestamp beyond ±TUM_MAX_STAMP, or no frames.
    """
    if not path.is_file():
        raise FileFormatError(f"{path}: no such TUM list (a TUM RGB-D folder has depth.txt)")
    stamps, paths = [], []
    for n, line in enumerate(path.read_text().splitlines(), 1):
        parts = line.split()
        if not parts or parts[0].startswith("#"):
            continue
        if len(parts) < 2 or not _parses(parts[0]):
            raise FileFormatError(f"{path}: line {n} is not 'timestamp path'")
        if abs(float(parts[0])) > TUM_MAX_STAMP:
            raise FileFormatError(f"{path}: line {n}: timestamp {parts[0][:40]} is not seconds of "
                                  f"a recording (at most {TUM_MAX_STAMP:g})")
        stamps.append(float(parts[0]))
        paths.append(path.parent / parts[1])
    if not stamps:
        raise FileFormatError(f"{path}: lists no frames")
    order = np.argsort(stamps, kind="stable")
    return np.asarray(stamps)[order], [paths[i] for i in order]


def _parses(text: str) -> bool:
    """Whether `text` is a finite number."""
    try:
        return bool(np.isfinite(float(text)))
    except ValueError:
        return False


def nearest_stamps(stamps: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """Find the nearest of sorted timestamps to each query.

    Parameters
    ----------
    stamps : (n,) float array
        Sorted.
    queries : (m,) float array

    Returns
    -------
    (m,) int array
        Indices into `stamps`.
    """
    right = np.searchsorted(stamps, queries).clip(0, len(stamps) - 1)
    left = (right - 1).clip(0)
    return np.where(np.abs(stamps[left] - queries) <= np.abs(stamps[right] - queries), left, right)
